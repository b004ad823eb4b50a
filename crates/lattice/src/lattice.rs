//! Lattices: reference node positions, node cell volumes and the spring topology (CSR).
//!
//! Two regular lattices are built here, both isotropic for the linear elasticity of central
//! springs (paper Section 2):
//!
//! * [`LatticeKind::Cubic`], Ladd's cubic lattice: nodes on a simple cubic grid of spacing `a`,
//!   springs to the 6 nearest (length `a`, group A of the paper's Fig. 2) and the 12
//!   second-nearest neighbours (length `a*sqrt(2)`, group B). Node cell volume `a^3`.
//! * [`LatticeKind::Hex`], the 2D hexagonal (triangular) lattice: rows along x at spacing `a`,
//!   rows `sqrt(3)/2 a` apart, odd rows shifted by `a/2`; 6 neighbours at distance `a`.
//!   Node cell area `sqrt(3)/2 a^2`.
//!
//! The topology is immutable once built; whether a spring is intact lives in
//! `hooke_core::State`.

use std::sync::OnceLock;

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::math::{Coords, Real, Vector};

/// Which regular lattice.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum LatticeKind {
    /// Ladd's 3D cubic lattice (6 + 12 neighbours).
    Cubic,
    /// 2D hexagonal (triangular) lattice (6 neighbours).
    Hex,
    /// 2D random lattice: Delaunay triangulation of scattered nodes ([`crate::random`]).
    Random2d,
    /// 3D random lattice: Delaunay tetrahedralisation of scattered nodes.
    Random3d,
}

impl LatticeKind {
    /// Spatial dimension of the lattice's elasticity (2 or 3).
    pub fn dim(self) -> usize {
        match self {
            LatticeKind::Cubic | LatticeKind::Random3d => 3,
            LatticeKind::Hex | LatticeKind::Random2d => 2,
        }
    }

    /// Springs per node in the bulk (the mean for random lattices: 6 for any planar Delaunay
    /// triangulation, about 15.5 for a 3D Poisson point set).
    pub fn coordination(self) -> usize {
        match self {
            LatticeKind::Cubic => 18,
            LatticeKind::Hex | LatticeKind::Random2d => 6,
            LatticeKind::Random3d => 15,
        }
    }

    /// True for the random lattices (springs of many lengths and stiffnesses).
    pub fn is_random(self) -> bool {
        matches!(self, LatticeKind::Random2d | LatticeKind::Random3d)
    }

    /// Name used on the command line and in case files.
    pub fn name(self) -> &'static str {
        match self {
            LatticeKind::Cubic => "cubic",
            LatticeKind::Hex => "hex",
            LatticeKind::Random2d => "random2d",
            LatticeKind::Random3d => "random3d",
        }
    }
}

/// Spring topology in compressed-row form: every spring is listed from both of its ends, so a
/// node's row holds all of its springs and force kernels can gather into the node alone.
///
/// Entries of row `n` are `offsets[n]..offsets[n+1]`; entry `e` names the undirected spring
/// `bond[e]` and the neighbour at its other end ([`Bonds::neighbour`]). Rows are sorted by
/// neighbour index, which fixes the order of every per-node sum and so makes results
/// independent of how the lattice was generated.
///
/// Each neighbour is read as the other end of the entry's spring, `ends[b][0] ^ ends[b][1] ^ n`.
/// The one reader that streams them every step, the CSR kernel, has them as an array of their
/// own (4 bytes per entry), built only for lattices the CSR kernel may run
/// ([`csr_may_run`]; [`Bonds::keep_neighbours`] builds it for a caller that
/// asks for that kernel anyway). On random3d that is 59 bytes per node, on Ladd's lattice 72.
/// Whether the general (CSR) kernel could ever run a body of a lattice with periods `period`
/// (0: not periodic): on a periodic lattice, or where no vector stencil can run (neither
/// AVX-512 nor AVX2, or `Simd::Portable`: [`hooke_sys::simd::lanes`]), since a stencil body that
/// softens moves to a general kernel. Only then is the rows' neighbour array built.
pub fn csr_may_run(period: [Real; 3]) -> bool {
    period.iter().any(|&p| p > 0.0) || hooke_sys::simd::lanes().is_none()
}

#[derive(Clone, Debug, Default)]
pub struct Bonds {
    pub offsets: Vec<u32>,
    /// Neighbour of each entry, or empty once shed.
    nbr: Vec<u32>,
    pub bond: Vec<u32>,
    /// End nodes of each undirected spring, `ends[b][0] < ends[b][1]`.
    pub ends: Vec<[u32; 2]>,
    /// Rest length `L_b` of each spring (m), or empty once shed ([`Lattice::shed_setup`]):
    /// read them with [`Lattice::rest`].
    rest: Vec<Real>,
}

impl Bonds {
    /// The stored rest lengths, or `None` once shed (then [`Lattice::rest`] computes each).
    #[inline]
    pub fn stored_rest(&self) -> Option<&[Real]> {
        (self.rest.len() == self.ends.len()).then_some(&self.rest[..])
    }

    /// Build from a list of undirected springs `(i, j)` with `i != j`; rest lengths from `pos`
    /// (minimum image along the axes where `period` is non-zero). The list becomes the springs'
    /// `ends` in place: a large block's pairs are its largest set-up array, and a copy of them
    /// was a second one to allocate and first touch.
    pub fn from_pairs(
        n_nodes: usize,
        pairs: Vec<[u32; 2]>,
        pos: &Coords,
        period: [Real; 3],
    ) -> Result<Self> {
        if n_nodes > u32::MAX as usize || 2 * pairs.len() > u32::MAX as usize {
            return Err(Error::InvalidInput {
                what: "lattice size",
                why: format!(
                    "{n_nodes} nodes and {} springs exceed the 32-bit indices; split the body",
                    pairs.len()
                ),
            });
        }
        let mut ends = pairs;
        ends.par_iter_mut().with_min_len(1 << 16).for_each(|e| {
            if e[0] > e[1] {
                e.swap(0, 1);
            }
        });
        // Regular lattices list their springs in order already.
        if !ends.is_sorted_by(|a, b| a < b) {
            ends.sort_unstable();
            ends.dedup();
        }
        let rest = ends
            .par_iter()
            .with_min_len(1 << 16)
            .map(|&[i, j]| reference_length(reference_vector(pos, period, i as usize, j as usize)))
            .collect();
        let mut bonds = Self::assemble(n_nodes, ends, rest);
        if csr_may_run(period) {
            bonds.keep_neighbours();
        }
        Ok(bonds)
    }

    /// The rows of the springs `ends`, sorted by `(i, j)` with `i < j`, and their rest lengths
    /// (one thread: see [`GridSprings::build`]).
    fn assemble(n_nodes: usize, ends: Vec<[u32; 2]>, rest: Vec<Real>) -> Self {
        let mut deg = vec![0u32; n_nodes + 1];
        for &[i, j] in &ends {
            deg[i as usize] += 1;
            deg[j as usize] += 1;
        }
        let mut offsets = vec![0u32; n_nodes + 1];
        for n in 0..n_nodes {
            offsets[n + 1] = offsets[n] + deg[n];
        }
        let m = offsets[n_nodes] as usize;
        let mut bond = vec![0u32; m];
        let mut fill: Vec<u32> = offsets[..n_nodes].to_vec();
        // Springs are sorted by (i, j), so filling in this order gives rows sorted by neighbour:
        // for node n, entries with a smaller neighbour arrive (as the j end) before larger ones.
        for (b, &[i, j]) in ends.iter().enumerate() {
            for a in [i, j] {
                bond[fill[a as usize] as usize] = b as u32;
                fill[a as usize] += 1;
            }
        }
        let bonds = Bonds {
            offsets,
            nbr: Vec::new(),
            bond,
            ends,
            rest,
        };
        debug_assert!(
            (0..n_nodes).all(|n| bonds.links(n).map(|(j, _)| j).is_sorted_by(|a, b| a < b))
        );
        bonds
    }

    /// Number of undirected springs.
    pub fn len(&self) -> usize {
        self.ends.len()
    }

    /// True when there is no spring.
    pub fn is_empty(&self) -> bool {
        self.ends.is_empty()
    }

    /// Range of node `n`'s entries.
    #[inline]
    pub fn row(&self, n: usize) -> std::ops::Range<usize> {
        self.offsets[n] as usize..self.offsets[n + 1] as usize
    }

    /// The neighbour of node `n` across its row entry `e`.
    #[inline(always)]
    pub fn neighbour(&self, n: usize, e: usize) -> usize {
        match self.nbr.get(e) {
            Some(&j) => j as usize,
            None => self.other_end(n, self.bond[e] as usize),
        }
    }

    /// The end of spring `b` that is not node `n` (`n` must be one of its ends).
    #[inline(always)]
    pub fn other_end(&self, n: usize, b: usize) -> usize {
        let [i, j] = self.ends[b];
        debug_assert!(i as usize == n || j as usize == n);
        (i ^ j) as usize ^ n
    }

    /// Node `n`'s neighbours and springs, `(j, b)`, in row order.
    #[inline]
    pub fn links(&self, n: usize) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.row(n)
            .map(move |e| (self.neighbour(n, e), self.bond[e] as usize))
    }

    /// The entry of node `n`'s row whose neighbour is `j`, if they are linked (a binary search:
    /// rows are sorted by neighbour).
    pub fn entry(&self, n: usize, j: usize) -> Option<usize> {
        let r = self.row(n);
        let at = if self.nbr.is_empty() {
            self.bond[r.clone()].binary_search_by(|&b| self.other_end(n, b as usize).cmp(&j))
        } else {
            self.nbr[r.clone()].binary_search(&(j as u32))
        };
        at.ok().map(|k| r.start + k)
    }

    /// The neighbour array, when kept (see [`Bonds::shed_neighbours`]).
    #[inline]
    pub fn neighbours(&self) -> Option<&[u32]> {
        (!self.nbr.is_empty() || self.bond.is_empty()).then_some(&self.nbr[..])
    }

    /// Heap bytes of the stored rest lengths (none once shed).
    pub fn rest_bytes(&self) -> usize {
        crate::memory::bytes(&self.rest)
    }

    /// Heap bytes of the rows: offsets, neighbours (while kept), springs.
    pub fn row_bytes(&self) -> usize {
        use crate::memory::bytes;
        bytes(&self.offsets) + bytes(&self.nbr) + bytes(&self.bond)
    }

    /// Build the neighbour array, if it is not kept (see [`Bonds::shed_neighbours`]): for a
    /// caller that runs the CSR kernel on a lattice built without it.
    pub fn keep_neighbours(&mut self) {
        if !self.nbr.is_empty() {
            return;
        }
        let mut nbr = vec![0u32; self.bond.len()];
        nbr.par_chunks_mut(1 << 16)
            .enumerate()
            .for_each(|(c, out)| {
                let start = c << 16;
                // The node of entry `start`: the last row that begins at or before it.
                let mut n = self.offsets.partition_point(|&o| o as usize <= start) - 1;
                for (k, v) in out.iter_mut().enumerate() {
                    let e = start + k;
                    while self.offsets[n + 1] as usize <= e {
                        n += 1;
                    }
                    *v = self.other_end(n, self.bond[e] as usize) as u32;
                }
            });
        self.nbr = nbr;
    }

    /// Free the neighbour array: every neighbour is then read from the springs' ends (one more
    /// indirection, 4 bytes fewer per entry).
    pub fn shed_neighbours(&mut self) {
        self.nbr = Vec::new();
    }
}

/// A lattice's springs, read as [`Bonds`] (`Deref`). A box of Ladd's or the hexagonal lattice
/// without a periodic axis has springs that follow from its grid alone ([`GridSprings`]): they
/// are built when something first reads them (a broken spring's ends, the general kernels, the
/// quasi-static solvers, a frame once a spring has broken), exactly as the box's constructor
/// built them before, and an intact body the stencils run never holds them (Ladd's rows and
/// ends: 146 bytes per node; its frames and prescribed nodes read the grid through
/// `hooke_core::law::GridLaw`). Changing them through `DerefMut`
/// makes them explicit for good; the changes that keep every value (shedding or storing rest
/// lengths, the neighbour array) keep the grid.
#[derive(Clone, Debug)]
pub struct Topology {
    built: OnceLock<Bonds>,
    /// The grid the springs follow from, while nothing has changed them.
    grid: Option<GridSprings>,
}

impl From<Bonds> for Topology {
    fn from(b: Bonds) -> Self {
        Topology {
            built: OnceLock::from(b),
            grid: None,
        }
    }
}

impl Topology {
    fn of_grid(g: GridSprings) -> Self {
        Topology {
            built: OnceLock::new(),
            grid: Some(g),
        }
    }

    /// Number of undirected springs (built or not).
    pub fn len(&self) -> usize {
        match (&self.grid, self.built.get()) {
            (Some(g), _) => g.springs,
            (None, Some(b)) => b.len(),
            (None, None) => 0,
        }
    }

    /// True when there is no spring.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The box grid the springs follow from, while nothing has changed them: its fast path
    /// ([`GridSprings::links`]) gives the built rows' values in their order without building.
    #[inline]
    pub fn grid(&self) -> Option<&GridSprings> {
        self.grid.as_ref()
    }

    /// Whether the rows and ends are held (built, or given).
    pub fn is_built(&self) -> bool {
        self.built.get().is_some()
    }

    /// The stored rest lengths: `None` once shed, or while a grid's springs are not built
    /// (then [`Lattice::rest`] computes each).
    #[inline]
    pub fn stored_rest(&self) -> Option<&[Real]> {
        self.built.get().and_then(|b| b.stored_rest())
    }

    /// Heap bytes of the rows (none while not built).
    pub fn row_bytes(&self) -> usize {
        self.built.get().map_or(0, |b| b.row_bytes())
    }

    /// Heap bytes of the stored rest lengths.
    pub fn rest_bytes(&self) -> usize {
        self.built.get().map_or(0, |b| b.rest_bytes())
    }

    /// Heap bytes of the springs' ends.
    pub fn ends_bytes(&self) -> usize {
        self.built
            .get()
            .map_or(0, |b| crate::memory::bytes(&b.ends))
    }

    /// The built springs, to change them in ways that keep every value (the grid stays).
    fn built_mut(&mut self) -> &mut Bonds {
        let _ = &**self;
        self.built.get_mut().expect("built just above")
    }
}

impl std::ops::Deref for Topology {
    type Target = Bonds;

    #[inline]
    fn deref(&self) -> &Bonds {
        self.built.get_or_init(|| {
            self.grid
                .as_ref()
                .expect("a topology is given or has a grid")
                .build()
        })
    }
}

impl std::ops::DerefMut for Topology {
    fn deref_mut(&mut self) -> &mut Bonds {
        let _ = &**self;
        self.grid = None;
        self.built.get_mut().expect("built just above")
    }
}

/// The springs of a box lattice without a periodic axis, known from its grid: a node is
/// linked to each neighbour of its star that lies in the box (Ladd's 18; the hexagonal
/// lattice's 6, which follow the row's parity), with rest length `|X_j - X_i|` of the
/// positions the box was built with.
#[derive(Clone, Copy, Debug)]
pub struct GridSprings {
    /// Nodes per axis (`[nx, rows, 1]` for the hexagonal lattice).
    pub n: [usize; 3],
    /// Spacing `a` (m).
    pub a: Real,
    /// The hexagonal lattice (else Ladd's).
    hex: bool,
    springs: usize,
    /// Whether the rows, once built, leave the rest lengths to [`Lattice::rest`].
    shed_rest: bool,
}

/// Ladd's star, each spring from its lower-numbered end in a box: the other 9 are these
/// negated.
const HALF_STAR: [[i64; 3]; 9] = [
    [1, 0, 0],
    [0, 1, 0],
    [0, 0, 1],
    [1, 1, 0],
    [1, -1, 0],
    [1, 0, 1],
    [1, 0, -1],
    [0, 1, 1],
    [0, 1, -1],
];

/// A grid's star in row order ([`GridSprings::star`]): per row parity, each neighbour's grid
/// offset and index step, ascending by step.
#[derive(Clone, Copy, Debug)]
pub struct Star {
    dirs: [[([i64; 3], i64); 18]; 2],
    len: usize,
}

impl GridSprings {
    fn cubic(n: [usize; 3], a: Real) -> Self {
        // A star direction d fits (n_x - |d_x|)(n_y - |d_y|)(n_z - |d_z|) times.
        let springs = HALF_STAR
            .iter()
            .map(|d| {
                (0..3)
                    .map(|c| n[c] - d[c].unsigned_abs() as usize)
                    .product::<usize>()
            })
            .sum();
        GridSprings {
            n,
            a,
            hex: false,
            springs,
            shed_rest: false,
        }
    }

    fn hex(nx: usize, rows: usize, a: Real) -> Self {
        // nx - 1 along each row, 2 nx - 1 between two rows.
        GridSprings {
            n: [nx, rows, 1],
            a,
            hex: true,
            springs: (nx - 1) * rows + (rows - 1) * (2 * nx - 1),
            shed_rest: false,
        }
    }

    /// The star's offsets in the order a node's row lists its neighbours (ascending index:
    /// by index step), for [`GridSprings::links`].
    pub fn star(&self) -> Star {
        let n = self.n.map(|v| v as i64);
        let mut star = Star {
            dirs: [[([0i64; 3], 0i64); 18]; 2],
            len: if self.hex { 6 } else { 18 },
        };
        for (parity, dirs) in star.dirs.iter_mut().enumerate() {
            if self.hex {
                // From an even row the rows above and below are reached at columns c - 1 and
                // c, from an odd one at c and c + 1.
                let s = parity as i64;
                let hex = [[1, 0], [-1, 0], [s - 1, 1], [s, 1], [s - 1, -1], [s, -1]];
                for (k, d) in hex.iter().enumerate() {
                    dirs[k] = ([d[0], d[1], 0], d[0] + n[0] * d[1]);
                }
            } else {
                for (k, d) in HALF_STAR.iter().enumerate() {
                    for (s, d) in [(0, *d), (1, d.map(|x| -x))] {
                        dirs[2 * k + s] = (d, d[0] + n[0] * (d[1] + n[1] * d[2]));
                    }
                }
            }
            dirs[..star.len].sort_unstable_by_key(|&(_, step)| step);
        }
        star
    }

    /// Node `i`'s links in row order, each as `f(j, L)`: the neighbour and the rest length
    /// the built rows hold (the same bits); `star` from [`GridSprings::star`].
    #[inline]
    pub fn links(&self, star: &Star, i: usize, mut f: impl FnMut(usize, Real)) {
        let g = self.coords(i);
        let parity = if self.hex { g[1] % 2 } else { 0 };
        let from = self.position(g);
        for &(d, step) in &star.dirs[parity][..star.len] {
            let h = [0, 1, 2].map(|c| g[c] as i64 + d[c]);
            if (0..3).all(|c| (0..self.n[c] as i64).contains(&h[c])) {
                let to = self.position(h.map(|v| v as usize));
                let l = reference_length([0, 1, 2].map(|c| to[c] - from[c]));
                f((i as i64 + step) as usize, l);
            }
        }
    }

    /// The cube share (the module's `cube_share`) of the spring between nodes `i` and `j` of a box of
    /// Ladd's lattice (`i == j`: of node `i`), as [`Lattice::cell_fractions`] gives it for the
    /// built box: a cube is in the box when its corner is.
    pub fn cube_share(&self, i: usize, j: usize) -> Real {
        debug_assert!(!self.hex);
        let n = self.n.map(|v| v as i64);
        let at = |i: usize| self.coords(i).map(|v| v as i64);
        cube_share(at(i), at(j), |c| {
            (0..3).all(|ax| c[ax] >= 0 && c[ax] + 1 < n[ax])
        })
    }

    /// Whether each cube about node `i` of a box of Ladd's lattice lies in the box (the node is
    /// a spacing or more inside every face): each of its springs' [`GridSprings::cube_share`]
    /// is then 1.
    #[inline]
    pub fn is_inner(&self, i: usize) -> bool {
        let g = self.coords(i);
        (0..3).all(|c| g[c] >= 1 && g[c] + 2 <= self.n[c])
    }

    /// How many springs the box has.
    pub fn springs(&self) -> usize {
        self.springs
    }

    /// Whether this is a box of Ladd's lattice (else the hexagonal one).
    pub fn is_cubic(&self) -> bool {
        !self.hex
    }

    fn coords(&self, i: usize) -> [usize; 3] {
        let (nx, ny) = (self.n[0], self.n[1]);
        [i % nx, (i / nx) % ny, i / (nx * ny)]
    }

    /// The position node `g` was built at: by the operations of [`cubic_positions`] and
    /// [`hex_positions`].
    #[inline(always)]
    fn position(&self, g: [usize; 3]) -> [Real; 3] {
        let a = self.a;
        if self.hex {
            let shift = if g[1] % 2 == 1 { 0.5 * a } else { 0.0 };
            [
                g[0] as Real * a + shift,
                g[1] as Real * hex_row_step(a),
                0.0,
            ]
        } else {
            g.map(|v| v as Real * a)
        }
    }

    /// The rest length of the spring between nodes `i` and `j` (the built one's bits).
    fn rest(&self, i: usize, j: usize) -> Real {
        let (pi, pj) = (self.position(self.coords(i)), self.position(self.coords(j)));
        reference_length([0, 1, 2].map(|c| pj[c] - pi[c]))
    }

    /// The rows and ends, exactly as the box's constructor built them before: each node's
    /// forward links in row order are the springs sorted by `(i, j)`, with the rest lengths
    /// the constructor computed ([`GridSprings::links`]).
    ///
    /// On one thread, with no rayon call: the first read may come from a task of a parallel
    /// loop, and a join here could take up another task of that loop, which would wait for
    /// this very initialisation (a reentrant one: a deadlock).
    fn build(&self) -> Bonds {
        let total: usize = self.n.iter().product();
        let star = self.star();
        let mut ends = Vec::with_capacity(self.springs);
        let mut rest = Vec::with_capacity(if self.shed_rest { 0 } else { self.springs });
        for i in 0..total {
            self.links(&star, i, |j, l| {
                if j > i {
                    ends.push([i as u32, j as u32]);
                    if !self.shed_rest {
                        rest.push(l);
                    }
                }
            });
        }
        debug_assert_eq!(ends.len(), self.springs);
        let mut b = Bonds::assemble(total, ends, rest);
        if csr_may_run([0.0; 3]) {
            let mut nbr = vec![0u32; b.bond.len()];
            for n in 0..total {
                for e in b.row(n) {
                    nbr[e] = b.other_end(n, b.bond[e] as usize) as u32;
                }
            }
            b.nbr = nbr;
        }
        b
    }
}

/// Reference vector from node `i` to node `j`: `X_j - X_i`, wrapped to the nearest image along
/// periodic axes (`period[c] > 0`).
#[inline(always)]
pub fn reference_vector(pos: &Coords, period: [Real; 3], i: usize, j: usize) -> [Real; 3] {
    let mut d = [
        pos.x()[j] - pos.x()[i],
        pos.y()[j] - pos.y()[i],
        pos.z()[j] - pos.z()[i],
    ];
    for c in 0..3 {
        let p = period[c];
        if p > 0.0 {
            if d[c] > 0.5 * p {
                d[c] -= p;
            } else if d[c] < -0.5 * p {
                d[c] += p;
            }
        }
    }
    d
}

/// A spring's rest length from its reference vector `D`, `|D|`: the one formula that builds
/// the rest lengths ([`Bonds::from_pairs`]) and recomputes them once shed ([`Lattice::rest`]),
/// so both give the same bits.
#[inline(always)]
pub fn reference_length(d: [Real; 3]) -> Real {
    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
}

/// Volumes that differ from node to node and from spring to spring (random lattices): what each
/// node and each spring stands for, in m^3 (a 2D plate's areas times its thickness).
#[derive(Clone, Debug, PartialEq)]
pub struct Cells {
    pub node: Vec<Real>,
    /// Each spring's volume. Only a body's set-up reads it (its stiffness `kappa V_s / L_s^2`):
    /// empty once [`Lattice::shed_setup`] freed it.
    pub spring: Vec<Real>,
    /// Each node's share of the body's boundary as an area vector (m^2, outward; a 2D plate's
    /// edge lengths times its thickness): a third (3D) or a half (2D) of each boundary facet
    /// around it. Zero inside. Tractions are spread over faces with it; empty once
    /// [`Lattice::shed_setup`] freed it.
    pub surface: Vec<[Real; 3]>,
    /// How the nodes were scattered: the calibration depends on it.
    pub sampler: crate::random::Sampler,
}

/// A lattice filled into a region: reference geometry and spring topology.
#[derive(Clone, Debug)]
pub struct Lattice {
    pub kind: LatticeKind,
    /// Lattice spacing `a` (m).
    pub spacing: Real,
    /// Reference node positions (m).
    pub pos: Coords,
    /// Volume each node stands for: `a^3` (cubic) or `sqrt(3)/2 a^2 h` (hex plate of thickness h).
    pub cell_volume: Real,
    /// Plate thickness `h` for 2D lattices (m); 1 for 3D.
    pub thickness: Real,
    /// Box length along each periodic axis (m); 0 where the axis is not periodic. Springs across
    /// a periodic boundary join a node to its neighbour's nearest image.
    pub period: [Real; 3],
    /// For box lattices: nodes per axis (`[nx, ny, 1]` for hex, with `ny` rows). Node index is
    /// `ix + nx * (iy + ny * iz)`.
    pub grid: Option<[usize; 3]>,
    /// The springs ([`Topology`]: read as [`Bonds`]; a box of a regular lattice builds them
    /// only when first read).
    pub bonds: Topology,
    /// Per-node and per-spring volumes of random lattices; `None` for the regular lattices, whose
    /// nodes all stand for `cell_volume`.
    pub cells: Option<Cells>,
}

impl Lattice {
    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.pos.len()
    }

    /// True when there is no node.
    pub fn is_empty(&self) -> bool {
        self.pos.is_empty()
    }

    /// Spatial dimension (2 or 3).
    pub fn dim(&self) -> usize {
        self.kind.dim()
    }

    /// True when some axis is periodic.
    pub fn is_periodic(&self) -> bool {
        self.period.iter().any(|&p| p > 0.0)
    }

    /// Free what only a set-up reads, once the body is built and its loads are spread: each
    /// spring's volume (the stiffnesses hold it) and each node's boundary area (tractions are
    /// spread with it); the node volumes shrink to their length. On a random3d body that is 91
    /// bytes per node (`hooke bench --json`, `memory_parts`). A body built from the lattice
    /// afterwards (`hooke_core::body::Body::from_cells`) or a traction spread over it would need
    /// them: both refuse a shed lattice. Regular lattices keep nothing of the kind.
    ///
    /// The rest lengths go too where every one of them is `|X_j - X_i|` to the bit, computed
    /// as [`Bonds::from_pairs`] computed it (a lattice that was not moved or periodic since),
    /// and no kernel streams them ([`csr_may_run`]): [`Lattice::rest`]
    /// then recomputes each one, a square root of values already loaded, instead of 8 bytes
    /// per spring (59 bytes per random3d node).
    pub fn shed_setup(&mut self) {
        if let Some(c) = &mut self.cells {
            c.spring = Vec::new();
            c.surface = Vec::new();
            c.node.shrink_to_fit();
        }
        if !csr_may_run(self.period) {
            self.shed_rest();
        }
    }

    /// Free the stored rest lengths if every one is `|X_j - X_i|` to the bit, computed as
    /// [`Bonds::from_pairs`] computed it (no periodic axis, and no node moved since); whether
    /// they are shed. [`Lattice::rest`] then recomputes each one where it is read.
    pub fn shed_rest(&mut self) -> bool {
        let built = self.bonds.is_built();
        if let Some(g) = self.bonds.grid().copied() {
            // A box moved since it was built (a case's box away from the origin) may round
            // some `|X_j - X_i|` otherwise than the lengths it was built with: those are kept,
            // so that every reader of a shed length (the frame, the CSR kernel) finds them.
            if !self.grid_rest_is_geometric(&g) {
                return self.bonds.stored_rest().is_none() && built && !self.bonds.is_empty();
            }
        }
        if let (Some(g), false) = (&mut self.bonds.grid, built) {
            // A box's rest lengths follow from its grid, wherever its nodes now are.
            g.shed_rest = true;
            return g.springs > 0;
        }
        if !self.is_periodic() && self.rest_is_geometric() {
            self.bonds.built_mut().rest = Vec::new();
        }
        self.bonds.stored_rest().is_none() && !self.bonds.is_empty()
    }

    /// Whether each of a box's rest lengths, those of the positions it was built with
    /// ([`GridSprings::links`]), is `|X_j - X_i|` of its nodes' present positions, to the bit.
    fn grid_rest_is_geometric(&self, g: &GridSprings) -> bool {
        // Nodes where the box put them give the same lengths; only a moved box is checked
        // spring by spring.
        let in_place = (0..self.len())
            .into_par_iter()
            .with_min_len(1 << 12)
            .all(|i| {
                let p = g.position(g.coords(i));
                (0..3).all(|c| self.pos.comp(c)[i].to_bits() == p[c].to_bits())
            });
        if in_place {
            return true;
        }
        let star = g.star();
        (0..self.len())
            .into_par_iter()
            .with_min_len(1 << 12)
            .all(|i| {
                let mut same = true;
                g.links(&star, i, |j, l| {
                    if j > i {
                        let here = reference_length(self.reference_vector(i, j));
                        same &= here.to_bits() == l.to_bits();
                    }
                });
                same
            })
    }

    /// Whether every stored rest length equals the one [`Lattice::rest`] would compute, bit
    /// for bit (true once shed).
    fn rest_is_geometric(&self) -> bool {
        let Some(rest) = self.bonds.stored_rest() else {
            return true;
        };
        rest.par_iter()
            .with_min_len(1 << 16)
            .enumerate()
            .all(|(b, &l)| self.geometric_rest(b).to_bits() == l.to_bits())
    }

    /// Rest length `L_b` of spring `b` (m): stored, or once shed ([`Lattice::shed_setup`])
    /// `|X_j - X_i|` by the operations that built it ([`Bonds::from_pairs`]; for a box whose
    /// springs follow from its grid, of the positions it was built with).
    #[inline(always)]
    pub fn rest(&self, b: usize) -> Real {
        match self.bonds.rest.get(b) {
            Some(&l) => l,
            None => self.geometric_rest(b),
        }
    }

    #[inline(always)]
    fn geometric_rest(&self, b: usize) -> Real {
        let [i, j] = self.bonds.ends[b];
        match self.bonds.grid() {
            Some(g) => g.rest(i as usize, j as usize),
            None => reference_length(self.reference_vector(i as usize, j as usize)),
        }
    }

    /// Every rest length (allocated when shed; see [`Lattice::rest`]).
    pub fn rest_lengths(&self) -> std::borrow::Cow<'_, [Real]> {
        match self.bonds.stored_rest() {
            Some(r) => r.into(),
            None => (0..self.bonds.len())
                .into_par_iter()
                .with_min_len(1 << 16)
                .map(|b| self.geometric_rest(b))
                .collect::<Vec<_>>()
                .into(),
        }
    }

    /// The rest lengths to change them (stored again if they were shed): for lattices whose
    /// springs are not meant to be at rest where their nodes are.
    pub fn rest_lengths_mut(&mut self) -> &mut [Real] {
        self.keep_rest();
        &mut self.bonds.rest
    }

    /// Store the rest lengths again if they were shed: for a caller that runs the CSR kernel,
    /// which streams them, on a lattice that shed them (as [`Bonds::keep_neighbours`]).
    pub fn keep_rest(&mut self) {
        if self.bonds.stored_rest().is_none() {
            let rest = self.rest_lengths().into_owned();
            self.bonds.built_mut().rest = rest;
            if let Some(g) = &mut self.bonds.grid {
                g.shed_rest = false;
            }
        }
    }

    /// The shortest rest length (m); infinity without springs.
    pub fn shortest(&self) -> Real {
        if let (Some(g), None) = (self.bonds.grid(), self.bonds.stored_rest()) {
            let star = g.star();
            return (0..self.len())
                .into_par_iter()
                .with_min_len(1 << 12)
                .map(|i| {
                    let mut m = Real::INFINITY;
                    g.links(&star, i, |_, l| m = m.min(l));
                    m
                })
                .reduce(|| Real::INFINITY, Real::min);
        }
        (0..self.bonds.len())
            .into_par_iter()
            .with_min_len(1 << 16)
            .map(|b| self.rest(b))
            .reduce(|| Real::INFINITY, Real::min)
    }

    /// Whether [`Lattice::shed_setup`] freed the set-up's volumes.
    pub fn is_shed(&self) -> bool {
        self.cells
            .as_ref()
            .is_some_and(|c| c.spring.len() != self.bonds.len() || c.surface.len() != self.len())
    }

    /// The volume node `n` stands for (m^3): its cell in a random lattice, `cell_volume` in a
    /// regular one.
    #[inline]
    pub fn node_volume(&self, n: usize) -> Real {
        match &self.cells {
            Some(c) => c.node[n],
            None => self.cell_volume,
        }
    }

    /// Reference vector from node `i` to node `j` (see [`reference_vector`]).
    #[inline(always)]
    pub fn reference_vector(&self, i: usize, j: usize) -> [Real; 3] {
        reference_vector(&self.pos, self.period, i, j)
    }

    /// Grid index of a box lattice's node `(ix, iy, iz)`.
    pub fn grid_index(&self, ix: usize, iy: usize, iz: usize) -> usize {
        let g = self
            .grid
            .expect("grid_index on a lattice that is not a box");
        ix + g[0] * (iy + g[1] * iz)
    }

    /// A box of Ladd's cubic lattice with `n = [nx, ny, nz]` nodes per axis, spacing `a`, the
    /// first node at the origin.
    pub fn cubic_box(n: [usize; 3], a: Real) -> Result<Self> {
        Self::cubic_box_periodic(n, a, [false; 3])
    }

    /// A cubic box that wraps around along the axes marked `periodic` (period `n a`; at least 3
    /// nodes along a periodic axis, so that no two springs join the same pair of nodes).
    pub fn cubic_box_periodic(n: [usize; 3], a: Real, periodic: [bool; 3]) -> Result<Self> {
        check_spacing(a)?;
        if (0..3).any(|c| periodic[c] && n[c] < 3) {
            return Err(Error::InvalidInput {
                what: "box size",
                why: format!("{n:?} nodes: a periodic axis needs at least 3 nodes"),
            });
        }
        if n.iter().any(|&v| v < 2) {
            return Err(Error::InvalidInput {
                what: "box size",
                why: format!("{n:?} nodes: a cubic box needs at least 2 nodes along each axis"),
            });
        }
        let total = n[0].checked_mul(n[1]).and_then(|v| v.checked_mul(n[2]));
        let total = match total {
            Some(t) if t <= u32::MAX as usize => t,
            _ => {
                return Err(Error::InvalidInput {
                    what: "box size",
                    why: format!("{n:?} nodes is more than 2^32 nodes"),
                })
            }
        };
        let pos = cubic_positions(n, a);
        let period = [0, 1, 2].map(|c| if periodic[c] { n[c] as Real * a } else { 0.0 });
        let bonds = if periodic.iter().any(|&p| p) {
            Bonds::from_pairs(total, cubic_pairs(n, periodic), &pos, period)?.into()
        } else {
            Topology::of_grid(GridSprings::cubic(n, a))
        };
        Ok(Lattice {
            kind: LatticeKind::Cubic,
            spacing: a,
            pos,
            cell_volume: a * a * a,
            thickness: 1.0,
            period,
            grid: Some(n),
            bonds,
            cells: None,
        })
    }

    /// A rectangle of the hexagonal lattice: `rows` rows of `nx` nodes, spacing `a`, plate
    /// thickness `h`. Row `r` lies at `y = r sqrt(3)/2 a`; odd rows are shifted by `+a/2` in x.
    pub fn hex_box(nx: usize, rows: usize, a: Real, h: Real) -> Result<Self> {
        Self::hex_box_periodic(nx, rows, a, h, [false; 2])
    }

    /// A hexagonal rectangle that wraps around along x (period `nx a`) and/or y (period
    /// `rows sqrt(3)/2 a`; needs an even number of rows so that the row shifts repeat).
    pub fn hex_box_periodic(
        nx: usize,
        rows: usize,
        a: Real,
        h: Real,
        periodic: [bool; 2],
    ) -> Result<Self> {
        check_spacing(a)?;
        if (periodic[0] && nx < 3) || (periodic[1] && (rows < 4 || rows % 2 == 1)) {
            return Err(Error::InvalidInput {
                what: "box size",
                why: format!("{nx} x {rows} nodes: periodic x needs 3 or more nodes per row, periodic y an even number of rows, at least 4"),
            });
        }
        if !(h.is_finite() && h > 0.0) {
            return Err(Error::InvalidInput {
                what: "plate thickness",
                why: format!("h = {h} m; give a positive thickness"),
            });
        }
        if nx < 2 || rows < 2 {
            return Err(Error::InvalidInput {
                what: "box size",
                why: format!("{nx} x {rows} nodes: a hexagonal box needs at least 2 nodes per row and 2 rows"),
            });
        }
        let total = nx
            .checked_mul(rows)
            .filter(|&t| t <= u32::MAX as usize)
            .ok_or(Error::InvalidInput {
                what: "box size",
                why: format!("{nx} x {rows} nodes is more than 2^32 nodes"),
            })?;
        let dy = hex_row_step(a);
        let pos = hex_positions(nx, rows, a);
        let periodic_any = periodic.iter().any(|&p| p);
        let period = [
            if periodic[0] { nx as Real * a } else { 0.0 },
            if periodic[1] { rows as Real * dy } else { 0.0 },
            0.0,
        ];
        let bonds = if periodic_any {
            Bonds::from_pairs(total, hex_pairs(nx, rows, periodic), &pos, period)?.into()
        } else {
            Topology::of_grid(GridSprings::hex(nx, rows, a))
        };
        Ok(Lattice {
            kind: LatticeKind::Hex,
            spacing: a,
            pos,
            cell_volume: dy * a * h,
            thickness: h,
            period,
            grid: Some([nx, rows, 1]),
            bonds,
            cells: None,
        })
    }
}

/// The reference positions of a box of Ladd's lattice with `n` nodes per axis and spacing
/// `a`, the first node at the origin: node `ix + nx (iy + ny iz)` at `(ix a, iy a, iz a)`.
fn cubic_positions(n: [usize; 3], a: Real) -> Coords {
    let total = n[0] * n[1] * n[2];
    // Positions and springs are made a layer of constant z at a time, in parallel: a large
    // block's set-up is mostly first writes to fresh memory, which then share the cores.
    let layer = n[0] * n[1];
    let mut pos = Coords::zeros(total);
    for (c, comp) in pos.xyz_mut().into_iter().enumerate() {
        comp.par_chunks_mut(layer)
            .enumerate()
            .for_each(|(iz, out)| {
                for (k, x) in out.iter_mut().enumerate() {
                    let g = [k % n[0], k / n[0], iz];
                    *x = g[c] as Real * a;
                }
            });
    }
    pos
}

/// The springs of a box of Ladd's lattice with `n` nodes per axis (wrapping along the axes
/// marked `periodic`), each from its lower-numbered end, sorted as [`Bonds::from_pairs`] wants
/// them.
fn cubic_pairs(n: [usize; 3], periodic: [bool; 3]) -> Vec<[u32; 2]> {
    let idx = |ix: usize, iy: usize, iz: usize| ix + n[0] * (iy + n[1] * iz);
    // Each spring is taken from its lower-numbered end ([`HALF_STAR`] and its negation), so
    // that the list comes out sorted as `Bonds::from_pairs` wants it (sorting 9 springs per
    // node took a tenth of a large block's set-up).
    // Without a periodic axis a neighbour is higher-numbered exactly when its index step
    // `dx + nx dy + nx ny dz` is positive, and the steps' order is the neighbours' order:
    // the star's forward half by step, so that a node's row needs no sort.
    let any_periodic = periodic.iter().any(|&p| p);
    let mut forward: Vec<([i64; 3], i64)> = HALF_STAR
        .iter()
        .flat_map(|d| [*d, d.map(|x| -x)])
        .map(|d| (d, d[0] + n[0] as i64 * (d[1] + n[1] as i64 * d[2])))
        .filter(|&(_, step)| step > 0)
        .collect();
    forward.sort_unstable_by_key(|&(_, step)| step);
    // Node (ix, iy, iz)'s springs to higher-numbered nodes, ascending, into `row`.
    let star = |ix: usize, iy: usize, iz: usize, row: &mut Vec<u32>| {
        let i = idx(ix, iy, iz) as u32;
        row.clear();
        if !any_periodic {
            let g = [ix as i64, iy as i64, iz as i64];
            for &(d, step) in &forward {
                if (0..3).all(|c| (0..n[c] as i64).contains(&(g[c] + d[c]))) {
                    row.push((i as i64 + step) as u32);
                }
            }
            return;
        }
        for d in HALF_STAR {
            for sign in [1, -1] {
                let mut j = [
                    ix as i64 + sign * d[0],
                    iy as i64 + sign * d[1],
                    iz as i64 + sign * d[2],
                ];
                let mut inside = true;
                for c in 0..3 {
                    if periodic[c] {
                        j[c] = j[c].rem_euclid(n[c] as i64);
                    }
                    inside &= (0..n[c] as i64).contains(&j[c]);
                }
                if inside {
                    let j = idx(j[0] as usize, j[1] as usize, j[2] as usize) as u32;
                    if j > i {
                        row.push(j);
                    }
                }
            }
        }
        row.sort_unstable();
    };
    // Each layer's springs counted, then written into its own part of the list.
    let counts: Vec<usize> = (0..n[2])
        .into_par_iter()
        .map(|iz| {
            let mut row = Vec::with_capacity(18);
            let mut count = 0;
            for iy in 0..n[1] {
                for ix in 0..n[0] {
                    star(ix, iy, iz, &mut row);
                    count += row.len();
                }
            }
            count
        })
        .collect();
    let mut pairs = vec![[0u32; 2]; counts.iter().sum()];
    let mut parts = Vec::with_capacity(n[2]);
    let mut rest = &mut pairs[..];
    for &c in &counts {
        let (part, tail) = rest.split_at_mut(c);
        parts.push(part);
        rest = tail;
    }
    parts.into_par_iter().enumerate().for_each(|(iz, out)| {
        let mut row = Vec::with_capacity(18);
        let mut k = 0;
        for iy in 0..n[1] {
            for ix in 0..n[0] {
                star(ix, iy, iz, &mut row);
                let i = idx(ix, iy, iz) as u32;
                for &j in &row {
                    out[k] = [i, j];
                    k += 1;
                }
            }
        }
    });
    pairs
}

/// The row step `sqrt(3)/2 a` of the hexagonal lattice.
fn hex_row_step(a: Real) -> Real {
    a * (3.0 as Real).sqrt() / 2.0
}

/// The reference positions of a rectangle of the hexagonal lattice, `rows` rows of `nx` nodes:
/// node `c + nx r` at `(c a + a/2 [r odd], r sqrt(3)/2 a)`.
fn hex_positions(nx: usize, rows: usize, a: Real) -> Coords {
    let total = nx * rows;
    let dy = hex_row_step(a);
    let mut pos = Coords::zeros(total);
    for r in 0..rows {
        for c in 0..nx {
            let shift = if r % 2 == 1 { 0.5 * a } else { 0.0 };
            pos.set(
                c + nx * r,
                Vector::new(c as Real * a + shift, r as Real * dy, 0.0),
            );
        }
    }
    pos
}

/// The springs of a rectangle of the hexagonal lattice (wrapping along the axes marked
/// `periodic`), each from its lower-numbered end unless it wraps.
fn hex_pairs(nx: usize, rows: usize, periodic: [bool; 2]) -> Vec<[u32; 2]> {
    let mut pairs = Vec::with_capacity(nx * rows * 3);
    for r in 0..rows {
        for c in 0..nx {
            let i = (c + nx * r) as u32;
            let wrap = |cc: i64| {
                if periodic[0] {
                    Some(cc.rem_euclid(nx as i64) as usize)
                } else {
                    (0..nx as i64).contains(&cc).then_some(cc as usize)
                }
            };
            if let Some(cc) = wrap(c as i64 + 1) {
                pairs.push([i, (cc + nx * r) as u32]);
            }
            let up = if r + 1 < rows {
                Some(r + 1)
            } else if periodic[1] {
                Some(0)
            } else {
                None
            };
            if let Some(ru) = up {
                // Up-neighbours: columns (c-1, c) from an even row, (c, c+1) from an odd row.
                let (lo, hi) = if r % 2 == 0 {
                    (c as i64 - 1, c as i64)
                } else {
                    (c as i64, c as i64 + 1)
                };
                for cc in [lo, hi] {
                    if let Some(cc) = wrap(cc) {
                        pairs.push([i, (cc + nx * ru) as u32]);
                    }
                }
            }
        }
    }
    pairs
}

impl Lattice {
    /// Keep only the nodes for which `keep(reference position)` is true, with the springs
    /// between kept nodes: a lattice filled into an arbitrary shape. If every node is kept the
    /// lattice is returned unchanged (a box keeps its grid, and so the stencil kernel);
    /// otherwise it has no grid and runs on the CSR kernel.
    pub fn retain(self, keep: impl Fn(Vector) -> bool) -> Result<Self> {
        let n = self.len();
        let kept: Vec<bool> = (0..n).map(|i| keep(self.pos.get(i))).collect();
        if kept.iter().all(|&k| k) {
            return Ok(self);
        }
        let mut new_index = vec![u32::MAX; n];
        let (mut x, mut y, mut z) = (Vec::new(), Vec::new(), Vec::new());
        for i in (0..n).filter(|&i| kept[i]) {
            new_index[i] = x.len() as u32;
            x.push(self.pos.x()[i]);
            y.push(self.pos.y()[i]);
            z.push(self.pos.z()[i]);
        }
        let pos = Coords::from_components(&x, &y, &z);
        if pos.is_empty() {
            return Err(Error::InvalidInput {
                what: "geometry",
                why: "the shape contains no lattice node: make it larger or the spacing smaller"
                    .into(),
            });
        }
        // Kept springs in their old order: the renumbering is monotone, so `from_pairs` keeps
        // that order and per-spring data can follow it.
        let kept_bonds: Vec<usize> = (0..self.bonds.len())
            .filter(|&b| {
                let [i, j] = self.bonds.ends[b];
                kept[i as usize] && kept[j as usize]
            })
            .collect();
        let pairs: Vec<[u32; 2]> = kept_bonds
            .iter()
            .map(|&b| {
                let [i, j] = self.bonds.ends[b];
                [new_index[i as usize], new_index[j as usize]]
            })
            .collect();
        let bonds = Bonds::from_pairs(pos.len(), pairs, &pos, self.period)?;
        let cells = self.cells.as_ref().map(|c| Cells {
            node: (0..n).filter(|&i| kept[i]).map(|i| c.node[i]).collect(),
            // What a shed lattice no longer has stays empty.
            spring: kept_bonds
                .iter()
                .filter_map(|&b| c.spring.get(b).copied())
                .collect(),
            surface: (0..n)
                .filter(|&i| kept[i])
                .filter_map(|i| c.surface.get(i).copied())
                .collect(),
            sampler: c.sampler,
        });
        Ok(Lattice {
            pos,
            bonds: bonds.into(),
            grid: None,
            cells,
            ..self
        })
    }
}

impl Lattice {
    /// The same lattice turned rigidly by the rotation `r` about the point `about` (a regular
    /// lattice laid along other axes, e.g. a Ladd lattice along a fibre: `crate::anisotropy`).
    /// Node and spring order are kept; the rest lengths are those of the turned positions. The
    /// result is no longer a box lattice (`grid` is `None`), so it runs on the general kernel.
    /// Periodic lattices are refused: their periods are along the axes.
    pub fn rotated(self, r: &crate::math::Matrix, about: Vector) -> Result<Self> {
        if self.is_periodic() {
            return Err(Error::InvalidInput {
                what: "lattice rotation",
                why: "a periodic lattice cannot be turned (its periods lie along the axes)".into(),
            });
        }
        let n = self.len();
        let (mut x, mut y, mut z) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        for i in 0..n {
            let p = about + r * (self.pos.get(i) - about);
            (x[i], y[i], z[i]) = (p.x, p.y, p.z);
        }
        let pos = Coords::from_components(&x, &y, &z);
        let bonds = Bonds::from_pairs(n, self.bonds.ends.clone(), &pos, self.period)?;
        Ok(Lattice {
            pos,
            bonds: bonds.into(),
            grid: None,
            ..self
        })
    }
}

fn check_spacing(a: Real) -> Result<()> {
    if a.is_finite() && a > 0.0 {
        Ok(())
    } else {
        Err(Error::InvalidInput {
            what: "lattice spacing",
            why: format!("a = {a} m; give a positive spacing"),
        })
    }
}

/// The share of the cubes of Ladd's lattice that would hold the segment from grid point `p` to
/// `q` in the bulk (4 for an axis spring, 2 for a face diagonal, 8 for a node: `p == q`) that
/// lie in the body (`cube(c)`, `c` a cube's lowest corner): each axis along which the two ends
/// differ fixes the cube's corner, each other axis leaves two choices. The one formula of
/// [`Lattice::cell_fractions`] and of a box's cell-weighted stiffnesses
/// ([`GridSprings::cube_share`]), so both give the same bits.
pub(crate) fn cube_share(p: [i64; 3], q: [i64; 3], cube: impl Fn([i64; 3]) -> bool) -> Real {
    let mut count = 0;
    let mut total = 0;
    for k in 0..8 {
        let mut c = [0i64; 3];
        let mut ok = true;
        for ax in 0..3 {
            let bit = (k >> ax) & 1;
            if p[ax] == q[ax] {
                c[ax] = p[ax] - bit;
            } else if bit == 1 {
                ok = false;
            } else {
                c[ax] = p[ax].min(q[ax]);
            }
        }
        if ok {
            total += 1;
            if cube(c) {
                count += 1;
            }
        }
    }
    count as Real / total as Real
}

impl Lattice {
    /// The share of a bulk spring's and a bulk node's material each spring and node of a regular
    /// lattice stands for (1 inside): the fraction of the cells that would hold it in the bulk
    /// (cubes of the Ladd lattice, triangles of the hexagonal one) that lie in the body. `None`
    /// for random lattices (their `Cells` are exact volumes already) and periodic ones.
    pub fn cell_fractions(&self) -> Option<(Vec<Real>, Vec<Real>)> {
        if self.cells.is_some() || self.period.iter().any(|&p| p != 0.0) {
            return None;
        }
        let bonds = &*self.bonds;
        let n = self.len();
        match self.kind {
            LatticeKind::Cubic => {
                let a = self.spacing;
                let lo = [0, 1, 2].map(|c| {
                    self.pos
                        .comp(c)
                        .iter()
                        .cloned()
                        .fold(Real::INFINITY, Real::min)
                });
                let cell = |i: usize| -> [i64; 3] {
                    [0, 1, 2].map(|c| ((self.pos.comp(c)[i] - lo[c]) / a).round() as i64)
                };
                // A lattice turned against the axes (`Lattice::rotated`) has no axis-aligned
                // cubes to count.
                let on_grid = (0..n).into_par_iter().all(|i| {
                    (0..3).all(|c| {
                        let v = (self.pos.comp(c)[i] - lo[c]) / a;
                        (v - v.round()).abs() < 1e-6
                    })
                });
                if !on_grid {
                    return None;
                }
                // A whole box (every grid node present): a cube is in the body when its corner
                // is; a shaped body looks its cubes' corners up.
                let whole = self.grid.filter(|g| g[0] * g[1] * g[2] == n);
                let nodes: std::collections::HashSet<[i64; 3]> = if whole.is_some() {
                    Default::default()
                } else {
                    (0..n).map(cell).collect()
                };
                let cube = |c: [i64; 3]| match whole {
                    Some(g) => (0..3).all(|ax| c[ax] >= 0 && c[ax] + 1 < g[ax] as i64),
                    None => (0..8).all(|k| {
                        nodes.contains(&[
                            c[0] + (k & 1),
                            c[1] + ((k >> 1) & 1),
                            c[2] + ((k >> 2) & 1),
                        ])
                    }),
                };
                let share = |p: [i64; 3], q: [i64; 3]| cube_share(p, q, cube);
                let springs = bonds
                    .ends
                    .par_iter()
                    .with_min_len(1 << 12)
                    .map(|e| share(cell(e[0] as usize), cell(e[1] as usize)))
                    .collect();
                let node = (0..n)
                    .into_par_iter()
                    .with_min_len(1 << 12)
                    .map(|i| share(cell(i), cell(i)))
                    .collect();
                Some((springs, node))
            }
            LatticeKind::Hex => {
                // Triangles: a spring's common neighbours (at most two in the bulk); a node's
                // bonded pairs of neighbours (six in the bulk).
                let linked = |i: usize, j: usize| bonds.entry(i, j).is_some();
                let springs = bonds
                    .ends
                    .iter()
                    .map(|e| {
                        let (i, j) = (e[0] as usize, e[1] as usize);
                        let common = bonds.links(i).filter(|&(k, _)| linked(k, j)).count();
                        common as Real / 2.0
                    })
                    .collect();
                let node = (0..n)
                    .map(|i| {
                        let row = bonds.row(i);
                        let mut t = 0;
                        for x in row.clone() {
                            for y in x + 1..row.end {
                                if linked(bonds.neighbour(i, x), bonds.neighbour(i, y)) {
                                    t += 1;
                                }
                            }
                        }
                        t as Real / 6.0
                    })
                    .collect();
                Some((springs, node))
            }
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cubic_bulk_node_has_18_neighbours() {
        let l = Lattice::cubic_box([5, 5, 5], 1.0).unwrap();
        let c = l.grid_index(2, 2, 2);
        assert_eq!(l.bonds.row(c).len(), 18);
        let lengths: Vec<_> = l
            .bonds
            .row(c)
            .map(|e| l.bonds.rest[l.bonds.bond[e] as usize])
            .collect();
        assert_eq!(
            lengths.iter().filter(|&&x| (x - 1.0).abs() < 1e-12).count(),
            6
        );
        assert_eq!(
            lengths
                .iter()
                .filter(|&&x| (x - 2f64.sqrt()).abs() < 1e-12)
                .count(),
            12
        );
        // Springs in a box: per axis pairs for A, per plane diagonals for B.
        let (n, m) = (5usize, 4usize);
        assert_eq!(l.bonds.len(), 3 * m * n * n + 6 * m * m * n);
    }

    #[test]
    fn hex_bulk_node_has_6_unit_neighbours() {
        let l = Lattice::hex_box(6, 6, 2.0, 0.1).unwrap();
        for (r, c) in [(2, 2), (3, 2)] {
            let i = c + 6 * r;
            assert_eq!(l.bonds.row(i).len(), 6);
            for e in l.bonds.row(i) {
                assert!((l.bonds.rest[l.bonds.bond[e] as usize] - 2.0).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn rows_list_each_spring_from_both_ends() {
        let l = Lattice::cubic_box([3, 4, 2], 0.5).unwrap();
        let mut count = vec![0; l.bonds.len()];
        for n in 0..l.len() {
            for e in l.bonds.row(n) {
                let b = l.bonds.bond[e] as usize;
                let [i, j] = l.bonds.ends[b];
                assert!(n as u32 == i || n as u32 == j);
                assert_eq!(
                    l.bonds.neighbour(n, e) as u32,
                    if n as u32 == i { j } else { i }
                );
                count[b] += 1;
            }
        }
        assert!(count.iter().all(|&c| c == 2));
    }

    /// With the neighbour array built or freed, every neighbour, link and entry reads the same;
    /// each spring is found from both ends, rows are sorted by neighbour, and a pair that is not
    /// linked is found in neither.
    #[test]
    fn neighbours_read_the_same_with_and_without_their_array() {
        let spec = crate::random::RandomSpec::default();
        let l = Lattice::random(3, [0.0; 3], [5.0, 4.0, 3.0], 1.0, 1.0, spec, &|_| true).unwrap();
        let (mut kept, mut shed) = (l.clone(), l.clone());
        kept.bonds.keep_neighbours();
        shed.bonds.shed_neighbours();
        assert!(shed.bonds.neighbours().is_none());
        let nbr = kept.bonds.neighbours().unwrap();
        assert_eq!(nbr.len(), 2 * l.bonds.len());
        for (b, &[i, j]) in l.bonds.ends.iter().enumerate() {
            for (n, m) in [(i as usize, j as usize), (j as usize, i as usize)] {
                let e = shed.bonds.entry(n, m).unwrap();
                assert_eq!((nbr[e] as usize, shed.bonds.bond[e] as usize), (m, b));
                assert_eq!(kept.bonds.entry(n, m), Some(e));
            }
        }
        for n in 0..l.len() {
            assert!(shed.bonds.links(n).eq(kept.bonds.links(n)));
            assert!(nbr[l.bonds.row(n)].is_sorted_by(|a, b| a < b));
            for j in 0..l.len() {
                let linked = nbr[l.bonds.row(n)].contains(&(j as u32));
                assert_eq!(shed.bonds.entry(n, j).is_some(), linked);
                assert_eq!(kept.bonds.entry(n, j).is_some(), linked);
            }
        }
    }

    #[test]
    fn periodic_boxes_give_every_node_a_full_star() {
        let l = Lattice::cubic_box_periodic([5, 4, 3], 0.5, [true, true, true]).unwrap();
        for n in 0..l.len() {
            assert_eq!(l.bonds.row(n).len(), 18);
        }
        assert!(l
            .bonds
            .rest
            .iter()
            .all(|&r| (r - 0.5).abs() < 1e-12 || (r - 0.5 * 2f64.sqrt()).abs() < 1e-12));
        let h = Lattice::hex_box_periodic(5, 4, 1.0, 1.0, [true, true]).unwrap();
        for n in 0..h.len() {
            assert_eq!(h.bonds.row(n).len(), 6);
        }
        assert!(h.bonds.rest.iter().all(|&r| (r - 1.0).abs() < 1e-12));
        assert!(Lattice::hex_box_periodic(5, 5, 1.0, 1.0, [false, true]).is_err());
    }

    /// The layer-parallel generation gives exactly the springs of a brute-force search (every
    /// pair at a or a sqrt(2), nearest image along periodic axes), in order, and the same bits
    /// for any thread count.
    #[test]
    fn cubic_boxes_hold_every_neighbour_pair_once_in_order() {
        // Thin boxes too: there the forward steps of different directions come closest.
        let boxes = [
            ([4, 3, 5], [false; 3]),
            ([2, 2, 2], [false; 3]),
            ([3, 2, 4], [false; 3]),
            ([2, 5, 3], [false; 3]),
            ([4, 3, 5], [true, false, true]),
            ([4, 3, 5], [false, true, true]),
        ];
        for (n, periodic) in boxes {
            let a = 0.3;
            let l = Lattice::cubic_box_periodic(n, a, periodic).unwrap();
            let mut expect = Vec::new();
            for i in 0..l.len() {
                for j in i + 1..l.len() {
                    let g = |k: usize| [k % n[0], k / n[0] % n[1], k / (n[0] * n[1])];
                    let (gi, gj) = (g(i), g(j));
                    let mut r2 = 0;
                    for c in 0..3 {
                        let mut d = gj[c].abs_diff(gi[c]);
                        if periodic[c] {
                            d = d.min(n[c] - d);
                        }
                        r2 += d * d;
                    }
                    if r2 == 1 || r2 == 2 {
                        expect.push([i as u32, j as u32]);
                    }
                }
            }
            assert_eq!(l.bonds.ends, expect, "{periodic:?}");
            for threads in [1, 3] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let m = pool.install(|| Lattice::cubic_box_periodic(n, a, periodic).unwrap());
                assert_eq!(m.bonds.ends, l.bonds.ends);
                assert_eq!(m.bonds.nbr, l.bonds.nbr);
                let (mut m, mut l) = (m.clone(), l.clone());
                m.bonds.keep_neighbours();
                l.bonds.keep_neighbours();
                assert_eq!(m.bonds.nbr, l.bonds.nbr);
                assert_eq!(m.bonds.bond, l.bonds.bond);
                let bits = |v: &[Real]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&m.bonds.rest), bits(&l.bonds.rest));
                assert_eq!(bits(m.pos.as_flat()), bits(l.pos.as_flat()));
            }
        }
    }

    #[test]
    fn a_box_grid_gives_its_built_rows_values_without_building_them() {
        // Thin boxes and a spacing whose multiples round, so that rest lengths of one
        // direction differ in their last bits from node to node; rows of 2 nodes, where a
        // hexagonal row's steps to the row below and along it come closest.
        let cubic = [[4, 3, 5], [2, 2, 2], [3, 2, 4], [2, 5, 3], [7, 6, 9]];
        let hex = [[2, 2, 1], [2, 5, 1], [3, 4, 1], [9, 7, 1], [6, 11, 1]];
        let boxes = cubic
            .map(|n| (n, false))
            .into_iter()
            .chain(hex.map(|n| (n, true)));
        for (n, is_hex) in boxes {
            let a = 0.1;
            let make = || {
                if is_hex {
                    Lattice::hex_box(n[0], n[1], a, 0.3).unwrap()
                } else {
                    Lattice::cubic_box(n, a).unwrap()
                }
            };
            let l = make();
            assert!(!l.bonds.is_built());
            let g = *l
                .bonds
                .grid()
                .expect("a box without a periodic axis has a grid");
            let springs = l.bonds.len();
            let shortest = l.shortest();
            assert!(!l.bonds.is_built(), "count and shortest read the grid");
            // What the constructors built before the grid (the pairs through `from_pairs`).
            let (pos, pairs) = if is_hex {
                (
                    hex_positions(n[0], n[1], a),
                    hex_pairs(n[0], n[1], [false; 2]),
                )
            } else {
                (cubic_positions(n, a), cubic_pairs(n, [false; 3]))
            };
            assert_eq!(pos, l.pos);
            let built = Bonds::from_pairs(l.len(), pairs, &pos, [0.0; 3]).unwrap();
            assert_eq!(springs, built.len(), "{n:?}");
            let star = g.star();
            for i in 0..l.len() {
                let mut links = Vec::new();
                g.links(&star, i, |j, r| links.push((j, r.to_bits())));
                let row: Vec<_> = built
                    .links(i)
                    .map(|(j, b)| (j, built.rest[b].to_bits()))
                    .collect();
                assert_eq!(links, row, "{n:?} node {i}");
            }
            let min = built.rest.iter().fold(Real::INFINITY, |m, &r| m.min(r));
            assert_eq!(shortest.to_bits(), min.to_bits());
            // Read, the springs are those; shed, the rest lengths read the same.
            assert_eq!(l.bonds.ends, built.ends);
            assert_eq!(l.bonds.bond, built.bond);
            assert!(l.bonds.is_built() && l.bonds.grid().is_some());
            // Where the box put its nodes it sheds them; moved, only where the moved nodes
            // give the same lengths (`a_moved_box_sheds_only_the_lengths_its_nodes_give`).
            assert!(make().shed_rest());
            let mut shed = make();
            for p in shed.pos.xyz_mut() {
                p.iter_mut().for_each(|x| *x += 0.7);
            }
            let was_shed = shed.shed_rest();
            for b in 0..springs {
                assert_eq!(shed.rest(b).to_bits(), built.rest[b].to_bits());
            }
            assert_eq!(shed.bonds.stored_rest().is_none(), was_shed);
            // A change through `DerefMut` leaves the grid behind.
            let mut changed = make();
            changed.rest_lengths_mut()[0] *= 2.0;
            assert!(changed.bonds.grid().is_none());
            assert_eq!(changed.rest(0), 2.0 * built.rest[0]);
        }
    }

    #[test]
    fn springs_first_read_in_a_parallel_loop_are_built_once() {
        // Every task of the loop reads them; one builds them while the others wait. (The
        // build joins no rayon task, which could take up a task of this loop that then waits
        // for the build on the same thread; this test does not provoke that race, it checks
        // the built springs under concurrent first reads.)
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(4)
            .build()
            .unwrap();
        for _ in 0..10 {
            let l = Lattice::cubic_box([30, 20, 20], 0.1).unwrap();
            let entries: usize = pool.install(|| {
                (0..l.len())
                    .into_par_iter()
                    .with_max_len(64)
                    .map(|i| l.bonds.row(i).len())
                    .sum()
            });
            assert_eq!(entries, 2 * l.bonds.len());
        }
    }

    #[test]
    fn degenerate_boxes_are_refused() {
        assert!(Lattice::cubic_box([1, 4, 4], 1.0).is_err());
        assert!(Lattice::cubic_box([4, 4, 4], 0.0).is_err());
        assert!(Lattice::hex_box(4, 1, 1.0, 1.0).is_err());
        assert!(Lattice::hex_box(4, 4, 1.0, -1.0).is_err());
    }
}
