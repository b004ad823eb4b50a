//! Bodies and regions: the shapes a lattice is filled into, and the node sets boundary
//! conditions act on. Shared by the [`crate::Builder`] and the case files.

use hooke_contact::MeshShape;
use hooke_core::random::{Curved, RandomSpec};
use hooke_core::{Body, Lattice, LatticeKind, Real, Vector};

use crate::builder::BuildError;

/// A primitive of a body's geometry (m). In 2D bodies z is ignored.
#[derive(Clone, Debug)]
pub enum Shape {
    /// An axis-aligned box.
    Box { lo: Vector, hi: Vector },
    /// A sphere (a disk in 2D).
    Ball { c: Vector, r: Real },
    /// A cylinder along `axis` (0, 1, 2), `half` its half-length.
    Cylinder {
        c: Vector,
        axis: usize,
        r: Real,
        half: Real,
    },
    /// A polygon in the x-y plane, extruded over `z` in 3D.
    Polygon {
        pts: Vec<(Real, Real)>,
        z: Option<(Real, Real)>,
    },
    /// A closed triangle mesh (STL/OBJ).
    Mesh(std::sync::Arc<MeshShape>),
    /// Non-overlapping balls (spheres; disks in 2D): random inclusions
    /// ([`crate::inclusions::place`]).
    Balls(std::sync::Arc<crate::inclusions::Balls>),
}

impl Shape {
    /// An axis-aligned box from two corners.
    pub fn cuboid(lo: [Real; 3], hi: [Real; 3]) -> Shape {
        Shape::Box {
            lo: Vector::from(lo),
            hi: Vector::from(hi),
        }
    }

    /// A sphere (disk in 2D).
    pub fn ball(center: [Real; 3], radius: Real) -> Shape {
        Shape::Ball {
            c: Vector::from(center),
            r: radius,
        }
    }

    /// Bounding box.
    pub fn bounds(&self) -> (Vector, Vector) {
        match self {
            Shape::Box { lo, hi } => (*lo, *hi),
            Shape::Ball { c, r } => (c - Vector::repeat(*r), c + Vector::repeat(*r)),
            Shape::Cylinder { c, axis, r, half } => {
                let mut d = Vector::repeat(*r);
                d[*axis] = *half;
                (c - d, c + d)
            }
            Shape::Polygon { pts, z } => {
                let (z0, z1) = z.unwrap_or((0.0, 0.0));
                let x0 = pts.iter().map(|p| p.0).fold(Real::INFINITY, Real::min);
                let x1 = pts.iter().map(|p| p.0).fold(Real::NEG_INFINITY, Real::max);
                let y0 = pts.iter().map(|p| p.1).fold(Real::INFINITY, Real::min);
                let y1 = pts.iter().map(|p| p.1).fold(Real::NEG_INFINITY, Real::max);
                (Vector::new(x0, y0, z0), Vector::new(x1, y1, z1))
            }
            Shape::Mesh(m) => {
                let (lo, hi) = m.bounds();
                (Vector::from(lo), Vector::from(hi))
            }
            Shape::Balls(b) => b.bounds(),
        }
    }

    /// `p` inside, with the surface moved out by `tol` (negative: in).
    pub fn contains(&self, p: Vector, tol: Real, dim: usize) -> bool {
        match self {
            // The mesh's own inside test; `tol` (1e-9 a) is below its resolution.
            Shape::Mesh(m) => m.contains([p.x, p.y, p.z]),
            Shape::Balls(b) => b.contains(p, tol),
            Shape::Box { lo, hi } => (0..dim).all(|c| p[c] >= lo[c] - tol && p[c] <= hi[c] + tol),
            Shape::Ball { c, r } => {
                let mut d = p - c;
                if dim == 2 {
                    d.z = 0.0;
                }
                d.norm() <= r + tol
            }
            Shape::Cylinder { c, axis, r, half } => {
                let mut d = p - c;
                let along = d[*axis];
                d[*axis] = 0.0;
                if dim == 2 {
                    d.z = 0.0;
                }
                along.abs() <= half + tol && d.norm() <= r + tol
            }
            Shape::Polygon { pts, z } => {
                if let (Some((z0, z1)), 3) = (z, dim) {
                    if p.z < z0 - tol || p.z > z1 + tol {
                        return false;
                    }
                }
                // Crossing-number test; points within tol of an edge count as on the edge.
                let mut inside = false;
                let mut near = false;
                for k in 0..pts.len() {
                    let (a, b) = (pts[k], pts[(k + 1) % pts.len()]);
                    if (a.1 > p.y) != (b.1 > p.y)
                        && p.x < a.0 + (p.y - a.1) * (b.0 - a.0) / (b.1 - a.1)
                    {
                        inside = !inside;
                    }
                    let (ex, ey) = (b.0 - a.0, b.1 - a.1);
                    let len2 = ex * ex + ey * ey;
                    let t = (((p.x - a.0) * ex + (p.y - a.1) * ey) / len2).clamp(0.0, 1.0);
                    let (dx, dy) = (p.x - a.0 - t * ex, p.y - a.1 - t * ey);
                    near |= (dx * dx + dy * dy).sqrt() <= tol.abs();
                }
                if tol >= 0.0 {
                    inside || near
                } else {
                    inside && !near
                }
            }
        }
    }
}

/// A body: a box, or the union of `add` shapes less the `subtract` shapes.
#[derive(Clone, Debug, Default)]
pub struct Solid {
    pub bbox: Option<(Vector, Vector)>,
    pub add: Vec<Shape>,
    pub subtract: Vec<Shape>,
}

impl Solid {
    /// The box from `lo` to `hi` (m).
    pub fn cuboid(lo: [Real; 3], hi: [Real; 3]) -> Self {
        Solid {
            bbox: Some((Vector::from(lo), Vector::from(hi))),
            ..Default::default()
        }
    }

    /// The bounding box the lattice is laid over.
    pub fn bounds(&self, dim: usize) -> Result<(Vector, Vector), BuildError> {
        let (lo, hi) =
            match (&self.bbox, self.add.is_empty()) {
                (Some((lo, hi)), true) => (*lo, *hi),
                (None, false) => {
                    let mut lo = Vector::repeat(Real::INFINITY);
                    let mut hi = Vector::repeat(Real::NEG_INFINITY);
                    for sh in &self.add {
                        let (l, h) = sh.bounds();
                        lo = lo.inf(&l);
                        hi = hi.sup(&h);
                    }
                    if dim == 2 {
                        lo.z = 0.0;
                        hi.z = 0.0;
                    }
                    (lo, hi)
                }
                (Some(_), false) => {
                    return Err(BuildError::new(
                        "geometry",
                        "give the body as geometry.box or as [[geometry.add]] shapes, not both",
                    ))
                }
                (None, true) => return Err(BuildError::new(
                    "geometry",
                    "give the body: box = { min = [...], max = [...] }, or [[geometry.add]] shapes",
                )),
            };
        if (0..dim).any(|c| hi[c] - lo[c] <= 0.0) {
            return Err(BuildError::new(
                "geometry.box",
                "the box is empty: every max coordinate must exceed its min",
            ));
        }
        Ok((lo, hi))
    }

    /// The curved pieces of the body's boundary, for a random lattice to put nodes on: the
    /// surfaces of its spheres and cylinders, added or subtracted (each is trimmed to where it
    /// bounds the body while it is sampled). Boxes' faces off the bounding box, polygons' walls
    /// and meshes are not among them: random nodes there lie inside the body.
    pub fn curved(&self, dim: usize) -> Vec<Curved<'static>> {
        let mut out = Vec::new();
        for sh in self.add.iter().chain(&self.subtract) {
            match *sh {
                Shape::Ball { c, r } if dim == 3 => out.push(Curved::sphere(c.into(), r)),
                Shape::Ball { c, r } => out.push(Curved::circle(2, [c.x, c.y, 0.0], 2, r)),
                Shape::Cylinder { c, axis, r, half } if dim == 3 => {
                    let c: [Real; 3] = c.into();
                    out.push(Curved::cylinder_wall(c, axis, r, half));
                    for s in [-1.0, 1.0] {
                        let mut end = c;
                        end[axis] += s * half;
                        out.push(Curved::circle(3, end, axis, r));
                        out.push(Curved::plane(end, axis, vec![end]));
                    }
                }
                Shape::Cylinder { c, axis: 2, r, .. } => {
                    out.push(Curved::circle(2, [c.x, c.y, 0.0], 2, r))
                }
                _ => {}
            }
        }
        out
    }

    /// Whether `p` is in the body, surfaces moved out by `tol`.
    pub fn contains(&self, p: Vector, tol: Real, dim: usize) -> bool {
        (self.add.is_empty() || self.add.iter().any(|s| s.contains(p, tol, dim)))
            && !self.subtract.iter().any(|s| s.contains(p, -tol, dim))
    }
}

/// About 600 bytes per node at peak: 4e7 nodes is what a 24 GiB machine holds.
pub const MAX_NODES: Real = 4e7;

/// Fill `geometry` with a lattice of `kind` and spacing `a` (2D: plate thickness `h`).
///
/// Regular lattices fill the bounding box and keep the nodes inside the body (a node within
/// 1e-9 a of a surface counts as inside, so faces placed on a node plane keep their nodes);
/// random lattices are sampled in place, conforming to the box faces.
pub fn fill_lattice(
    kind: LatticeKind,
    a: Real,
    h: Real,
    random: RandomSpec,
    geometry: &Solid,
) -> Result<Lattice, BuildError> {
    let dim = kind.dim();
    let (lo, hi) = geometry.bounds(dim)?;
    let size = hi - lo;
    // Counted in floating point first: a mistyped spacing must give an error, not an overflow.
    let countf = |len: Real, pitch: Real| (len / pitch + 1e-9).floor() + 1.0;
    let count = |len: Real, pitch: Real| countf(len, pitch) as usize;
    let total = match kind {
        LatticeKind::Cubic => countf(size.x, a) * countf(size.y, a) * countf(size.z, a),
        LatticeKind::Hex => countf(size.x, a) * countf(size.y, a * 3f64.sqrt() / 2.0),
        LatticeKind::Random2d => countf(size.x, a) * countf(size.y, a),
        LatticeKind::Random3d => countf(size.x, a) * countf(size.y, a) * countf(size.z, a),
    };
    if !(total <= MAX_NODES) {
        return Err(BuildError::new("lattice.spacing", format!("{total:.3e} nodes would not fit in memory (at most {MAX_NODES:e}); use a larger spacing or --scale below 1")));
    }
    let geo = |e: hooke_core::Error| BuildError::new("geometry", e.to_string());
    let mut lattice = match kind {
        LatticeKind::Cubic => {
            let n = [count(size.x, a), count(size.y, a), count(size.z, a)];
            if n.iter().any(|&v| v < 2) {
                return Err(BuildError::new("geometry", format!("the box holds {n:?} nodes at spacing {a:e} m; make it larger or the spacing smaller")));
            }
            Lattice::cubic_box(n, a).map_err(geo)?
        }
        LatticeKind::Hex => {
            let (nx, rows) = (count(size.x, a), count(size.y, a * 3f64.sqrt() / 2.0));
            if nx < 2 || rows < 2 {
                return Err(BuildError::new("geometry", format!("the box holds {nx} x {rows} nodes at spacing {a:e} m; make it larger or the spacing smaller")));
            }
            Lattice::hex_box(nx, rows, a, h).map_err(geo)?
        }
        LatticeKind::Random2d | LatticeKind::Random3d => {
            // Sampled in place: nodes inside the body only, simplices bridging a hole or a notch
            // dropped (`hooke_core::random`).
            let tol = 1e-9 * a;
            let inside = |p: [Real; 3]| geometry.contains(Vector::new(p[0], p[1], p[2]), tol, dim);
            let curved = geometry.curved(dim);
            return Lattice::random_conforming(
                dim,
                lo.into(),
                hi.into(),
                a,
                h,
                random,
                &inside,
                &curved,
            )
            .map_err(geo);
        }
    };
    for i in 0..lattice.len() {
        lattice.pos.x_mut()[i] += lo.x;
        lattice.pos.y_mut()[i] += lo.y;
        if dim == 3 {
            lattice.pos.z_mut()[i] += lo.z;
        }
    }
    if !geometry.add.is_empty() || !geometry.subtract.is_empty() {
        let tol = 1e-9 * a;
        lattice = lattice
            .retain(|p| geometry.contains(p, tol, dim))
            .map_err(geo)?;
    }
    Ok(lattice)
}

/// A face of the body's bounding box: the nodes at the extreme of one coordinate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Face {
    pub axis: usize,
    pub high: bool,
}

impl Face {
    /// `"x-"`, `"x+"`, `"y-"`, `"y+"`, `"z-"`, `"z+"`.
    pub fn parse(s: &str, dim: usize) -> Option<Face> {
        let (axis, high) = match s {
            "x-" => (0, false),
            "x+" => (0, true),
            "y-" => (1, false),
            "y+" => (1, true),
            "z-" if dim == 3 => (2, false),
            "z+" if dim == 3 => (2, true),
            _ => return None,
        };
        Some(Face { axis, high })
    }
}

/// A set of nodes that boundary conditions act on.
#[derive(Clone, Debug)]
pub enum Region {
    /// The nodes on a face of the body (within 1e-6 a; a hexagonal lattice's x faces are
    /// zigzag, so within 0.51 a there).
    Face(Face),
    /// The nodes in an axis-aligned box (m), faces included.
    Box { lo: Vector, hi: Vector },
    /// The nodes within `tolerance` (default a/2) of the plane `x_axis = at`.
    Plane {
        axis: usize,
        at: Real,
        tolerance: Option<Real>,
    },
    /// The nodes inside a shape.
    Inside(Shape),
    /// Every node.
    All,
    /// Given nodes.
    Nodes(Vec<u32>),
}

impl Region {
    /// The nodes of `body` in the region, in increasing order.
    pub fn select(&self, body: &Body) -> Vec<u32> {
        let c = |f: Face| body.lattice.pos.comp(f.axis);
        let extreme = |f: Face| {
            if f.high {
                c(f).iter().cloned().fold(Real::NEG_INFINITY, Real::max)
            } else {
                c(f).iter().cloned().fold(Real::INFINITY, Real::min)
            }
        };
        self.select_where(&body.lattice, &extreme, &Some)
    }

    /// [`Region::select`] on a piece of a body ([`hooke_core::team::Piece`]): `extreme(face)`
    /// is the whole body's extreme coordinate on that face, and `global(i)` the body's index
    /// of the piece's node `i` (`None` for a dummy node, which no region holds). The nodes are
    /// the piece's, in increasing order.
    pub fn select_where(
        &self,
        lat: &hooke_core::Lattice,
        extreme: &dyn Fn(Face) -> Real,
        global: &dyn Fn(u32) -> Option<u32>,
    ) -> Vec<u32> {
        let (dim, a, n) = (lat.dim(), lat.spacing, lat.len() as u32);
        let real = (0..n).filter(|&i| global(i).is_some());
        match self {
            Region::Face(f) => {
                let c = lat.pos.comp(f.axis);
                let ext = extreme(*f);
                // A hex lattice's odd rows are shifted by a/2: its x faces are zigzag.
                let tol = if lat.kind == LatticeKind::Hex && f.axis == 0 {
                    0.51 * a
                } else {
                    1e-6 * a
                };
                real.filter(|&i| (c[i as usize] - ext).abs() <= tol)
                    .collect()
            }
            Region::Box { lo, hi } => real
                .filter(|&i| {
                    let p = lat.pos.get(i as usize);
                    (0..dim).all(|c| p[c] >= lo[c] && p[c] <= hi[c])
                })
                .collect(),
            Region::Plane {
                axis,
                at,
                tolerance,
            } => {
                let tol = tolerance.unwrap_or(0.5 * a);
                real.filter(|&i| (lat.pos.comp(*axis)[i as usize] - at).abs() <= tol)
                    .collect()
            }
            Region::Inside(s) => real
                .filter(|&i| s.contains(lat.pos.get(i as usize), 1e-9 * a, dim))
                .collect(),
            Region::All => real.collect(),
            Region::Nodes(v) => {
                let mut v: Vec<u32> = v.to_vec();
                v.sort_unstable();
                v.dedup();
                real.filter(|&i| global(i).is_some_and(|g| v.binary_search(&g).is_ok()))
                    .collect()
            }
        }
    }
}

/// The nodal loads that apply the traction `t` (Pa) on the face of `nodes` whose outward
/// normal is along `normal`, scaled in time by `scale`: each node carries its share of the face,
/// its boundary area on random lattices, its cell volume over the lattice pitch along the normal
/// on regular ones (a^2 for a cubic face; a h along a hex row, (sqrt(3)/2) a h across). On a
/// cell-weighted regular body (`weighted`) the face is the one between its outer node lines,
/// as the body's material is: the trapezoid rule, a node at either end of the face along an
/// axis in its plane carries half its share (a quarter at a corner of a cubic face), so the
/// loads add up to the traction times that face's area.
pub fn traction_loads(
    body: &Body,
    nodes: &[u32],
    t: Vector,
    normal: usize,
    scale: hooke_core::loading::TimeFunction,
    weighted: bool,
) -> Vec<hooke_core::loading::Load> {
    use hooke_core::loading::Load;
    let lat = &body.lattice;
    assert!(
        !lat.is_shed(),
        "tractions spread over a body whose boundary areas were shed (Lattice::shed_setup): spread them before shedding"
    );
    match &lat.cells {
        Some(cells) => nodes
            .iter()
            .filter_map(|&i| {
                let area = cells.surface[i as usize][normal].abs();
                (area > 0.0).then(|| Load {
                    nodes: vec![i],
                    force: t * area,
                    scale: scale.clone(),
                })
            })
            .collect(),
        None => {
            let a = lat.spacing;
            let pitch = match (lat.kind, normal) {
                (LatticeKind::Hex, 1) => a * 3f64.sqrt() / 2.0,
                _ => a,
            };
            let cell_area = lat.cell_volume / pitch;
            if !weighted {
                return vec![Load {
                    nodes: nodes.to_vec(),
                    force: t * cell_area,
                    scale,
                }];
            }
            // Each node's share: halved per in-plane axis along which it is at an end.
            let tol = 1e-6 * a;
            let extent = |c: usize| {
                nodes
                    .iter()
                    .fold((Real::INFINITY, -Real::INFINITY), |(l, h), &j| {
                        let x = lat.pos.comp(c)[j as usize];
                        (l.min(x), h.max(x))
                    })
            };
            let ends: Vec<(usize, Real, Real)> = (0..lat.dim())
                .filter(|&c| c != normal)
                .map(|c| (c, extent(c)))
                .filter(|&(_, (lo, hi))| hi - lo > tol)
                .map(|(c, (lo, hi))| (c, lo, hi))
                .collect();
            let share = |i: u32| -> Real {
                ends.iter()
                    .map(|&(c, lo, hi)| {
                        let x = lat.pos.comp(c)[i as usize];
                        if (x - lo).abs() < tol || (hi - x).abs() < tol {
                            0.5
                        } else {
                            1.0
                        }
                    })
                    .product()
            };
            let mut groups: Vec<(Real, Vec<u32>)> = Vec::new();
            for &i in nodes {
                let f = share(i);
                match groups.iter_mut().find(|(g, _)| *g == f) {
                    Some((_, v)) => v.push(i),
                    None => groups.push((f, vec![i])),
                }
            }
            groups
                .into_iter()
                .map(|(f, nodes)| Load {
                    nodes,
                    force: t * (cell_area * f),
                    scale: scale.clone(),
                })
                .collect()
        }
    }
}

/// Fill `geometry` with a cubic lattice of spacing `a` turned by `r` (a lattice vector `v` is
/// `r v` in the body: [`hooke_core::anisotropy::lattice_rotation`] lays it along a fibre,
/// [`hooke_core::Orthotropic::lattice_rotation`] along material axes): a grid over the body's box as the turned lattice sees it, turned about
/// the box's centre, keeping the nodes inside the box and the body (within 1e-9 a).
pub fn fill_turned_cubic(
    a: Real,
    r: &hooke_core::math::Matrix,
    geometry: &Solid,
) -> Result<Lattice, BuildError> {
    let (lo, hi) = geometry.bounds(3)?;
    let r = *r;
    let centre = 0.5 * (lo + hi);
    // The box's corners in the turned lattice's frame, and their bounds.
    let (mut llo, mut lhi) = (
        Vector::repeat(Real::INFINITY),
        Vector::repeat(Real::NEG_INFINITY),
    );
    for corner in 0..8 {
        let c = Vector::new(
            if corner & 1 == 0 { lo.x } else { hi.x },
            if corner & 2 == 0 { lo.y } else { hi.y },
            if corner & 4 == 0 { lo.z } else { hi.z },
        );
        let l = r.transpose() * (c - centre);
        llo = llo.inf(&l);
        lhi = lhi.sup(&l);
    }
    let size = lhi - llo;
    let countf = |len: Real| (len / a + 1e-9).floor() + 2.0;
    let total = countf(size.x) * countf(size.y) * countf(size.z);
    if !(total <= MAX_NODES) {
        return Err(BuildError::new("lattice.spacing", format!("{total:.3e} nodes would not fit in memory (at most {MAX_NODES:e}); use a larger spacing or --scale below 1")));
    }
    let n = [size.x, size.y, size.z].map(|s| countf(s) as usize);
    let geo = |e: hooke_core::Error| BuildError::new("geometry", e.to_string());
    let mut lattice = Lattice::cubic_box(n, a).map_err(geo)?;
    // The grid from the bounds' low corner in the turned frame (so a face the turn leaves in
    // place stays a node plane), then turned about the box's centre.
    let shift = centre + llo;
    for i in 0..lattice.len() {
        lattice.pos.x_mut()[i] += shift.x;
        lattice.pos.y_mut()[i] += shift.y;
        lattice.pos.z_mut()[i] += shift.z;
    }
    let lattice = lattice.rotated(&r, centre).map_err(geo)?;
    let tol = 1e-9 * a;
    lattice
        .retain(|p| {
            (0..3).all(|c| p[c] >= lo[c] - tol && p[c] <= hi[c] + tol)
                && geometry.contains(p, tol, 3)
        })
        .map_err(geo)
}
