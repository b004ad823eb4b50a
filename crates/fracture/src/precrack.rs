//! Pre-cracks: line segments (2D) and planar polygons (3D). Every spring whose reference
//! segment crosses one is removed at set-up.
//!
//! A spring crosses when its two end nodes lie strictly on opposite sides of the crack (line or
//! plane) and the crossing point lies inside the segment or polygon. A node exactly on the
//! crack's line or plane counts as on neither side: place cracks between node rows or planes.

use hooke_core::{Body, Real, Vector};

use crate::error::FractureError;

/// A pre-crack.
#[derive(Clone, Debug, PartialEq)]
pub enum Crack {
    /// A segment from `a` to `b` in the plane of a 2D body (z ignored).
    Segment { a: [Real; 2], b: [Real; 2] },
    /// A planar polygon (3 or more vertices, in order) in a 3D body.
    Polygon { vertices: Vec<[Real; 3]> },
}

/// The springs of `body` that `crack` cuts (indices of undirected springs).
pub fn springs_cut(body: &Body, crack: &Crack, index: usize) -> Result<Vec<usize>, FractureError> {
    let out = springs_crossing(body, crack, index)?;
    if out.is_empty() {
        return Err(no_spring(index));
    }
    Ok(out)
}

/// The error of a pre-crack that cuts no spring of the body.
pub(crate) fn no_spring(index: usize) -> FractureError {
    FractureError::BadCrack {
        index,
        why: "it cuts no spring: it lies outside the body, or along a node row or plane (move it between two)".into(),
    }
}

/// [`springs_cut`], without refusing a crack that cuts none of `body`'s springs (a process's
/// piece of a body may hold none that a crack cuts).
pub fn springs_crossing(
    body: &Body,
    crack: &Crack,
    index: usize,
) -> Result<Vec<usize>, FractureError> {
    let lat = &body.lattice;
    let bonds = &*lat.bonds;
    let bad = |why: String| FractureError::BadCrack { index, why };
    let mut out = Vec::new();
    match crack {
        Crack::Segment { a, b } => {
            if lat.dim() != 2 {
                return Err(bad(
                    "a segment cuts 2D bodies; give a polygon for a 3D body".into(),
                ));
            }
            let (p, r) = (Vector::new(a[0], a[1], 0.0), Vector::new(b[0], b[1], 0.0));
            if (r - p).norm() == 0.0 || !a.iter().chain(b).all(|v| v.is_finite()) {
                return Err(bad("the segment has zero length or a non-finite end".into()));
            }
            let orient = |o: Vector, u: Vector, w: Vector| {
                (u.x - o.x) * (w.y - o.y) - (u.y - o.y) * (w.x - o.x)
            };
            let crosses = |x: Vector, y: Vector| {
                let (d1, d2) = (orient(p, r, x), orient(p, r, y));
                let (d3, d4) = (orient(x, y, p), orient(x, y, r));
                d1 * d2 < 0.0 && d3 * d4 < 0.0
            };
            for (s, &[i, j]) in bonds.ends.iter().enumerate() {
                // The spring as a segment along its (minimum-image) reference vector, seen from
                // both ends: across a periodic boundary the two images differ.
                let (x, y) = (lat.pos.get(i as usize), lat.pos.get(j as usize));
                let dv = lat.reference_vector(i as usize, j as usize);
                let d = Vector::new(dv[0], dv[1], dv[2]);
                if crosses(x, x + d) || crosses(y - d, y) {
                    out.push(s);
                }
            }
        }
        Crack::Polygon { vertices } => {
            if lat.dim() != 3 {
                return Err(bad(
                    "a polygon cuts 3D bodies; give a segment for a 2D body".into(),
                ));
            }
            if vertices.len() < 3 || !vertices.iter().flatten().all(|v| v.is_finite()) {
                return Err(bad("a polygon needs 3 or more finite vertices".into()));
            }
            let v: Vec<Vector> = vertices
                .iter()
                .map(|p| Vector::new(p[0], p[1], p[2]))
                .collect();
            // Newell's normal: robust for any simple polygon.
            let mut normal = Vector::zeros();
            for k in 0..v.len() {
                let (c, d) = (v[k], v[(k + 1) % v.len()]);
                normal += Vector::new(
                    (c.y - d.y) * (c.z + d.z),
                    (c.z - d.z) * (c.x + d.x),
                    (c.x - d.x) * (c.y + d.y),
                );
            }
            let size = v.iter().map(|p| (p - v[0]).norm()).fold(0.0, Real::max);
            if normal.norm() <= 1e-12 * size * size {
                return Err(bad(
                    "the polygon has no area (its vertices are collinear)".into()
                ));
            }
            let n = normal.normalize();
            if let Some(off) = v
                .iter()
                .map(|p| (p - v[0]).dot(&n).abs())
                .find(|&d| d > 1e-9 * size.max(lat.spacing))
            {
                return Err(bad(format!(
                    "the polygon is not planar (a vertex is {off:.3e} m off its plane)"
                )));
            }
            // Project onto the coordinate plane most nearly parallel to the polygon.
            let drop = n.iamax();
            let (ax, ay) = ((drop + 1) % 3, (drop + 2) % 3);
            let poly: Vec<(Real, Real)> = v.iter().map(|p| (p[ax], p[ay])).collect();
            let inside = |x: Real, y: Real| {
                let mut c = false;
                for k in 0..poly.len() {
                    let (p1, p2) = (poly[k], poly[(k + 1) % poly.len()]);
                    if (p1.1 > y) != (p2.1 > y)
                        && x < p1.0 + (y - p1.1) * (p2.0 - p1.0) / (p2.1 - p1.1)
                    {
                        c = !c;
                    }
                }
                c
            };
            for (s, &[i, j]) in bonds.ends.iter().enumerate() {
                // The spring as a segment from node i along its (minimum-image) reference vector.
                let x = lat.pos.get(i as usize);
                let d = lat.reference_vector(i as usize, j as usize);
                let y = x + Vector::new(d[0], d[1], d[2]);
                let (dx, dy) = ((x - v[0]).dot(&n), (y - v[0]).dot(&n));
                if dx * dy < 0.0 {
                    let t = dx / (dx - dy);
                    let mut hit = x + (y - x) * t;
                    // Along periodic axes the crossing point is brought back into the box.
                    for c in 0..3 {
                        let p = lat.period[c];
                        if p > 0.0 {
                            let lo = lat
                                .pos
                                .comp(c)
                                .iter()
                                .cloned()
                                .fold(Real::INFINITY, Real::min);
                            hit[c] = lo + (hit[c] - lo).rem_euclid(p);
                        }
                    }
                    if inside(hit[ax], hit[ay]) {
                        out.push(s);
                    }
                }
            }
        }
    }
    Ok(out)
}
