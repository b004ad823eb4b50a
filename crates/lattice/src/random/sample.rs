//! Node sets that fill a box with a given mean spacing: blue noise (Poisson-disk) and a jittered
//! grid. Both are seeded and reproducible, and both *conform to the box*: corners, edges and faces
//! of the box carry nodes of their own (sampled first, with the same rules in one dimension less),
//! so a body cut from the box has flat faces exactly where the box has them. That makes loaded end
//! planes, symmetry planes and cross-section areas exact, which the moduli tests rely on.
//! Arbitrary shapes keep the nodes of the box that the shape contains.

use super::rng::Rng;

/// How nodes are placed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Sampler {
    /// Maximal Poisson-disk sampling (Bridson's algorithm per stratum): no two nodes closer than
    /// `r = c_d a`, no gap that could take another node. `c_d` is set so that the node density is
    /// about `1/a^d` (measured: see [`poisson_radius`]).
    Poisson,
    /// A grid of spacing about `a` whose nodes move by up to `amplitude * a / 2` along each axis
    /// (uniformly, independently); boundary nodes move only along their face.
    Jitter { amplitude: f64 },
}

impl Sampler {
    /// Name used on the command line and in case files.
    pub fn name(&self) -> &'static str {
        match self {
            Sampler::Poisson => "poisson",
            Sampler::Jitter { .. } => "jitter",
        }
    }
}

/// Poisson-disk radius for a mean spacing `a` in `dim` dimensions. Maximal Poisson-disk sets
/// reach a number density of about `0.70/r^2` (2D) and `0.73/r^3` (3D) (random sequential
/// adsorption to saturation: covered fraction 0.547 in 2D, 0.38 in 3D), so `r = 0.84 a` (2D) and
/// `r = 0.90 a` (3D) give about one node per `a^d`.
pub fn poisson_radius(dim: usize, a: f64) -> f64 {
    if dim == 2 {
        0.84 * a
    } else {
        0.90 * a
    }
}

/// Sample the box `[lo, hi]` (z ignored in 2D: `lo[2] = hi[2] = 0`) and keep the nodes for which
/// `inside` holds.
pub fn sample_box(
    dim: usize,
    lo: [f64; 3],
    hi: [f64; 3],
    a: f64,
    sampler: Sampler,
    seed: u64,
    inside: &dyn Fn([f64; 3]) -> bool,
) -> Vec<[f64; 3]> {
    sample_conforming(dim, lo, hi, a, sampler, seed, inside, &[]).0
}

/// A curved piece of a body's boundary that its nodes should lie on, as the box's faces do: a
/// surface (3D), a curve bounding a plate (2D), or a curved edge of a solid (3D). Poisson-disk
/// sampling puts nodes on it first, by Bridson's rule within the piece, then fills the rest.
///
/// The piece may be given larger than the body's boundary (a whole sphere, a cylinder's wall
/// beyond another shape): a node is kept on it only where the body's `inside` test says the
/// point is in the body and a step of `1e-6 a` along one of its normals leaves the body, so the
/// union and difference of shapes trim their pieces without being told how.
pub struct Curved<'a> {
    /// 1 for a curve, 2 for a surface.
    pub dim: usize,
    /// Points of the piece to grow from: one per part that the body may cut apart.
    pub starts: Vec<[f64; 3]>,
    /// The point of the piece nearest to a point close to it.
    pub project: Box<dyn Fn([f64; 3]) -> [f64; 3] + 'a>,
    /// Unit tangents (the first `dim`) and unit normals (the body's dimension less `dim`) at a
    /// point of the piece.
    pub frame: Box<dyn Fn([f64; 3]) -> Frame + 'a>,
}

/// Up to two unit tangents and up to two unit normals at a point of a [`Curved`] piece.
pub type Frame = ([[f64; 3]; 2], [[f64; 3]; 2]);

fn unit_axis(axis: usize) -> [f64; 3] {
    let mut e = [0.0; 3];
    e[axis] = 1.0;
    e
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn normalised(a: [f64; 3]) -> [f64; 3] {
    let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    if n > 0.0 {
        [a[0] / n, a[1] / n, a[2] / n]
    } else {
        [1.0, 0.0, 0.0]
    }
}

/// `p - c` without its component along `axis`, and that component.
fn split(p: [f64; 3], c: [f64; 3], axis: usize) -> ([f64; 3], f64) {
    let mut d = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
    let along = d[axis];
    d[axis] = 0.0;
    (d, along)
}

impl<'a> Curved<'a> {
    /// The sphere of centre `c` and radius `r` (3D).
    pub fn sphere(c: [f64; 3], r: f64) -> Curved<'a> {
        let starts = (0..6)
            .map(|k| {
                let mut p = c;
                p[k / 2] += if k % 2 == 0 { r } else { -r };
                p
            })
            .collect();
        Curved {
            dim: 2,
            starts,
            project: Box::new(move |p| {
                let n = normalised([p[0] - c[0], p[1] - c[1], p[2] - c[2]]);
                [c[0] + r * n[0], c[1] + r * n[1], c[2] + r * n[2]]
            }),
            frame: Box::new(move |p| {
                let n = normalised([p[0] - c[0], p[1] - c[1], p[2] - c[2]]);
                // A tangent from the axis least along n, then the third by the right hand.
                let k = (0..3)
                    .min_by(|&i, &j| n[i].abs().total_cmp(&n[j].abs()))
                    .unwrap_or(0);
                let t1 = normalised(cross(n, unit_axis(k)));
                ([t1, cross(n, t1)], [n, [0.0; 3]])
            }),
        }
    }

    /// The wall of the cylinder of radius `r` about the line through `c` along `axis` (3D),
    /// unbounded along the axis: the body's test trims it.
    pub fn cylinder_wall(c: [f64; 3], axis: usize, r: f64, half: f64) -> Curved<'a> {
        let e = unit_axis(axis);
        let (b1, b2) = (unit_axis((axis + 1) % 3), unit_axis((axis + 2) % 3));
        let mut starts = Vec::new();
        for s in [0.0, -0.9 * half, 0.9 * half] {
            for (u, v) in [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)] {
                starts.push([0, 1, 2].map(|k| c[k] + s * e[k] + r * (u * b1[k] + v * b2[k])));
            }
        }
        Curved {
            dim: 2,
            starts,
            project: Box::new(move |p| {
                let (d, along) = split(p, c, axis);
                let n = normalised(d);
                [0, 1, 2].map(|k| c[k] + along * e[k] + r * n[k])
            }),
            frame: Box::new(move |p| {
                let n = normalised(split(p, c, axis).0);
                ([e, cross(e, n)], [n, [0.0; 3]])
            }),
        }
    }

    /// The circle of radius `r` about `c` in the plane normal to `axis`: a plate's edge (2D,
    /// `axis` 2), or a solid's curved edge (3D, where both the radial and the axial direction
    /// are normals).
    pub fn circle(dim: usize, c: [f64; 3], axis: usize, r: f64) -> Curved<'a> {
        let e = unit_axis(axis);
        let (b1, b2) = (unit_axis((axis + 1) % 3), unit_axis((axis + 2) % 3));
        let starts = [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)]
            .iter()
            .map(|&(u, v)| [0, 1, 2].map(|k| c[k] + r * (u * b1[k] + v * b2[k])))
            .collect();
        Curved {
            dim: 1,
            starts,
            project: Box::new(move |p| {
                let n = normalised(split(p, c, axis).0);
                [0, 1, 2].map(|k| c[k] + r * n[k])
            }),
            frame: Box::new(move |p| {
                let n = normalised(split(p, c, axis).0);
                let normals = if dim == 3 { [n, e] } else { [n, [0.0; 3]] };
                ([cross(e, n), [0.0; 3]], normals)
            }),
        }
    }

    /// The plane through `c` normal to `axis` (3D), unbounded: the body's test trims it to a
    /// cylinder's flat end or a box's face.
    pub fn plane(c: [f64; 3], axis: usize, starts: Vec<[f64; 3]>) -> Curved<'a> {
        let e = unit_axis(axis);
        let (b1, b2) = (unit_axis((axis + 1) % 3), unit_axis((axis + 2) % 3));
        Curved {
            dim: 2,
            starts,
            project: Box::new(move |p| {
                let mut q = p;
                q[axis] = c[axis];
                q
            }),
            frame: Box::new(move |_| ([b1, b2], [e, [0.0; 3]])),
        }
    }
}

/// [`sample_box`] with nodes on the curved pieces of the boundary first (Poisson only: a
/// jittered grid has no distance rule to make room for them, so it ignores them). Returns the
/// nodes and how many of them, first in the list, lie on the curved pieces.
///
/// With curved pieces the box's strata place only nodes that the body holds (a node outside
/// would keep the body's own nodes at bay near the curved surface), reseeding each stratum until
/// a thousand random tries in a row find no room, since the body may cut a stratum apart.
#[allow(clippy::too_many_arguments)]
pub fn sample_conforming(
    dim: usize,
    lo: [f64; 3],
    hi: [f64; 3],
    a: f64,
    sampler: Sampler,
    seed: u64,
    inside: &dyn Fn([f64; 3]) -> bool,
    curved: &[Curved],
) -> (Vec<[f64; 3]>, usize) {
    let mut rng = Rng::new(seed);
    match sampler {
        Sampler::Jitter { amplitude } => {
            let pts = jittered(dim, lo, hi, a, amplitude, seed);
            (pts.into_iter().filter(|&p| inside(p)).collect(), 0)
        }
        Sampler::Poisson => {
            let r = poisson_radius(dim, a);
            let mut grid = Grid::new(dim, lo, hi, r);
            let mut pts: Vec<[f64; 3]> = Vec::new();
            // Curves before surfaces, as edges before faces.
            let mut order: Vec<&Curved> = curved.iter().collect();
            order.sort_by_key(|c| c.dim);
            for piece in order {
                grow_on(dim, piece, a, r, inside, &mut rng, &mut grid, &mut pts);
            }
            let on_curved = pts.len();
            let filter = if curved.is_empty() {
                None
            } else {
                Some(inside)
            };
            poisson(dim, lo, hi, r, &mut rng, &mut grid, &mut pts, filter);
            let kept = pts
                .iter()
                .enumerate()
                .filter(|&(i, p)| i < on_curved || inside(*p))
                .map(|(_, p)| *p)
                .collect();
            (kept, on_curved)
        }
    }
}

/// Bridson's rule on a curved piece: candidates in the shell `r..2r` of the tangent plane (or
/// line) at an active node, projected onto the piece.
#[allow(clippy::too_many_arguments)]
fn grow_on(
    dim: usize,
    piece: &Curved,
    a: f64,
    r: f64,
    inside: &dyn Fn([f64; 3]) -> bool,
    rng: &mut Rng,
    grid: &mut Grid,
    pts: &mut Vec<[f64; 3]>,
) {
    let step = 1e-6 * a;
    let normals = dim - piece.dim;
    // A point off the sampling box would share a clamped grid cell with another node, which
    // the one-node-per-cell grid cannot hold: such a piece is cut off at the box.
    let (glo, gcell, gn) = (grid.lo, grid.cell, grid.n);
    let on_boundary = |p: [f64; 3]| {
        if !inside(p) || !holds(glo, gcell, gn, p) {
            return false;
        }
        let (_, n) = (piece.frame)(p);
        n.iter().take(normals).any(|n| {
            let out = |s: f64| [p[0] + s * n[0], p[1] + s * n[1], p[2] + s * n[2]];
            !inside(out(step)) || !inside(out(-step))
        })
    };
    let mut active: Vec<[f64; 3]> = Vec::new();
    for &s in &piece.starts {
        let p = (piece.project)(s);
        if on_boundary(p) && grid.far_from_all(p, r) {
            grid.insert(p);
            active.push(p);
            pts.push(p);
        }
        // Candidates in the tangent plane (or line) at the centre, projected onto the piece.
        let candidate = |centre: [f64; 3], rng: &mut Rng| {
            let (t, _) = (piece.frame)(centre);
            let d = shell(piece.dim, r, rng);
            let mut p = centre;
            for (m, t) in t.iter().take(piece.dim).enumerate() {
                for c in 0..3 {
                    p[c] += d[m] * t[c];
                }
            }
            (piece.project)(p)
        };
        grow_front(&mut active, r, rng, grid, pts, &candidate, &|p| {
            on_boundary(*p)
        });
    }
}

/// The jittered grid's shape: `n[c]` intervals of `h[c]` along each sampled axis, so
/// `n[c] + 1` nodes, boundary nodes included.
#[derive(Clone, Copy, Debug)]
pub(crate) struct JitterGrid {
    pub dim: usize,
    pub lo: [f64; 3],
    pub n: [usize; 3],
    pub h: [f64; 3],
    pub amp: f64,
    pub seed: u64,
}

impl JitterGrid {
    pub fn new(dim: usize, lo: [f64; 3], hi: [f64; 3], a: f64, amp: f64, seed: u64) -> Self {
        let mut n = [0usize; 3];
        let mut h = [0.0; 3];
        for c in 0..dim {
            n[c] = ((hi[c] - lo[c]) / a).round().max(1.0) as usize;
            h[c] = (hi[c] - lo[c]) / n[c] as f64;
        }
        JitterGrid {
            dim,
            lo,
            n,
            h,
            amp,
            seed,
        }
    }

    /// Nodes along each axis (1 on a plate's z).
    pub fn count(&self) -> [usize; 3] {
        [0, 1, 2].map(|c| if c < self.dim { self.n[c] + 1 } else { 1 })
    }

    /// The node of grid index `idx`, from a stream of its own: seeded by the lattice's seed and
    /// the node's place in the grid, not by how many nodes were drawn before it, so any part of
    /// the grid can be sampled alone and gives the nodes the whole grid has there (a process
    /// building its own part of a body needs exactly that).
    pub fn node(&self, idx: [usize; 3]) -> [f64; 3] {
        let [ni, nj, _] = self.count();
        let linear = (idx[0] + ni * (idx[1] + nj * idx[2])) as u64;
        let mut rng = Rng::new(mix(mix(self.seed) ^ linear));
        let mut p = [0.0; 3];
        for c in 0..self.dim {
            p[c] = self.lo[c] + idx[c] as f64 * self.h[c];
            // Boundary nodes stay on their face: only their tangential coordinates move.
            let u = rng.uniform();
            if idx[c] > 0 && idx[c] < self.n[c] {
                p[c] += self.amp * self.h[c] * (u - 0.5);
            }
        }
        p
    }
}

/// SplitMix64's finaliser: neighbouring inputs give unrelated outputs, so that neighbouring
/// nodes' streams are unrelated.
fn mix(x: u64) -> u64 {
    let mut x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

fn jittered(dim: usize, lo: [f64; 3], hi: [f64; 3], a: f64, amp: f64, seed: u64) -> Vec<[f64; 3]> {
    let g = JitterGrid::new(dim, lo, hi, a, amp, seed);
    let [ni, nj, nk] = g.count();
    let mut out = Vec::with_capacity(ni * nj * nk);
    for k in 0..nk {
        for j in 0..nj {
            for i in 0..ni {
                out.push(g.node([i, j, k]));
            }
        }
    }
    out
}

/// Background grid for the distance checks: cells of side `r/sqrt(d)` hold at most one node.
/// Whether `p` lies in the box a grid of `n` cells of side `cell` from `lo` covers (an axis
/// of one cell is a plane's unused one).
fn holds(lo: [f64; 3], cell: f64, n: [usize; 3], p: [f64; 3]) -> bool {
    (0..3).all(|a| n[a] == 1 || (p[a] >= lo[a] && p[a] <= lo[a] + cell * n[a] as f64))
}

struct Grid {
    lo: [f64; 3],
    cell: f64,
    n: [usize; 3],
    /// Index steps along x, y and z of the arrays below, which hold a border of two empty
    /// cells around the box on each sampled axis: a cell's neighbours within two cells are
    /// then at fixed index offsets, with no test of the box's edges.
    stride: [usize; 3],
    /// The border's width on each axis (none on a plate's z).
    border: [usize; 3],
    /// The node of each cell, by value: a read at a random place (the Bridson front wanders)
    /// then misses the cache once, not twice as an index into the node list would.
    node: Vec<[f64; 3]>,
    /// One bit per cell, set when it holds a node: an eighth of a megabyte per million cells,
    /// so it stays in cache where `node` (192 times larger) would miss on nearly every read.
    /// Most cells are empty.
    full: Vec<u64>,
    /// The node of each cell to a 255th of the cell on each axis (3 bytes instead of 24): a
    /// 10^6-node body's 5.6 million cells take 17 MB, which the last-level cache holds, where
    /// `node` (134 MB) misses. The distance checks decide from it, and read `node` only when
    /// the rounding leaves the answer open (see [`Grid::far_from_all`]).
    coarse: Vec<[u8; 3]>,
    /// Cells whose node is further from its coarse position than the bound allows (only
    /// possible for a node clamped into an edge cell): always read exactly.
    loose: Vec<u64>,
    /// The cell offsets that can hold a node closer than `r`, nearest first, each with its
    /// index offset (see [`Grid::far_from_all`]).
    near: Vec<([i32; 3], isize)>,
}

/// Empty cells on each side of a sampled axis (the reach of [`Grid::far_from_all`]).
const BORDER: usize = 2;

impl Grid {
    fn new(dim: usize, lo: [f64; 3], hi: [f64; 3], r: f64) -> Self {
        let cell = r / (dim as f64).sqrt();
        let mut n = [1usize; 3];
        let mut padded = [1usize; 3];
        let mut border = [0usize; 3];
        for c in 0..dim {
            n[c] = ((hi[c] - lo[c]) / cell).floor() as usize + 1;
            border[c] = BORDER;
            padded[c] = n[c] + 2 * BORDER;
        }
        let stride = [1, padded[0], padded[0] * padded[1]];
        // Offsets within two cells (ceil(sqrt(3)) cells of side r/sqrt(d) cover the distance
        // r), ordered by the whole cells between (a gap of g cells on an axis keeps a node g
        // cells away) and then by distance: a rejected candidate usually meets its blocker in
        // the first few.
        let gap = |d: i32| (d.abs() - 1).max(0);
        let span = if dim == 3 { -2..=2 } else { 0..=0 };
        let mut near = Vec::new();
        for k in span {
            for j in -2..=2i32 {
                for i in -2..=2i32 {
                    let d = [i, j, k];
                    let step = (0..3).map(|a| d[a] as isize * stride[a] as isize).sum();
                    near.push((d, step));
                }
            }
        }
        near.sort_by_key(|(d, _)| {
            let g2 = gap(d[0]).pow(2) + gap(d[1]).pow(2) + gap(d[2]).pow(2);
            (g2, d[0].pow(2) + d[1].pow(2) + d[2].pow(2))
        });
        let cells = padded[0] * padded[1] * padded[2];
        Grid {
            lo,
            cell,
            n,
            stride,
            border,
            node: vec![[0.0; 3]; cells],
            full: vec![0; cells.div_ceil(64)],
            coarse: vec![[0; 3]; cells],
            loose: vec![0; cells.div_ceil(64)],
            near,
        }
    }

    fn cell_of(&self, p: [f64; 3]) -> [usize; 3] {
        let mut c = [0usize; 3];
        for a in 0..3 {
            // Truncation is the floor here: the quotient is clamped at 0 first (a NaN too).
            c[a] = (((p[a] - self.lo[a]) / self.cell).max(0.0) as usize).min(self.n[a] - 1);
        }
        c
    }

    /// Where cell `c` (of the box, not counting the border) sits in the arrays.
    fn index(&self, c: [usize; 3]) -> usize {
        (0..3)
            .map(|a| (c[a] + self.border[a]) * self.stride[a])
            .sum()
    }

    /// Whether no node lies closer than `r` to `p`. The answer does not depend on the order
    /// in which cells are visited, so visiting the nearest first changes no node set, only the
    /// time a rejection takes.
    ///
    /// Each full cell is first judged from its node's coarse position `q'`, which is within
    /// `e = (1/2 + 10^-6) cell / 255` of the node on each axis, so `| |p - q| - |p - q'| | <=
    /// sqrt(3) e = E`. A node with `|p - q'| < r - E` is certainly closer than `r`, one with
    /// `|p - q'| > r + E` certainly not; only between (a band of about 0.4 % of `r` on either
    /// side) is the node's exact position read. The bound `e` is checked at insertion on the
    /// very numbers used here (a cell where it fails is marked `loose` and always read
    /// exactly), and the thresholds carry a further relative margin of 10^-7, far above the
    /// rounding of the squared distances, so every answer is the exact test's `|p - q|^2 <
    /// r^2` on the node's own coordinates.
    fn far_from_all(&self, p: [f64; 3], r: f64) -> bool {
        let c = self.cell_of(p);
        let base = self.index(c) as isize;
        let r2 = r * r;
        let big = 3f64.sqrt() * (0.5 + 1e-6) * self.cell / 255.0;
        let sure_near = ((r - big) * (1.0 - 1e-7)).max(0.0).powi(2);
        let sure_far = ((r + big) * (1.0 + 1e-7)).powi(2);
        for &(d, step) in &self.near {
            // Within the border, so inside the arrays; a full cell lies in the box.
            let at = (base + step) as usize;
            if bit(&self.full, at) {
                let cd = [0, 1, 2].map(|a| (c[a] as i64 + d[a] as i64) as usize);
                let coarse = dist2(p, self.coarse_node(at, cd));
                let loose = bit(&self.loose, at);
                if !loose && coarse < sure_near {
                    return false;
                }
                if (loose || coarse <= sure_far) && dist2(p, self.node[at]) < r2 {
                    return false;
                }
            }
        }
        true
    }

    /// The coarse position of the node of cell `c` (`at` its index): the cell's corner plus
    /// whole 255ths of the cell.
    fn coarse_node(&self, at: usize, c: [usize; 3]) -> [f64; 3] {
        let w = self.coarse[at];
        let step = self.cell / 255.0;
        [
            (self.lo[0] + c[0] as f64 * self.cell) + w[0] as f64 * step,
            (self.lo[1] + c[1] as f64 * self.cell) + w[1] as f64 * step,
            (self.lo[2] + c[2] as f64 * self.cell) + w[2] as f64 * step,
        ]
    }

    /// Start loading the coarse cells within `reach` cells of `p` (a front node, around which
    /// its candidates are checked): the loads then overlap instead of each check waiting for
    /// its own. A prefetch changes no value.
    fn prefetch(&self, p: [f64; 3], reach: usize) {
        let c = self.cell_of(p);
        let span = |a: usize| c[a].saturating_sub(reach)..(c[a] + reach + 1).min(self.n[a]);
        let xs = span(0);
        for k in span(2) {
            for j in span(1) {
                let first = self.index([xs.start, j, k]);
                let last = self.index([xs.end - 1, j, k]);
                for at in (first..=last).step_by(64 / 3) {
                    hooke_sys::prefetch(&self.coarse[at]);
                }
                hooke_sys::prefetch(&self.coarse[last]);
            }
        }
    }

    fn insert(&mut self, p: [f64; 3]) {
        let c = self.cell_of(p);
        let at = self.index(c);
        self.node[at] = p;
        self.full[at >> 6] |= 1 << (at & 63);
        let step = self.cell / 255.0;
        self.coarse[at] = [0, 1, 2].map(|a| {
            let corner = self.lo[a] + c[a] as f64 * self.cell;
            ((p[a] - corner) / step).round().clamp(0.0, 255.0) as u8
        });
        // The bound far_from_all relies on, checked on the numbers it will use.
        let q = self.coarse_node(at, c);
        if (0..3).any(|a| (p[a] - q[a]).abs() > (0.5 + 5e-7) * step) {
            self.loose[at >> 6] |= 1 << (at & 63);
        }
    }
}

/// Bit `at` of a bitmap.
fn bit(bits: &[u64], at: usize) -> bool {
    bits[at >> 6] & (1 << (at & 63)) != 0
}

/// Squared distance between two points.
fn dist2(p: [f64; 3], q: [f64; 3]) -> f64 {
    (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)
}

/// A stratum of the box: each coordinate is fixed (at a face) or free within the box.
struct Stratum {
    fixed: [Option<f64>; 3],
}

#[allow(clippy::too_many_arguments)]
fn poisson(
    dim: usize,
    lo: [f64; 3],
    hi: [f64; 3],
    r: f64,
    rng: &mut Rng,
    grid: &mut Grid,
    pts: &mut Vec<[f64; 3]>,
    filter: Option<&dyn Fn([f64; 3]) -> bool>,
) {
    // Strata by dimension: corners, then edges, then faces, then the interior.
    let mut strata: Vec<(usize, Stratum)> = Vec::new();
    let combos = 3usize.pow(dim as u32);
    for m in 0..combos {
        let mut fixed = [Some(0.0); 3];
        let mut free = 0;
        let mut code = m;
        for c in 0..dim {
            fixed[c] = match code % 3 {
                0 => Some(lo[c]),
                1 => Some(hi[c]),
                _ => {
                    free += 1;
                    None
                }
            };
            code /= 3;
        }
        strata.push((free, Stratum { fixed }));
    }
    strata.sort_by_key(|s| s.0);
    for (free, s) in &strata {
        grow(*free, s, lo, hi, r, rng, grid, pts, filter);
    }
}

#[allow(clippy::too_many_arguments)]
fn grow(
    free: usize,
    s: &Stratum,
    lo: [f64; 3],
    hi: [f64; 3],
    r: f64,
    rng: &mut Rng,
    grid: &mut Grid,
    pts: &mut Vec<[f64; 3]>,
    filter: Option<&dyn Fn([f64; 3]) -> bool>,
) {
    let free_axes: Vec<usize> = (0..3).filter(|&c| s.fixed[c].is_none()).collect();
    let in_box = |p: &[f64; 3]| {
        free_axes.iter().all(|&c| p[c] >= lo[c] && p[c] <= hi[c]) && filter.is_none_or(|f| f(*p))
    };
    let place = |rng: &mut Rng| {
        let mut p = [0.0; 3];
        for c in 0..3 {
            p[c] = match s.fixed[c] {
                Some(v) => v,
                None => rng.range(lo[c], hi[c]),
            };
        }
        p
    };
    if free == 0 {
        let p = place(rng);
        if in_box(&p) && grid.far_from_all(p, r) {
            grid.insert(p);
            pts.push(p);
        }
        return;
    }
    // Bridson: seed once (the free part of a stratum is connected once lower strata are placed),
    // then grow from an active front, 30 candidates per node in the shell r..2r. A body that
    // filters the nodes may cut the stratum apart: then seed again until a thousand tries in a
    // row find no room.
    let mut active: Vec<[f64; 3]> = Vec::new();
    loop {
        for _ in 0..1000 {
            let p = place(rng);
            if in_box(&p) && grid.far_from_all(p, r) {
                grid.insert(p);
                active.push(p);
                pts.push(p);
                break;
            }
        }
        if active.is_empty() {
            return;
        }
        let candidate = |centre: [f64; 3], rng: &mut Rng| {
            let d = shell(free, r, rng);
            let mut p = centre;
            for (m, &c) in free_axes.iter().enumerate() {
                p[c] += d[m];
            }
            p
        };
        grow_front(&mut active, r, rng, grid, pts, &candidate, &in_box);
        if filter.is_none() {
            return;
        }
    }
}

/// Bridson's front: from a random active node, up to 30 candidates; the first kept one far
/// enough from every node joins the front, and a node with none left leaves it. The front
/// holds its nodes' positions rather than their indices: the pick is at a random place, and a
/// position there is one cache miss where an index into `pts` was two.
fn grow_front(
    active: &mut Vec<[f64; 3]>,
    r: f64,
    rng: &mut Rng,
    grid: &mut Grid,
    pts: &mut Vec<[f64; 3]>,
    candidate: &impl Fn([f64; 3], &mut Rng) -> [f64; 3],
    keep: &impl Fn(&[f64; 3]) -> bool,
) {
    const TRIES: usize = 30;
    while !active.is_empty() {
        let slot = rng.below(active.len());
        let centre = active[slot];
        // The candidates lie within 2r (3.5 cells) of the centre; prefetching 3 cells around
        // it was the fastest of 2 to 5 (a third off the sampling of a 10^6-node 3D body).
        grid.prefetch(centre, 3);
        let mut placed = false;
        for _ in 0..TRIES {
            let p = candidate(centre, rng);
            if keep(&p) && grid.far_from_all(p, r) {
                grid.insert(p);
                active.push(p);
                pts.push(p);
                placed = true;
                break;
            }
        }
        if !placed {
            active.swap_remove(slot);
        }
    }
}

/// A random offset uniform in the shell `r <= |d| < 2r` of dimension `k` (1, 2 or 3).
fn shell(k: usize, r: f64, rng: &mut Rng) -> [f64; 3] {
    loop {
        let mut d = [0.0; 3];
        for v in d.iter_mut().take(k) {
            *v = rng.range(-2.0 * r, 2.0 * r);
        }
        let n2: f64 = d.iter().map(|v| v * v).sum();
        if n2 >= r * r && n2 < 4.0 * r * r {
            return d;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn min_dist(p: &[[f64; 3]]) -> f64 {
        let mut m = f64::INFINITY;
        for i in 0..p.len() {
            for j in 0..i {
                let d = ((p[i][0] - p[j][0]).powi(2)
                    + (p[i][1] - p[j][1]).powi(2)
                    + (p[i][2] - p[j][2]).powi(2))
                .sqrt();
                m = m.min(d);
            }
        }
        m
    }

    #[test]
    fn poisson_keeps_its_distance_conforms_and_has_the_density() {
        for dim in [2, 3] {
            let hi = if dim == 2 {
                [12.0, 9.0, 0.0]
            } else {
                [8.0, 7.0, 6.0]
            };
            let p = sample_box(dim, [0.0; 3], hi, 1.0, Sampler::Poisson, 3, &|_| true);
            let r = poisson_radius(dim, 1.0);
            assert!(min_dist(&p) >= r * (1.0 - 1e-12));
            let vol: f64 = (0..dim).map(|c| hi[c]).product();
            let density = p.len() as f64 / vol;
            assert!((0.8..1.25).contains(&density), "dim {dim}: {density}");
            // Every face carries nodes exactly on it.
            for c in 0..dim {
                assert!(p.iter().filter(|q| q[c] == 0.0).count() > 3);
                assert!(p.iter().filter(|q| q[c] == hi[c]).count() > 3);
            }
            let again = sample_box(dim, [0.0; 3], hi, 1.0, Sampler::Poisson, 3, &|_| true);
            assert_eq!(p, again);
        }
    }

    #[test]
    fn the_grid_answers_as_a_search_of_every_node_would() {
        // The grid visits cells nearest first and skips empty ones by a bitmap; its answer
        // must be exactly that of comparing with every node, near the threshold too.
        for dim in [2, 3] {
            let hi = if dim == 2 {
                [9.0, 7.0, 0.0]
            } else {
                [6.0, 5.0, 4.0]
            };
            let r = poisson_radius(dim, 1.0);
            let pts = sample_box(dim, [0.0; 3], hi, 1.0, Sampler::Poisson, 5, &|_| true);
            let mut grid = Grid::new(dim, [0.0; 3], hi, r);
            for &p in &pts {
                grid.insert(p);
            }
            let mut rng = Rng::new(11);
            let mut near = 0;
            for _ in 0..20_000 {
                let mut p = [0.0; 3];
                for c in 0..dim {
                    p[c] = rng.range(0.0, hi[c]);
                }
                let brute = pts.iter().all(|q| {
                    (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2) >= r * r
                });
                assert_eq!(grid.far_from_all(p, r), brute, "at {p:?}");
                near += usize::from(!brute);
            }
            // Poisson sets are maximal: nearly every point of the box is within r of a node.
            assert!(near > 19_000, "{near}");
            // Points at distances from a node within and beyond the coarse positions' band
            // around r (0.4 % of r), down to the last bits: the answer is the exact one.
            let brute = |p: [f64; 3]| {
                pts.iter().all(|q| {
                    (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2) >= r * r
                })
            };
            let (mut inside, mut outside) = (0, 0);
            for (m, q) in pts.iter().enumerate().step_by(7) {
                for f in [
                    1e-2, 4e-3, 1e-3, 1e-6, 1e-12, 1e-15, 0.0, -1e-15, -1e-12, -1e-6, -1e-3, -4e-3,
                    -1e-2,
                ] {
                    let mut d = [0.0; 3];
                    for v in d.iter_mut().take(dim) {
                        *v = rng.range(-1.0, 1.0);
                    }
                    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                    let p = [0, 1, 2].map(|c| q[c] + d[c] / len * r * (1.0 + f));
                    let want = brute(p);
                    assert_eq!(grid.far_from_all(p, r), want, "node {m}, {f:e} of r");
                    if want {
                        outside += 1;
                    } else {
                        inside += 1;
                    }
                }
            }
            assert!(inside > 100 && outside > 5, "{inside} {outside}");
        }
    }

    #[test]
    fn jitter_fills_the_grid_and_keeps_boundary_nodes_on_their_faces() {
        let p = sample_box(
            3,
            [0.0; 3],
            [4.0, 3.0, 2.0],
            1.0,
            Sampler::Jitter { amplitude: 0.6 },
            1,
            &|_| true,
        );
        assert_eq!(p.len(), 5 * 4 * 3);
        assert!(p
            .iter()
            .all(|q| (0..3).all(|c| q[c] >= 0.0) && q[0] <= 4.0 && q[1] <= 3.0 && q[2] <= 2.0));
        assert_eq!(p.iter().filter(|q| q[0] == 0.0).count(), 12);
    }

    #[test]
    fn curved_nodes_lie_on_the_surface_cover_it_and_keep_their_distance() {
        // A ball of radius 4 (3D) and a disk of radius 5 (2D), centred in their boxes.
        for (dim, rad) in [(3, 4.0), (2, 5.0)] {
            let c = if dim == 3 { [4.5; 3] } else { [5.5, 5.5, 0.0] };
            let hi = if dim == 3 {
                [9.0; 3]
            } else {
                [11.0, 11.0, 0.0]
            };
            let dist = move |p: [f64; 3]| {
                ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2)).sqrt()
            };
            let inside = move |p: [f64; 3]| dist(p) <= rad + 1e-9;
            let piece = if dim == 3 {
                Curved::sphere(c, rad)
            } else {
                Curved::circle(2, c, 2, rad)
            };
            let (p, on) = sample_conforming(
                dim,
                [0.0; 3],
                hi,
                1.0,
                Sampler::Poisson,
                7,
                &inside,
                std::slice::from_ref(&piece),
            );
            let r = poisson_radius(dim, 1.0);
            assert!(on > 0 && on < p.len());
            // The curved nodes come first and lie on the surface to rounding.
            assert!(p[..on].iter().all(|&q| (dist(q) - rad).abs() < 1e-9 * rad));
            assert!(p[on..].iter().all(|&q| dist(q) < rad - 1e-9));
            assert!(min_dist(&p) >= r * (1.0 - 1e-12));
            // Maximal on the surface: no point of it is farther than 2r from a curved node
            // (Bridson's shell reaches 2r), checked on a dense set of surface points.
            let probes: Vec<[f64; 3]> = if dim == 3 {
                (0..400)
                    .map(|k| {
                        // A Fibonacci sphere.
                        let z = 1.0 - 2.0 * (k as f64 + 0.5) / 400.0;
                        let phi = k as f64 * 2.399_963_229_728_653;
                        let s = (1.0 - z * z).sqrt();
                        [
                            c[0] + rad * s * phi.cos(),
                            c[1] + rad * s * phi.sin(),
                            c[2] + rad * z,
                        ]
                    })
                    .collect()
            } else {
                (0..200)
                    .map(|k| {
                        let t = k as f64 * std::f64::consts::TAU / 200.0;
                        [c[0] + rad * t.cos(), c[1] + rad * t.sin(), 0.0]
                    })
                    .collect()
            };
            for q in probes {
                let near = p[..on]
                    .iter()
                    .map(|&s| {
                        ((s[0] - q[0]).powi(2) + (s[1] - q[1]).powi(2) + (s[2] - q[2]).powi(2))
                            .sqrt()
                    })
                    .fold(f64::INFINITY, f64::min);
                assert!(near <= 2.0 * r, "dim {dim}: a gap of {near} on the surface");
            }
            // The same seed gives the same nodes, bit for bit.
            let (again, on_again) = sample_conforming(
                dim,
                [0.0; 3],
                hi,
                1.0,
                Sampler::Poisson,
                7,
                &inside,
                std::slice::from_ref(&piece),
            );
            assert_eq!(on, on_again);
            assert!(p.iter().zip(&again).all(|(x, y)| x == y) && p.len() == again.len());
        }
    }
}
