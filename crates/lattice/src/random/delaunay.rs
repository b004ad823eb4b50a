//! Delaunay triangulation (2D, `N = 3`) and tetrahedralisation (3D, `N = 4`) by Bowyer-Watson
//! insertion with exact predicates.
//!
//! Why our own: the 2D crates (spade) have no 3D counterpart of the same weight, and the general
//! d-dimensional crate pulls in a large dependency tree for what is, for our node sets (blue
//! noise or jittered grids: no duplicate points, minimum distances guaranteed), a short
//! algorithm. Robustness comes from Shewchuk's adaptive exact predicates (`robust` crate):
//! every orientation and in-sphere decision is exact, so the triangulation is the exact Delaunay
//! triangulation of the points and the enclosing super-simplex.
//!
//! The cavity of a new point `p` (the simplices whose open circumball holds `p`) is star-shaped
//! from `p`, ties (co-spherical points, which the box's flat faces and the jittered grid give)
//! included, so every new simplex is positively oriented without a test. Let `T` be in the
//! cavity and `T'` not, sharing the facet `f`; both circumspheres pass through the circle `C`
//! in which `f`'s plane cuts them. Spheres through one circle are nested on each side of its
//! plane, and `T'`'s far vertex, on its sphere, is not strictly inside `T`'s ball (the mesh is
//! Delaunay), so on `T'`'s side the open ball of `T` lies within that of `T'`, and in the plane
//! both contain the open disc of `C`. `p` is strictly inside `T`'s ball and not inside `T'`'s,
//! so it lies strictly on `T`'s side of `f`. (The first simplex of the cavity holds `p`
//! strictly inside its ball unless `p` is a vertex: a duplicate, refused.)
//!
//! The super-simplex has its vertices about 100 box sizes away. Hull simplices whose circumsphere
//! reaches that far (very flat ones on the convex hull) are therefore missing from the result;
//! they are exactly the boundary slivers the lattice builder drops anyway.

use crate::error::{Error, Result};
use robust::{Coord, Coord3D};

const NONE: u32 = u32::MAX;

/// The simplices of a triangulation of `points`, positively oriented, with their face
/// neighbours (`nbr[s][i]` shares the facet opposite vertex `i`; `NONE` on the hull).
#[derive(Clone, Debug)]
pub struct Mesh<const N: usize> {
    pub simplices: Vec<[u32; N]>,
    pub nbr: Vec<[u32; N]>,
}

/// Orientation of a simplex: positive for a counter-clockwise triangle / positively oriented
/// tetrahedron (robust's sign conventions), zero when degenerate.
pub(crate) fn orient<const N: usize>(p: &[[f64; 3]], v: &[u32; N]) -> f64 {
    let c2 = |i: u32| {
        let q = p[i as usize];
        Coord { x: q[0], y: q[1] }
    };
    let c3 = |i: u32| {
        let q = p[i as usize];
        Coord3D {
            x: q[0],
            y: q[1],
            z: q[2],
        }
    };
    match N {
        3 => robust::orient2d(c2(v[0]), c2(v[1]), c2(v[2])),
        4 => robust::orient3d(c3(v[0]), c3(v[1]), c3(v[2]), c3(v[3])),
        _ => unreachable!("simplices have 3 or 4 vertices"),
    }
}

/// The largest magnitude of three finite numbers (a plain comparison, not `f64::max`'s NaN
/// handling).
#[inline(always)]
fn max3(x: f64, y: f64, z: f64) -> f64 {
    let max = |x: f64, y: f64| if x > y { x } else { y };
    max(max(x.abs(), y.abs()), z.abs())
}

/// Positive when `q` lies strictly inside the circumsphere of the positively oriented simplex.
fn in_sphere<const N: usize>(p: &[[f64; 3]], v: &[u32; N], q: [f64; 3]) -> f64 {
    let c2 = |r: [f64; 3]| Coord { x: r[0], y: r[1] };
    let c3 = |r: [f64; 3]| Coord3D {
        x: r[0],
        y: r[1],
        z: r[2],
    };
    let at = |i: u32| p[i as usize];
    match N {
        3 => robust::incircle(c2(at(v[0])), c2(at(v[1])), c2(at(v[2])), c2(q)),
        4 => {
            let (a, b, c, d) = (at(v[0]), at(v[1]), at(v[2]), at(v[3]));
            match insphere_fast(a, b, c, d, q) {
                Some(det) => det,
                // robust's insphere is positive inside for orient3d(a, b, c, d) > 0.
                None => robust::insphere(c3(a), c3(b), c3(c), c3(d), c3(q)),
            }
        }
        _ => unreachable!(),
    }
}

/// The in-sphere determinant of Shewchuk's `insphere` (the same expression, so its sign is
/// `robust::insphere`'s) when a bound says that sign is certain, `None` otherwise.
///
/// Shewchuk bounds the error of this floating-point determinant by `(16 + 224 eps) eps P`,
/// `P` the permanent (the determinant with every term's absolute value) evaluated in floating
/// point from the same rounded differences. Every difference is at most `M` in magnitude, so
/// each lift is at most `3 M^2`, each of its 3x3 minors' permanents at most `6 M^3`, and `P <=
/// 72 M^5`; `73 M^5` also covers the rounding of `P` and of `M^5`. That bound costs a maximum
/// where the permanent costs forty products and sums, and it rarely decides otherwise: on a
/// random node set the determinant is of order `M^5` and the bound `2.6e-13 M^5`, and the
/// near-ties it leaves (co-spherical points on the box's faces) go to the adaptive exact
/// predicate as before. Spreads of `M` below `1e-40` (whose fifth power leaves the normal
/// range) or above `1e40` always go there.
#[inline(always)]
fn insphere_fast(a: [f64; 3], b: [f64; 3], c: [f64; 3], d: [f64; 3], e: [f64; 3]) -> Option<f64> {
    const EPS: f64 = f64::EPSILON / 2.0;
    const BOUND: f64 = 73.0 * (16.0 + 224.0 * EPS) * EPS;
    let (aex, aey, aez) = (a[0] - e[0], a[1] - e[1], a[2] - e[2]);
    let (bex, bey, bez) = (b[0] - e[0], b[1] - e[1], b[2] - e[2]);
    let (cex, cey, cez) = (c[0] - e[0], c[1] - e[1], c[2] - e[2]);
    let (dex, dey, dez) = (d[0] - e[0], d[1] - e[1], d[2] - e[2]);
    let ab = aex * bey - bex * aey;
    let bc = bex * cey - cex * bey;
    let cd = cex * dey - dex * cey;
    let da = dex * aey - aex * dey;
    let ac = aex * cey - cex * aey;
    let bd = bex * dey - dex * bey;
    let abc = aez * bc - bez * ac + cez * ab;
    let bcd = bez * cd - cez * bd + dez * bc;
    let cda = cez * da + dez * ac + aez * cd;
    let dab = dez * ab + aez * bd + bez * da;
    let alift = aex * aex + aey * aey + aez * aez;
    let blift = bex * bex + bey * bey + bez * bez;
    let clift = cex * cex + cey * cey + cez * cez;
    let dlift = dex * dex + dey * dey + dez * dez;
    let det = (dlift * abc - clift * dab) + (blift * cda - alift * bcd);
    // In a tree, not a chain.
    let m = max3(
        max3(aex, aey, aez),
        max3(bex, bey, bez),
        max3(cex, cey, cez),
    )
    .max(max3(dex, dey, dez));
    if !(1e-40..=1e40).contains(&m) {
        return None;
    }
    let m2 = m * m;
    let bound = BOUND * (m2 * m2 * m);
    (det.abs() > bound).then_some(det)
}

/// A simplex of the triangulation under construction: its vertices and its face neighbours
/// side by side, so that visiting a simplex reads one cache line (the cavity search reaches
/// simplices all over the list). A dead simplex, waiting in the free list, has `v[0] = NONE`.
#[derive(Clone, Copy)]
#[repr(C, align(32))]
struct Simplex<const N: usize> {
    v: [u32; N],
    nbr: [u32; N],
}

struct Builder<const N: usize> {
    pts: Vec<[f64; 3]>,
    simplex: Vec<Simplex<N>>,
    free: Vec<u32>,
    mark: Vec<u32>,
    stamp: u32,
    /// Scratch of `insert`, kept so that an insertion allocates nothing: the boundary facets
    /// joined to the new point, and the facets through it waiting for their partner.
    facets: Vec<([u32; N], u32, u32, usize)>,
    open: Open,
}

/// An open-addressing table of the facets through a new point that wait for their partner,
/// cleared between insertions by a generation count rather than by writing it.
#[derive(Default)]
struct Open {
    /// `(generation, key, simplex, slot)`; a key is the facet's vertices other than the point.
    table: Vec<(u32, [u32; 2], u32, u32)>,
    generation: u32,
}

impl Open {
    /// Start an insertion that will offer at most `facets` facets.
    fn begin(&mut self, facets: usize) {
        let want = (4 * facets).next_power_of_two().max(64);
        if self.table.len() < want || self.generation == u32::MAX {
            self.table = vec![(0, [NONE; 2], 0, 0); want];
            self.generation = 0;
        }
        self.generation += 1;
    }

    /// Offer a facet; returns its partner's `(simplex, slot)` when that was offered before.
    fn offer(&mut self, key: [u32; 2], w: u32, j: usize) -> Option<(u32, usize)> {
        let mask = self.table.len() - 1;
        let h = key[0].wrapping_mul(0x9E37_79B1) ^ key[1].wrapping_mul(0x85EB_CA77);
        let mut at = (h ^ (h >> 15)) as usize & mask;
        loop {
            let e = &mut self.table[at];
            if e.0 != self.generation {
                *e = (self.generation, key, w, j as u32);
                return None;
            }
            if e.1 == key {
                // A facet is shared by exactly two simplices: free the entry for nobody.
                e.1 = [NONE; 2];
                return Some((e.2, e.3 as usize));
            }
            at = (at + 1) & mask;
        }
    }
}

/// Triangulate `points` (z = 0 for `N = 3`). Fails only on duplicate points, non-finite
/// coordinates or fewer points than a simplex needs.
pub fn triangulate<const N: usize>(points: &[[f64; 3]]) -> Result<Mesh<N>> {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for c in 0..3 {
            lo[c] = lo[c].min(p[c]);
            hi[c] = hi[c].max(p[c]);
        }
    }
    triangulate_in(points, lo, hi)
}

/// [`triangulate`] with the super-simplex placed around the box `[lo, hi]` (which should hold
/// the points) rather than around the points' own bounds. Two point sets triangulated in one
/// box share their super-simplex, so a part of a body triangulated alone keeps exactly the
/// simplices the whole body has around its inner nodes, hull ones included (see
/// `random::part`).
pub fn triangulate_in<const N: usize>(
    points: &[[f64; 3]],
    lo: [f64; 3],
    hi: [f64; 3],
) -> Result<Mesh<N>> {
    triangulate_checked(points, lo, hi, |_, _| Ok(()))
}

/// [`triangulate_in`] that shows `check` every simplex of the finished triangulation, those
/// with a vertex of the super-simplex included (their vertices index the slice `check` is
/// given: the points, then the super-simplex's), before they are dropped; an error from
/// `check` is returned.
pub(crate) fn triangulate_checked<const N: usize>(
    points: &[[f64; 3]],
    lo: [f64; 3],
    hi: [f64; 3],
    check: impl Fn(&[[f64; 3]], &[u32; N]) -> Result<()>,
) -> Result<Mesh<N>> {
    let n = points.len();
    if n < N {
        return Err(Error::InvalidInput {
            what: "random lattice",
            why: format!(
                "{n} nodes cannot form a simplex: make the shape larger or the spacing smaller"
            ),
        });
    }
    if points.iter().any(|p| p.iter().any(|c| !c.is_finite())) {
        return Err(Error::InvalidInput {
            what: "random lattice",
            why: "a node coordinate is not finite".into(),
        });
    }
    let centre = [
        0.5 * (lo[0] + hi[0]),
        0.5 * (lo[1] + hi[1]),
        0.5 * (lo[2] + hi[2]),
    ];
    let size = (0..3)
        .map(|c| hi[c] - lo[c])
        .fold(0.0, f64::max)
        .max(1e-300);
    let far = 100.0 * size;
    let mut pts = points.to_vec();
    let sup: Vec<[f64; 3]> = if N == 3 {
        (0..3)
            .map(|k| {
                let t = std::f64::consts::PI / 2.0 + k as f64 * 2.0 * std::f64::consts::PI / 3.0;
                [
                    centre[0] + 2.0 * far * t.cos(),
                    centre[1] + 2.0 * far * t.sin(),
                    0.0,
                ]
            })
            .collect()
    } else {
        [
            [1.0, 1.0, 1.0],
            [1.0, -1.0, -1.0],
            [-1.0, 1.0, -1.0],
            [-1.0, -1.0, 1.0],
        ]
        .iter()
        .map(|d| {
            [
                centre[0] + 2.0 * far * d[0],
                centre[1] + 2.0 * far * d[1],
                centre[2] + 2.0 * far * d[2],
            ]
        })
        .collect()
    };
    pts.extend_from_slice(&sup);
    let mut first = [0u32; N];
    for (k, v) in first.iter_mut().enumerate() {
        *v = (n + k) as u32;
    }
    if orient(&pts, &first) < 0.0 {
        first.swap(0, 1);
    }
    let mut b = Builder {
        pts,
        simplex: vec![Simplex {
            v: first,
            nbr: [NONE; N],
        }],
        free: Vec::new(),
        mark: vec![0],
        stamp: 0,
        facets: Vec::new(),
        open: Open::default(),
    };
    // Insert in Morton order of the quantised coordinates: consecutive points are close, so the
    // walk from the last new simplex is short.
    let mut order: Vec<(u64, u32)> = (0..n)
        .map(|i| (morton_key(&points[i], lo, hi), i as u32))
        .collect();
    order.sort_unstable();
    let mut last = 0u32;
    let mut cavity: Vec<u32> = Vec::new();
    let mut boundary: Vec<(u32, usize)> = Vec::new();
    let mut created: Vec<u32> = Vec::new();
    for &(_, i) in &order {
        last = b.insert(i, last, &mut cavity, &mut boundary, &mut created)?;
    }
    for x in &b.simplex {
        if x.v.iter().all(|&v| v != NONE) {
            check(&b.pts, &x.v)?;
        }
    }
    // Keep the simplices without a super vertex (a dead one has a vertex NONE); neighbours
    // outside that set become hull facets.
    let mut new_id = vec![NONE; b.simplex.len()];
    let mut simplices = Vec::new();
    for (s, x) in b.simplex.iter().enumerate() {
        if x.v.iter().all(|&v| (v as usize) < n) {
            new_id[s] = simplices.len() as u32;
            simplices.push(x.v);
        }
    }
    let mut nbr = Vec::with_capacity(simplices.len());
    for (s, x) in b.simplex.iter().enumerate() {
        if new_id[s] != NONE {
            let mut row = [NONE; N];
            for k in 0..N {
                let t = x.nbr[k];
                row[k] = if t == NONE { NONE } else { new_id[t as usize] };
            }
            nbr.push(row);
        }
    }
    Ok(Mesh { simplices, nbr })
}

impl<const N: usize> Builder<N> {
    fn with_vertex(&self, s: u32, k: usize, p: u32) -> [u32; N] {
        let mut v = self.simplex[s as usize].v;
        v[k] = p;
        v
    }

    /// Visibility walk from `start` to a simplex containing point `p`.
    fn locate(&self, p: u32, start: u32) -> Result<u32> {
        let mut cur = start;
        for rot in 0..10_000_000usize {
            let mut moved = false;
            for kk in 0..N {
                // Rotate the first facet tried so the walk cannot cycle on ties.
                let k = (kk + rot) % N;
                if orient(&self.pts, &self.with_vertex(cur, k, p)) < 0.0 {
                    let t = self.simplex[cur as usize].nbr[k];
                    if t == NONE {
                        break;
                    }
                    cur = t;
                    moved = true;
                    break;
                }
            }
            if !moved {
                return Ok(cur);
            }
        }
        Err(Error::InvalidInput {
            what: "random lattice",
            why: "point location did not terminate (degenerate node set)".into(),
        })
    }

    /// Start loading the neighbours of a simplex that just joined a cavity, which the search
    /// tests next: their reads (anywhere in the list) then overlap rather than wait in turn.
    fn prefetch_around(&self, s: u32) {
        for &t in &self.simplex[s as usize].nbr {
            if t != NONE {
                hooke_sys::prefetch(&self.simplex[t as usize]);
                hooke_sys::prefetch(&self.mark[t as usize]);
            }
        }
    }

    fn alloc(&mut self, v: [u32; N]) -> u32 {
        let x = Simplex { v, nbr: [NONE; N] };
        if let Some(s) = self.free.pop() {
            self.simplex[s as usize] = x;
            s
        } else {
            self.simplex.push(x);
            self.mark.push(0);
            (self.simplex.len() - 1) as u32
        }
    }

    fn insert(
        &mut self,
        p: u32,
        start: u32,
        cavity: &mut Vec<u32>,
        boundary: &mut Vec<(u32, usize)>,
        created: &mut Vec<u32>,
    ) -> Result<u32> {
        let q = self.pts[p as usize];
        let s0 = self.locate(p, start)?;
        if in_sphere(&self.pts, &self.simplex[s0 as usize].v, q) <= 0.0 {
            return Err(Error::InvalidInput {
                what: "random lattice",
                why: format!("node {p} at {q:?} duplicates another node"),
            });
        }
        self.stamp += 1;
        let stamp = self.stamp;
        cavity.clear();
        cavity.push(s0);
        self.mark[s0 as usize] = stamp;
        self.prefetch_around(s0);
        let mut head = 0;
        while head < cavity.len() {
            let s = cavity[head];
            head += 1;
            for k in 0..N {
                let t = self.simplex[s as usize].nbr[k];
                if t != NONE
                    && self.mark[t as usize] != stamp
                    && in_sphere(&self.pts, &self.simplex[t as usize].v, q) > 0.0
                {
                    self.mark[t as usize] = stamp;
                    cavity.push(t);
                    self.prefetch_around(t);
                }
            }
        }
        // The cavity is star-shaped from p: every boundary facet is seen strictly from the
        // inside, so joining it to p gives a positively oriented simplex. This needs no test
        // (see the module docs), and none was ever seen to fail while it was made; the
        // lattice builder still checks every simplex it keeps.
        boundary.clear();
        for &s in cavity.iter() {
            for k in 0..N {
                let t = self.simplex[s as usize].nbr[k];
                if t == NONE || self.mark[t as usize] != stamp {
                    boundary.push((s, k));
                }
            }
        }
        // New simplices: each boundary facet joined to p (p takes the place of the vertex
        // opposite the facet, which keeps the orientation).
        created.clear();
        let mut facets = std::mem::take(&mut self.facets);
        facets.clear();
        facets.extend(boundary.iter().map(|&(s, k)| {
            (
                self.with_vertex(s, k, p),
                s,
                self.simplex[s as usize].nbr[k],
                k,
            )
        }));
        for &s in cavity.iter() {
            self.simplex[s as usize].v[0] = NONE;
        }
        for &(v, s, outer, k) in &facets {
            let w = self.alloc(v);
            self.mark[w as usize] = 0;
            self.simplex[w as usize].nbr[k] = outer;
            if outer != NONE {
                // Two simplices share at most one facet, so `s` appears once in the outer row.
                let o = &mut self.simplex[outer as usize].nbr;
                let m = o.iter().position(|&x| x == s).unwrap();
                o[m] = w;
            }
            created.push(w);
        }
        self.facets = facets;
        for &s in cavity.iter() {
            self.mark[s as usize] = 0;
            self.free.push(s);
        }
        // Facets through p between new simplices: each is named by its vertices other than p
        // and shared by exactly two new simplices, paired through a small hash table (a cavity
        // has tens of new simplices; a linear search for each partner was the hottest loop of
        // the triangulation). The pairing is unique, so the mesh does not depend on how.
        let mut open = std::mem::take(&mut self.open);
        open.begin(created.len() * (N - 1));
        for &w in created.iter() {
            let v = self.simplex[w as usize].v;
            let kp = v.iter().position(|&x| x == p).unwrap();
            for j in 0..N {
                if j == kp {
                    continue;
                }
                // Built in two scalars, not by indexed stores into an array: the table lookup
                // read the array back whole before its two halves had reached the cache
                // (a failed store-to-load forwarding, a tenth of the triangulation's time).
                let (mut a, mut b) = (NONE, NONE);
                for c in 0..N {
                    if c != kp && c != j {
                        if a == NONE {
                            a = v[c];
                        } else {
                            b = v[c];
                        }
                    }
                }
                let key = if b != NONE && a > b { [b, a] } else { [a, b] };
                if let Some((w2, j2)) = open.offer(key, w, j) {
                    self.simplex[w as usize].nbr[j] = w2;
                    self.simplex[w2 as usize].nbr[j2] = w;
                }
            }
        }
        self.open = open;
        Ok(created[0])
    }
}

/// Morton (Z-order) key of `p`, its coordinates quantised to 21 bits in the box `[lo, hi]`:
/// points close in space get close keys.
pub(crate) fn morton_key(p: &[f64; 3], lo: [f64; 3], hi: [f64; 3]) -> u64 {
    let q: [u64; 3] = [0, 1, 2].map(|c| {
        let span = (hi[c] - lo[c]).max(1e-300);
        (((p[c] - lo[c]) / span).clamp(0.0, 1.0) * 2_097_151.0) as u64
    });
    let mut key = 0u64;
    for bit in (0..21).rev() {
        for qc in q {
            key = (key << 1) | ((qc >> bit) & 1);
        }
    }
    key
}

/// Signed measure (area or volume) of a simplex.
pub fn measure<const N: usize>(p: &[[f64; 3]], v: &[u32; N]) -> f64 {
    match N {
        3 => 0.5 * orient(p, v),
        _ => orient(p, v) / 6.0,
    }
}

/// Circumradius of a simplex (the radius of its circumscribed circle or sphere).
pub fn circumradius<const N: usize>(p: &[[f64; 3]], v: &[u32; N]) -> f64 {
    circumsphere(p, v).1
}

/// Centre and radius of a simplex's circumscribed circle (z = the vertices' z) or sphere; an
/// infinite radius for a degenerate simplex.
pub fn circumsphere<const N: usize>(p: &[[f64; 3]], v: &[u32; N]) -> ([f64; 3], f64) {
    // Solve 2 (x_k - x_0) . c = |x_k - x_0|^2 for the centre offset c.
    let x0 = p[v[0] as usize];
    let d = N - 1;
    let mut m = [[0.0; 4]; 3];
    for k in 1..N {
        let xk = p[v[k] as usize];
        let e: Vec<f64> = (0..d).map(|c| xk[c] - x0[c]).collect();
        for c in 0..d {
            m[k - 1][c] = 2.0 * e[c];
        }
        m[k - 1][3] = e.iter().map(|x| x * x).sum();
    }
    // Gaussian elimination with partial pivoting on the d x d system.
    for col in 0..d {
        let piv = (col..d)
            .max_by(|&a, &b| m[a][col].abs().total_cmp(&m[b][col].abs()))
            .unwrap();
        m.swap(col, piv);
        let pv = m[col][col];
        if pv == 0.0 {
            return (x0, f64::INFINITY);
        }
        for r in 0..d {
            if r != col {
                let f = m[r][col] / pv;
                for c in 0..4 {
                    m[r][c] -= f * m[col][c];
                }
            }
        }
    }
    let mut centre = x0;
    let mut r2 = 0.0;
    for c in 0..d {
        let off = m[c][3] / m[c][c];
        centre[c] += off;
        r2 += off * off;
    }
    (centre, r2.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::random::rng::Rng;

    fn check_delaunay<const N: usize>(pts: &[[f64; 3]], m: &Mesh<N>) {
        // Every simplex positive, no point strictly inside any circumsphere (brute force),
        // neighbours symmetric.
        for (s, v) in m.simplices.iter().enumerate() {
            assert!(orient(pts, v) > 0.0);
            for (i, q) in pts.iter().enumerate() {
                if !v.contains(&(i as u32)) {
                    assert!(in_sphere(pts, v, *q) <= 0.0, "point {i} inside simplex {s}");
                }
            }
            for k in 0..N {
                let t = m.nbr[s][k];
                if t != NONE {
                    assert!(m.nbr[t as usize].contains(&(s as u32)));
                }
            }
        }
    }

    #[test]
    fn random_points_2d_and_3d_are_delaunay_and_fill_the_hull() {
        let mut rng = Rng::new(5);
        let p2: Vec<[f64; 3]> = (0..300)
            .map(|_| [rng.uniform(), rng.uniform(), 0.0])
            .collect();
        let m2 = triangulate::<3>(&p2).unwrap();
        check_delaunay(&p2, &m2);
        // Euler: a triangulation of n points with h on the hull has 2n - 2 - h triangles (all hull
        // triangles present up to the flattest ones, see the module docs).
        assert!(m2.simplices.len() > 2 * 300 - 2 - 60);
        let p3: Vec<[f64; 3]> = (0..300)
            .map(|_| [rng.uniform(), rng.uniform(), rng.uniform()])
            .collect();
        let m3 = triangulate::<4>(&p3).unwrap();
        check_delaunay(&p3, &m3);
        let vol: f64 = m3.simplices.iter().map(|v| measure(&p3, v)).sum();
        // The hull of 300 uniform points in the unit cube holds about 0.8 of it.
        assert!(vol > 0.75 && vol < 1.0, "{vol}");
    }

    /// The cavity needs no star-shape test (module docs): with ties everywhere (unperturbed
    /// grids, where every cell's corners are co-circular or co-spherical) and on conforming
    /// Poisson sets (flat faces, co-spherical box corners), every simplex is positive, no point
    /// lies inside a circumsphere, the neighbours are mutual and the grid's hull is filled.
    #[test]
    fn ties_leave_every_simplex_positive_and_the_mesh_delaunay() {
        let grid2: Vec<[f64; 3]> = (0..15 * 15)
            .map(|k| [(k % 15) as f64, (k / 15) as f64, 0.0])
            .collect();
        let m2 = triangulate::<3>(&grid2).unwrap();
        check_delaunay(&grid2, &m2);
        let area: f64 = m2.simplices.iter().map(|v| measure(&grid2, v)).sum();
        assert!((area - 196.0).abs() < 1e-9, "{area}");
        let grid3: Vec<[f64; 3]> = (0..8 * 8 * 8)
            .map(|k| [(k % 8) as f64, ((k / 8) % 8) as f64, (k / 64) as f64])
            .collect();
        let m3 = triangulate::<4>(&grid3).unwrap();
        check_delaunay(&grid3, &m3);
        let vol: f64 = m3.simplices.iter().map(|v| measure(&grid3, v)).sum();
        assert!((vol - 343.0).abs() < 1e-9, "{vol}");
        for (dim, hi) in [(2, [9.0, 7.0, 0.0]), (3, [5.0, 4.0, 3.0])] {
            let pts = crate::random::sample::sample_box(
                dim,
                [0.0; 3],
                hi,
                1.0,
                crate::random::Sampler::Poisson,
                3,
                &|_| true,
            );
            if dim == 2 {
                check_delaunay(&pts, &triangulate::<3>(&pts).unwrap());
            } else {
                check_delaunay(&pts, &triangulate::<4>(&pts).unwrap());
            }
        }
    }

    #[test]
    fn a_grid_with_cospherical_points_is_triangulated_validly() {
        // The worst case for ties: an unperturbed cubic grid (every cube co-spherical).
        let mut p = Vec::new();
        for k in 0..5 {
            for j in 0..5 {
                for i in 0..5 {
                    p.push([i as f64, j as f64, k as f64]);
                }
            }
        }
        let m = triangulate::<4>(&p).unwrap();
        for v in &m.simplices {
            assert!(orient(&p, v) > 0.0);
        }
        let vol: f64 = m.simplices.iter().map(|v| measure(&p, v)).sum();
        assert!((vol - 64.0).abs() < 1e-9, "{vol}");
        let dup = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ];
        assert!(triangulate::<3>(&dup).is_err());
    }

    #[test]
    fn the_filtered_in_sphere_test_decides_only_what_the_exact_one_does() {
        // Random tetrahedra and points, at scales from 1e-30 to 1e30, and the near-ties the
        // filter must leave to the exact predicate: a cube's corners (co-spherical) with the
        // fifth moved off the sphere by a few ulps or not at all.
        let mut rng = Rng::new(7);
        let c3 = |r: [f64; 3]| Coord3D {
            x: r[0],
            y: r[1],
            z: r[2],
        };
        let exact = |a, b, c, d, e| robust::insphere(c3(a), c3(b), c3(c), c3(d), c3(e));
        let (mut decided, mut left) = (0, 0);
        for scale in [1e-30, 1e-3, 1.0, 7.0, 1e30] {
            for _ in 0..20_000 {
                let mut pt = || [0, 1, 2].map(|_| scale * rng.range(-1.0, 1.0));
                let (a, b, c, d, e) = (pt(), pt(), pt(), pt(), pt());
                match insphere_fast(a, b, c, d, e) {
                    Some(det) => {
                        assert_eq!(det.signum(), exact(a, b, c, d, e).signum());
                        decided += 1;
                    }
                    None => left += 1,
                }
            }
        }
        assert!(decided > 99_000, "{decided} decided, {left} left");
        let corner = |i: u32| [(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64];
        for ulps in [-3i64, -1, 0, 1, 3] {
            for k in 0..3 {
                let mut e = corner(7);
                e[k] = f64::from_bits((e[k].to_bits() as i64 + ulps) as u64);
                let (a, b, c, d) = (corner(0), corner(1), corner(2), corner(4));
                let want = exact(a, b, c, d, e);
                assert_eq!(want == 0.0, ulps == 0);
                match insphere_fast(a, b, c, d, e) {
                    Some(det) => assert_eq!(det.signum(), want.signum(), "{ulps} ulps"),
                    None => assert_eq!(in_sphere(&[a, b, c, d], &[0, 1, 2, 3], e), want),
                }
                assert_eq!(
                    in_sphere(&[a, b, c, d], &[0, 1, 2, 3], e).signum(),
                    want.signum()
                );
            }
        }
    }

    #[test]
    fn circumradius_of_known_simplices() {
        let p = [
            [0.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [0.0, 2.0, 0.0],
            [0.0, 0.0, 2.0],
        ];
        assert!((circumradius(&p, &[0, 1, 2]) - 2f64.sqrt()).abs() < 1e-12);
        assert!((circumradius(&p, &[0, 1, 2, 3]) - 3f64.sqrt()).abs() < 1e-12);
    }
}
