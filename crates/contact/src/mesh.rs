//! Closed triangle meshes as body shapes: STL (ASCII or binary) and OBJ files, validated, then
//! used through parry's point containment (pseudo-normal inside test of an oriented `TriMesh`).
//!
//! A lattice is only as good as its inside test, so a mesh must bound a solid: every edge is
//! shared by exactly two triangles that traverse it in opposite directions (closed and
//! consistently oriented), no triangle is degenerate, and no two triangles that share no vertex
//! intersect. Inward-facing meshes (negative enclosed volume) are flipped. Every failure says
//! which file, what is wrong, and where.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use parry3d_f64::math::{Pose, Vector};
use parry3d_f64::query::{intersection_test, PointQuery};
use parry3d_f64::shape::{TriMesh, TriMeshFlags, Triangle};

/// What is wrong with a mesh file.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}:{line}: {msg}")]
    Parse {
        path: PathBuf,
        line: usize,
        msg: String,
    },
    #[error("{path}: {msg}")]
    Invalid { path: PathBuf, msg: String },
}

/// A validated closed triangle mesh.
pub struct MeshShape {
    mesh: TriMesh,
    lo: [f64; 3],
    hi: [f64; 3],
    volume: f64,
    triangles: usize,
}

impl std::fmt::Debug for MeshShape {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MeshShape")
            .field("triangles", &self.triangles)
            .field("lo", &self.lo)
            .field("hi", &self.hi)
            .field("volume", &self.volume)
            .finish()
    }
}

fn v3(p: [f64; 3]) -> Vector {
    Vector::new(p[0], p[1], p[2])
}

impl MeshShape {
    /// Read an `.stl` or `.obj` file (by extension), scale its coordinates by `scale` (e.g. 1e-3
    /// for millimetres) and validate it.
    pub fn load(path: &Path, scale: f64) -> Result<Self, MeshError> {
        let bytes = std::fs::read(path).map_err(|source| MeshError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase());
        let (mut v, t) = match ext.as_deref() {
            Some("stl") => parse_stl(path, &bytes)?,
            Some("obj") => parse_obj(path, &bytes)?,
            _ => {
                return Err(MeshError::Invalid {
                    path: path.to_path_buf(),
                    msg: "unknown mesh format: give an .stl or .obj file".into(),
                })
            }
        };
        for p in &mut v {
            for c in p.iter_mut() {
                *c *= scale;
            }
        }
        Self::from_triangles(path, v, t)
    }

    /// Validate vertices and triangles (`path` names the source in errors).
    pub fn from_triangles(
        path: &Path,
        vertices: Vec<[f64; 3]>,
        triangles: Vec<[u32; 3]>,
    ) -> Result<Self, MeshError> {
        let bad = |msg: String| MeshError::Invalid {
            path: path.to_path_buf(),
            msg,
        };
        if triangles.is_empty() {
            return Err(bad("the mesh has no triangle".into()));
        }
        if let Some(p) = vertices.iter().find(|p| p.iter().any(|c| !c.is_finite())) {
            return Err(bad(format!("vertex {p:?} is not finite")));
        }
        // Merge vertices with identical coordinates (STL repeats them per facet).
        let mut index: HashMap<[u64; 3], u32> = HashMap::new();
        let mut verts: Vec<[f64; 3]> = Vec::new();
        let mut remap = Vec::with_capacity(vertices.len());
        for p in &vertices {
            let key = p.map(|c| (c + 0.0).to_bits());
            let id = *index.entry(key).or_insert_with(|| {
                verts.push(*p);
                (verts.len() - 1) as u32
            });
            remap.push(id);
        }
        let mut tris = Vec::with_capacity(triangles.len());
        for (k, t) in triangles.iter().enumerate() {
            if t.iter().any(|&i| i as usize >= vertices.len()) {
                return Err(bad(format!(
                    "triangle {k} names a vertex that does not exist"
                )));
            }
            let t = t.map(|i| remap[i as usize]);
            let (a, b, c) = (
                verts[t[0] as usize],
                verts[t[1] as usize],
                verts[t[2] as usize],
            );
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || cross_norm(a, b, c) == 0.0 {
                return Err(bad(format!(
                    "triangle {k} is degenerate (zero area) at {a:?}: remove it or repair the mesh"
                )));
            }
            tris.push(t);
        }
        // Closed and consistently oriented: each directed edge once, its reverse once.
        let mut directed: HashMap<(u32, u32), usize> = HashMap::new();
        for (k, t) in tris.iter().enumerate() {
            for e in 0..3 {
                let (a, b) = (t[e], t[(e + 1) % 3]);
                if directed.insert((a, b), k).is_some() {
                    return Err(bad(format!(
                        "the edge from {:?} to {:?} is used twice in the same direction: the \
                         triangles are not consistently oriented, or more than two meet at an edge",
                        verts[a as usize], verts[b as usize]
                    )));
                }
            }
        }
        let open: Vec<(u32, u32)> = directed
            .keys()
            .filter(|&&(a, b)| !directed.contains_key(&(b, a)))
            .cloned()
            .collect();
        if let Some(&(a, b)) = open.iter().min() {
            return Err(bad(format!(
                "the mesh is open: {} edges have a triangle on one side only, e.g. from {:?} to \
                 {:?}; close the holes (a body must be watertight)",
                open.len(),
                verts[a as usize],
                verts[b as usize]
            )));
        }
        // Outward orientation: positive enclosed volume (divergence theorem).
        let volume: f64 = tris
            .iter()
            .map(|t| {
                let (a, b, c) = (
                    verts[t[0] as usize],
                    verts[t[1] as usize],
                    verts[t[2] as usize],
                );
                (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                    + a[2] * (b[0] * c[1] - b[1] * c[0]))
                    / 6.0
            })
            .sum();
        if volume < 0.0 {
            for t in &mut tris {
                t.swap(1, 2);
            }
        }
        self_intersections(&verts, &tris).map_err(bad)?;
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in &verts {
            for c in 0..3 {
                lo[c] = lo[c].min(p[c]);
                hi[c] = hi[c].max(p[c]);
            }
        }
        let n = tris.len();
        let mesh = TriMesh::with_flags(
            verts.iter().map(|&p| v3(p)).collect(),
            tris,
            TriMeshFlags::ORIENTED | TriMeshFlags::HALF_EDGE_TOPOLOGY,
        )
        .map_err(|e| bad(format!("parry refused the mesh: {e:?}")))?;
        Ok(MeshShape {
            mesh,
            lo,
            hi,
            volume: volume.abs(),
            triangles: n,
        })
    }

    /// True when `p` lies inside the solid.
    pub fn contains(&self, p: [f64; 3]) -> bool {
        if (0..3).any(|c| p[c] < self.lo[c] || p[c] > self.hi[c]) {
            return false;
        }
        self.mesh.contains_local_point(v3(p))
    }

    /// Axis-aligned bounds.
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        (self.lo, self.hi)
    }

    /// Enclosed volume (m^3).
    pub fn volume(&self) -> f64 {
        self.volume
    }

    /// The parry mesh (oriented, with pseudo-normals), for rigid bodies.
    pub fn trimesh(&self) -> &TriMesh {
        &self.mesh
    }

    /// Number of triangles.
    pub fn triangles(&self) -> usize {
        self.triangles
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross_norm(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    let (u, v) = (sub(b, a), sub(c, a));
    let x = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt()
}

/// Find two triangles that share no vertex and intersect (uniform-grid broad phase on their
/// bounding boxes, parry's exact convex test for the candidates).
fn self_intersections(verts: &[[f64; 3]], tris: &[[u32; 3]]) -> Result<(), String> {
    let n = tris.len();
    let boxes: Vec<([f64; 3], [f64; 3])> = tris
        .iter()
        .map(|t| {
            let mut lo = [f64::INFINITY; 3];
            let mut hi = [f64::NEG_INFINITY; 3];
            for &i in t {
                for c in 0..3 {
                    lo[c] = lo[c].min(verts[i as usize][c]);
                    hi[c] = hi[c].max(verts[i as usize][c]);
                }
            }
            (lo, hi)
        })
        .collect();
    let mut glo = [f64::INFINITY; 3];
    let mut ghi = [f64::NEG_INFINITY; 3];
    let mut mean = 0.0;
    for (lo, hi) in &boxes {
        for c in 0..3 {
            glo[c] = glo[c].min(lo[c]);
            ghi[c] = ghi[c].max(hi[c]);
            mean += (hi[c] - lo[c]) / (3 * n) as f64;
        }
    }
    let cell = mean.max(1e-12 * (0..3).map(|c| ghi[c] - glo[c]).fold(0.0, f64::max));
    let cell_of = |x: f64, c: usize| ((x - glo[c]) / cell).floor() as i64;
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    for (k, (lo, hi)) in boxes.iter().enumerate() {
        let (a, b) = (
            [0, 1, 2].map(|c| cell_of(lo[c], c)),
            [0, 1, 2].map(|c| cell_of(hi[c], c)),
        );
        // Very large triangles span many cells; cap the work by clamping to 64 cells per axis.
        for z in a[2]..=b[2].min(a[2] + 64) {
            for y in a[1]..=b[1].min(a[1] + 64) {
                for x in a[0]..=b[0].min(a[0] + 64) {
                    grid.entry([x, y, z]).or_default().push(k as u32);
                }
            }
        }
    }
    let tri = |k: usize| {
        let t = tris[k];
        Triangle::new(
            v3(verts[t[0] as usize]),
            v3(verts[t[1] as usize]),
            v3(verts[t[2] as usize]),
        )
    };
    let mut checked: std::collections::HashSet<(u32, u32)> = std::collections::HashSet::new();
    let mut keys: Vec<&[i64; 3]> = grid.keys().collect();
    keys.sort();
    for key in keys {
        let list = &grid[key];
        for (x, &i) in list.iter().enumerate() {
            for &j in &list[x + 1..] {
                let (i, j) = (i.min(j), i.max(j));
                let (ti, tj) = (tris[i as usize], tris[j as usize]);
                if ti.iter().any(|v| tj.contains(v)) || !checked.insert((i, j)) {
                    continue;
                }
                let (bi, bj) = (&boxes[i as usize], &boxes[j as usize]);
                if (0..3).any(|c| bi.1[c] < bj.0[c] || bj.1[c] < bi.0[c]) {
                    continue;
                }
                let hit = intersection_test(
                    &Pose::IDENTITY,
                    &tri(i as usize),
                    &Pose::IDENTITY,
                    &tri(j as usize),
                )
                .map(|r| r.intersecting)
                .unwrap_or(false);
                if hit {
                    return Err(format!(
                        "the mesh intersects itself: triangles {i} and {j} cross near {:?}",
                        verts[ti[0] as usize]
                    ));
                }
            }
        }
    }
    Ok(())
}

/// Vertices and triangles as read from a file, before validation.
type Soup = (Vec<[f64; 3]>, Vec<[u32; 3]>);

fn parse_obj(path: &Path, bytes: &[u8]) -> Result<Soup, MeshError> {
    let text = String::from_utf8_lossy(bytes);
    let err = |line: usize, msg: String| MeshError::Parse {
        path: path.to_path_buf(),
        line,
        msg,
    };
    let mut v = Vec::new();
    let mut t = Vec::new();
    for (ln, line) in text.lines().enumerate() {
        let line_no = ln + 1;
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => {
                let c: Vec<f64> = it
                    .take(3)
                    .map(|s| s.parse::<f64>())
                    .collect::<Result<_, _>>()
                    .map_err(|e| err(line_no, format!("vertex coordinate: {e}")))?;
                if c.len() != 3 {
                    return Err(err(
                        line_no,
                        "a vertex needs three coordinates: v X Y Z".into(),
                    ));
                }
                v.push([c[0], c[1], c[2]]);
            }
            Some("f") => {
                let mut idx = Vec::new();
                for tok in it {
                    let first = tok.split('/').next().unwrap_or("");
                    let i: i64 = first
                        .parse()
                        .map_err(|e| err(line_no, format!("face index \"{tok}\": {e}")))?;
                    // OBJ counts from 1; negative indices count back from the last vertex.
                    let abs = if i > 0 { i - 1 } else { v.len() as i64 + i };
                    if abs < 0 || abs >= v.len() as i64 {
                        return Err(err(line_no, format!("face index {i} names no vertex")));
                    }
                    idx.push(abs as u32);
                }
                if idx.len() < 3 {
                    return Err(err(line_no, "a face needs at least three vertices".into()));
                }
                for k in 1..idx.len() - 1 {
                    t.push([idx[0], idx[k], idx[k + 1]]);
                }
            }
            _ => {}
        }
    }
    Ok((v, t))
}

fn parse_stl(path: &Path, bytes: &[u8]) -> Result<Soup, MeshError> {
    let binary_len = |n: usize| 84 + 50 * n;
    let is_binary = bytes.len() >= 84 && {
        let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as usize;
        binary_len(n) == bytes.len()
    };
    if is_binary {
        let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as usize;
        let mut v = Vec::with_capacity(3 * n);
        let mut t = Vec::with_capacity(n);
        for k in 0..n {
            let base = 84 + 50 * k + 12; // skip the normal
            for m in 0..3 {
                let mut p = [0.0; 3];
                for c in 0..3 {
                    let o = base + 12 * m + 4 * c;
                    p[c] = f32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]])
                        as f64;
                }
                v.push(p);
            }
            let b = (3 * k) as u32;
            t.push([b, b + 1, b + 2]);
        }
        return Ok((v, t));
    }
    let text = String::from_utf8_lossy(bytes);
    if !text.trim_start().starts_with("solid") {
        return Err(MeshError::Parse {
            path: path.to_path_buf(),
            line: 1,
            msg: "neither ASCII STL (starts with \"solid\") nor binary STL (84 + 50 n bytes)"
                .into(),
        });
    }
    let mut v = Vec::new();
    let mut t = Vec::new();
    let mut facet = Vec::new();
    for (ln, line) in text.lines().enumerate() {
        let mut it = line.split_whitespace();
        match it.next() {
            Some("vertex") => {
                let c: Vec<f64> = it
                    .map(|s| s.parse::<f64>())
                    .collect::<Result<_, _>>()
                    .map_err(|e| MeshError::Parse {
                        path: path.to_path_buf(),
                        line: ln + 1,
                        msg: format!("vertex coordinate: {e}"),
                    })?;
                if c.len() != 3 {
                    return Err(MeshError::Parse {
                        path: path.to_path_buf(),
                        line: ln + 1,
                        msg: "a vertex needs three coordinates".into(),
                    });
                }
                facet.push(v.len() as u32);
                v.push([c[0], c[1], c[2]]);
            }
            Some("endfacet") => {
                if facet.len() != 3 {
                    return Err(MeshError::Parse {
                        path: path.to_path_buf(),
                        line: ln + 1,
                        msg: format!("a facet has {} vertices; STL facets have 3", facet.len()),
                    });
                }
                t.push([facet[0], facet[1], facet[2]]);
                facet.clear();
            }
            _ => {}
        }
    }
    Ok((v, t))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cube [0, s]^3 as 12 outward triangles.
    pub fn cube(s: f64) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let v: Vec<[f64; 3]> = (0..8)
            .map(|i| {
                [
                    (i & 1) as f64 * s,
                    ((i >> 1) & 1) as f64 * s,
                    ((i >> 2) & 1) as f64 * s,
                ]
            })
            .collect();
        let quads = [
            [0, 2, 3, 1], // z = 0, normal -z
            [4, 5, 7, 6], // z = s
            [0, 1, 5, 4], // y = 0
            [2, 6, 7, 3], // y = s
            [0, 4, 6, 2], // x = 0
            [1, 3, 7, 5], // x = s
        ];
        let mut t = Vec::new();
        for q in quads {
            t.push([q[0], q[1], q[2]]);
            t.push([q[0], q[2], q[3]]);
        }
        (v, t)
    }

    #[test]
    fn cube_contains_inside_points_either_orientation() {
        let (v, t) = cube(2.0);
        let m = MeshShape::from_triangles(Path::new("cube"), v.clone(), t.clone()).unwrap();
        assert!((m.volume() - 8.0).abs() < 1e-12);
        assert!(m.contains([1.0, 1.0, 1.0]));
        assert!(m.contains([0.1, 1.9, 0.05]));
        assert!(!m.contains([2.1, 1.0, 1.0]));
        assert!(!m.contains([-0.01, 1.0, 1.0]));
        let flipped: Vec<[u32; 3]> = t.iter().map(|x| [x[0], x[2], x[1]]).collect();
        let m = MeshShape::from_triangles(Path::new("cube"), v, flipped).unwrap();
        assert!(m.contains([1.0, 1.0, 1.0]) && !m.contains([3.0, 1.0, 1.0]));
    }

    #[test]
    fn open_inconsistent_and_self_intersecting_meshes_are_refused() {
        let (v, mut t) = cube(1.0);
        t.pop();
        let e = MeshShape::from_triangles(Path::new("open.stl"), v.clone(), t).unwrap_err();
        assert!(e.to_string().contains("open.stl: the mesh is open"), "{e}");
        let (_, mut t) = cube(1.0);
        t[0] = [t[0][0], t[0][2], t[0][1]];
        let e = MeshShape::from_triangles(Path::new("flip.obj"), v.clone(), t).unwrap_err();
        assert!(e.to_string().contains("same direction"), "{e}");
        // Two cubes, the second pushed into the first: closed and oriented, but crossing.
        let (v1, t1) = cube(1.0);
        let mut v2: Vec<[f64; 3]> = v1
            .iter()
            .map(|p| [p[0] + 0.5, p[1] + 0.3, p[2] + 0.2])
            .collect();
        let mut v = v1.clone();
        v.append(&mut v2);
        let mut t = t1.clone();
        t.extend(t1.iter().map(|x| x.map(|i| i + 8)));
        let e = MeshShape::from_triangles(Path::new("two.stl"), v, t).unwrap_err();
        assert!(e.to_string().contains("intersects itself"), "{e}");
    }

    #[test]
    fn stl_ascii_binary_and_obj_read_the_same_cube() {
        let (v, t) = cube(1.0);
        let dir = std::env::temp_dir().join(format!("hooke-mesh-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut ascii = String::from("solid cube\n");
        let mut bin = vec![0u8; 80];
        bin.extend_from_slice(&(t.len() as u32).to_le_bytes());
        let mut obj = String::new();
        for p in &v {
            obj.push_str(&format!("v {} {} {}\n", p[0], p[1], p[2]));
        }
        for tri in &t {
            ascii.push_str("facet normal 0 0 0\nouter loop\n");
            bin.extend_from_slice(&[0u8; 12]);
            for &i in tri {
                let p = v[i as usize];
                ascii.push_str(&format!("vertex {} {} {}\n", p[0], p[1], p[2]));
                for c in p {
                    bin.extend_from_slice(&(c as f32).to_le_bytes());
                }
            }
            bin.extend_from_slice(&[0u8; 2]);
            ascii.push_str("endloop\nendfacet\n");
            obj.push_str(&format!("f {} {} {}\n", tri[0] + 1, tri[1] + 1, tri[2] + 1));
        }
        ascii.push_str("endsolid cube\n");
        for (name, bytes) in [
            ("a.stl", ascii.into_bytes()),
            ("b.stl", bin),
            ("c.obj", obj.into_bytes()),
        ] {
            let p = dir.join(name);
            std::fs::write(&p, bytes).unwrap();
            let m = MeshShape::load(&p, 2.0).unwrap();
            assert!((m.volume() - 8.0).abs() < 1e-9, "{name}");
            assert!(m.contains([1.0, 1.5, 0.5]) && !m.contains([1.0, 2.5, 0.5]));
        }
        let bad = dir.join("bad.obj");
        std::fs::write(&bad, "v 0 0 0\nv 1 0\n").unwrap();
        let e = MeshShape::load(&bad, 1.0).unwrap_err();
        assert!(e.to_string().contains("bad.obj:2:"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
