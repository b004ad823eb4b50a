//! The dispersive spring law (momentum dispersion, paper Section 3) in its symmetric,
//! energy-conserving form (`docs/model.md`).
//!
//! Spring `s` joins nodes `i` and `j`, rest length `L_s`, current length `l_s`, extension
//! `dL_s = l_s - L_s` (geometrically nonlinear). Over each node's intact springs `t`:
//!
//! ```text
//! Pi_n = sum_t k_t L_t dL_t        the node's pool: the momentum flow it collects
//! S_n  = sum_t k_t L_t^2           its normaliser
//! p_n  = Pi_n / S_n                the pool ratio (0 for a node with no intact spring)
//!
//! U    = 1/2 sum_s k_s dL_s^2  +  q/2 sum_n Pi_n^2 / S_n
//! T_s  = dU/d(dL_s) = k_s dL_s + q k_s L_s (p_i + p_j)
//! ```
//!
//! A softening material's damaged spring enters all of this with its current stiffness
//! `w_s k_s` (`w_s` its damage weight, [`crate::state::Springs`]): every `k` above is read from
//! the state's springs, not from the body.
//!
//! The first term of `T_s` is the direct force `F^mu` of the paper, the second the dispersed
//! force `F^*`: each node spreads `q` times its collected flow back over all its springs in
//! proportion to their length. `T_s` acts along the spring on both ends, equal and opposite, so
//! linear and angular momentum are conserved exactly, and since `T = dU/d(dL)` a symplectic
//! integrator conserves energy.
//!
//! One evaluation is two gathers over each node's CSR row: a node pre-pass for `p_n`, then a
//! spring pass for the forces. Every node writes only its own entries, and every per-node sum
//! runs in row order, so the result is bit-identical for any number of threads.

use rayon::prelude::*;

use crate::body::{Body, GridStiffness};
use crate::lattice::Lattice;
use crate::math::{Coords, Matrix, Real, Vector};
use crate::state::{Springs, State};

/// Below this many nodes a pass runs on one thread: rayon's fork cost is larger than the work.
pub const MIN_NODES_PER_TASK: usize = 1024;

/// Tension of one spring (N): the one-spring evaluation of the law, for tests and for
/// per-spring output. `lever` is the spring's dispersion lever ([`Body::levers`]): its rest
/// length `L` for an isotropic material.
#[inline]
pub fn tension(k: Real, lever: Real, dl: Real, q: Real, p_i: Real, p_j: Real) -> Real {
    k * dl + q * k * lever * (p_i + p_j)
}

/// Strain energy split into the direct springs and the dispersive pools (J).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Energy {
    /// `1/2 sum_s k_s dL_s^2`.
    pub direct: Real,
    /// `q/2 sum_n Pi_n^2 / S_n`.
    pub dispersive: Real,
}

impl Energy {
    /// Total strain energy.
    pub fn total(&self) -> Real {
        self.direct + self.dispersive
    }
}

/// Geometry of the spring from node `i` to node `j`: its current vector `d`, length `l` and
/// extension `dL = l - L`.
///
/// The extension is formed without cancellation: with `D = X_j - X_i` the reference vector
/// (`|D| = L`) and `w = u_j - u_i`,
/// `dL = (|D + w|^2 - L^2) / (l + L) = (2 D.w + w.w) / (l + L)`. Subtracting `L` from `l`
/// directly would lose the digits of `dL` that lie below the rounding of `l` (1e-16 L), which at
/// a strain of 1e-5 is already one part in 1e11 and stalls tight static solves.
#[derive(Clone, Copy, Debug)]
pub struct SpringGeometry {
    pub d: [Real; 3],
    pub l: Real,
    pub dl: Real,
}

/// See [`SpringGeometry`].
#[inline(always)]
pub fn spring_geometry(
    lat: &Lattice,
    u: &Coords,
    i: usize,
    j: usize,
    rest: Real,
) -> SpringGeometry {
    geometry_from(lat.reference_vector(i, j), u, i, j, rest)
}

/// [`spring_geometry`] of spring `b` from `i` to `j`, and its rest length `L_b`
/// ([`Lattice::rest`]): where the lattice shed them, `|D|` of the same reference vector `D`.
#[inline(always)]
pub fn spring_geometry_rest(
    lat: &Lattice,
    u: &Coords,
    b: usize,
    i: usize,
    j: usize,
) -> (SpringGeometry, Real) {
    let big = lat.reference_vector(i, j);
    let rest = match lat.bonds.stored_rest() {
        Some(r) => r[b],
        None => crate::lattice::reference_length(big),
    };
    (geometry_from(big, u, i, j, rest), rest)
}

#[inline(always)]
fn geometry_from(big: [Real; 3], u: &Coords, i: usize, j: usize, rest: Real) -> SpringGeometry {
    let w = [
        u.x()[j] - u.x()[i],
        u.y()[j] - u.y()[i],
        u.z()[j] - u.z()[i],
    ];
    let d = [big[0] + w[0], big[1] + w[1], big[2] + w[2]];
    let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let num = 2.0 * (big[0] * w[0] + big[1] * w[1] + big[2] * w[2])
        + (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    SpringGeometry {
        d,
        l,
        dl: num / (l + rest),
    }
}

/// Current vector from node `i` to node `j`: reference vector plus displacement difference.
#[inline]
pub fn spring_vector(lat: &Lattice, u: &Coords, i: usize, j: usize) -> (Real, Real, Real) {
    let d = lat.reference_vector(i, j);
    (
        d[0] + (u.x()[j] - u.x()[i]),
        d[1] + (u.y()[j] - u.y()[i]),
        d[2] + (u.z()[j] - u.z()[i]),
    )
}

/// Pool `Pi_n` of node `n` over its intact springs.
#[inline]
fn node_pool(body: &Body, u: &Coords, sp: Springs<'_>, n: usize) -> Real {
    let bonds = &*body.lattice.bonds;
    let mut pi = 0.0;
    for e in bonds.row(n) {
        let b = bonds.bond[e] as usize;
        if sp.alive[b] {
            let rest = body.lattice.rest(b);
            pi += sp.k[b]
                * sp.lever.get(b)
                * spring_geometry(&body.lattice, u, n, bonds.neighbour(n, e), rest).dl;
        }
    }
    pi
}

/// Node pre-pass: `pool[n] = Pi_n / S_n` for every node.
pub fn compute_pools(body: &Body, u: &Coords, sp: Springs<'_>, norm: &[Real], pool: &mut [Real]) {
    fill_pools(body.q, norm, pool, |n| node_pool(body, u, sp, n));
}

/// `pool[n] = Pi_n / S_n` with `Pi_n = pi(n)`, in parallel (0 where `S_n` is 0); the plain
/// lattice (`q = 0`) has no pre-pass, its pools are 0.
fn fill_pools(q: Real, norm: &[Real], pool: &mut [Real], pi: impl Fn(usize) -> Real + Sync) {
    if q == 0.0 {
        pool.fill(0.0);
        return;
    }
    pool.par_iter_mut()
        .with_min_len(MIN_NODES_PER_TASK)
        .enumerate()
        .for_each(|(n, p)| *p = pool_ratio(q, norm[n], || pi(n)));
}

/// The pool ratios of the nodes `nodes` alone into `pool` (the others' left as they are),
/// each the bits the whole pre-pass gives it: a rank's own nodes, whose rows it holds whole.
pub fn pools_in(
    body: &Body,
    u: &Coords,
    sp: Springs<'_>,
    norm: &[Real],
    nodes: std::ops::Range<usize>,
    pool: &mut [Real],
) {
    let (q, from) = (body.q, nodes.start);
    pool[nodes]
        .par_iter_mut()
        .with_min_len(MIN_NODES_PER_TASK)
        .enumerate()
        .for_each(|(k, p)| {
            let n = from + k;
            *p = pool_ratio(q, norm[n], || node_pool(body, u, sp, n));
        });
}

/// The pool ratio `p_n = Pi_n / S_n` of a node with normaliser `s` and pool `pi()`: 0 for the
/// plain law (`q = 0`, `pi` not evaluated) and where `S_n` is 0.
#[inline]
pub fn pool_ratio(q: Real, s: Real, pi: impl FnOnce() -> Real) -> Real {
    // A normaliser is negative at a node of negative q_n in a body of several materials
    // (Body::q_node), and 0 only where the node has no spring.
    if q != 0.0 && s != 0.0 {
        pi() / s
    } else {
        0.0
    }
}

/// Force of node `n` from the state's displacements and pools, with dispersion ratio `q`.
#[inline]
pub fn node_force(
    body: &Body,
    q: Real,
    u: &Coords,
    sp: Springs<'_>,
    pool: &[Real],
    n: usize,
) -> [Real; 3] {
    node_force_with(body, q, u, sp, |i| pool[i], n)
}

/// [`node_force`] with the pools from `pool(i)`.
#[inline]
fn node_force_with(
    body: &Body,
    q: Real,
    u: &Coords,
    sp: Springs<'_>,
    pool: impl Fn(usize) -> Real,
    n: usize,
) -> [Real; 3] {
    let bonds = &*body.lattice.bonds;
    let lat = &body.lattice;
    let mut f = [0.0; 3];
    for e in bonds.row(n) {
        let b = bonds.bond[e] as usize;
        if !sp.alive[b] {
            continue;
        }
        let j = bonds.neighbour(n, e);
        let rest = lat.rest(b);
        let g = spring_geometry(lat, u, n, j, rest);
        let s = tension(sp.k[b], sp.lever.get(b), g.dl, q, pool(n), pool(j)) / g.l;
        f[0] += s * g.d[0];
        f[1] += s * g.d[1];
        f[2] += s * g.d[2];
    }
    f
}

/// The forces of a few nodes `nodes` (a boundary's), each the bits [`update_forces`] gives it,
/// from the pools of those nodes and their neighbours alone: a reaction between two frames
/// costs a few rows instead of two passes over the body.
pub fn forces_at(body: &Body, state: &State, nodes: &[usize]) -> Vec<[Real; 3]> {
    let u = &state.u;
    let grid = GridLaw::of(body, state);
    let sp = state.springs(body);
    let mut pools = std::collections::HashMap::new();
    for &n in nodes {
        let mut reach = vec![n];
        match &grid {
            Some(g) => g.links(u, n, |j, _, _, _| reach.push(j)),
            None => {
                let bonds = &*body.lattice.bonds;
                reach.extend(bonds.row(n).map(|e| bonds.neighbour(n, e)));
            }
        }
        for m in reach {
            pools.entry(m).or_insert_with(|| {
                pool_ratio(body.q, state.norm[m], || match &grid {
                    Some(g) => g.node_pool(u, m),
                    None => node_pool(body, u, sp, m),
                })
            });
        }
    }
    let pool = |i: usize| pools[&i];
    nodes
        .iter()
        .map(|&n| match &grid {
            Some(g) => g.node_force_with(u, pool, n),
            None => node_force_with(body, body.q, u, sp, pool, n),
        })
        .collect()
}

/// Spring pass: internal force on every node from the current pools.
pub fn compute_forces(body: &Body, u: &Coords, sp: Springs<'_>, pool: &[Real], f: &mut Coords) {
    fill_forces(f, |n| node_force(body, body.q, u, sp, pool, n));
}

/// `f[n] = force(n)` for every node, in parallel (each node writes only its own force).
fn fill_forces(f: &mut Coords, force: impl Fn(usize) -> [Real; 3] + Sync) {
    let [x, y, z] = f.xyz_mut();
    x.par_iter_mut()
        .zip(y.par_iter_mut())
        .zip(z.par_iter_mut())
        .with_min_len(MIN_NODES_PER_TASK)
        .enumerate()
        .for_each(|(n, ((fx, fy), fz))| [*fx, *fy, *fz] = force(n));
}

/// Both passes on a state: refreshes `state.pool` and `state.f` (of a pristine box, through its
/// [`GridLaw`]: the same bits).
pub fn update_forces(body: &Body, state: &mut State) {
    if let Some(law) = GridLaw::of(body, state) {
        return law.update_forces(state);
    }
    let sp = Springs::of(body, &state.alive, &state.k_eff);
    compute_pools(body, &state.u, sp, &state.norm, &mut state.pool);
    compute_forces(body, &state.u, sp, &state.pool, &mut state.f);
}

/// `sum_{i < n} f(i)` in parallel, in an order that does not depend on the thread count or on
/// rayon's work stealing: fixed chunks of [`crate::CHUNK`] terms, each summed in index
/// order, then the chunks' sums in chunk order. (rayon's own `sum` splits adaptively, so its
/// rounding changed from run to run.) For output and measurements, not the hot path.
pub fn ordered_sum(n: usize, f: impl Fn(usize) -> Real + Sync) -> Real {
    let chunk = crate::CHUNK;
    let partial: Vec<Real> = (0..n.div_ceil(chunk))
        .into_par_iter()
        .map(|c| (c * chunk..((c + 1) * chunk).min(n)).map(&f).sum())
        .collect();
    partial.iter().sum()
}

/// Strain energy `U` of displacements `u` (computed from scratch; not on the hot path).
pub fn energy(body: &Body, u: &Coords, sp: Springs<'_>, norm: &[Real]) -> Energy {
    let bonds = &*body.lattice.bonds;
    let direct = ordered_sum(bonds.len(), |b| {
        if !sp.alive[b] {
            return 0.0;
        }
        let [i, j] = bonds.ends[b];
        let dl = spring_geometry(
            &body.lattice,
            u,
            i as usize,
            j as usize,
            body.lattice.rest(b),
        )
        .dl;
        0.5 * sp.k[b] * dl * dl
    });
    let dispersive = if body.q == 0.0 {
        0.0
    } else {
        ordered_sum(body.nodes(), |n| {
            let s = norm[n];
            if s != 0.0 {
                let pi = node_pool(body, u, sp, n);
                0.5 * body.q * pi * pi / s
            } else {
                0.0
            }
        })
    };
    Energy { direct, dispersive }
}

/// Current tension of every spring (0 for broken ones), from the state's pools. For output and
/// measurements, not the hot path.
pub fn tensions(body: &Body, state: &State) -> Vec<Real> {
    spring_tensions(body, &state.u, state.springs(body), &state.pool)
}

/// Tension of every spring (0 for broken ones) for displacements `u` and pool ratios `pool`.
pub fn spring_tensions(body: &Body, u: &Coords, sp: Springs<'_>, pool: &[Real]) -> Vec<Real> {
    let bonds = &*body.lattice.bonds;
    (0..bonds.len())
        .map(|b| {
            if !sp.alive[b] {
                return 0.0;
            }
            let [i, j] = bonds.ends[b].map(|v| v as usize);
            let rest = body.lattice.rest(b);
            tension(
                sp.k[b],
                sp.lever.get(b),
                spring_geometry(&body.lattice, u, i, j, rest).dl,
                body.q,
                pool[i],
                pool[j],
            )
        })
        .collect()
}

/// The springs of a pristine box read from its grid ([`crate::lattice::Topology::grid`]) and
/// its stiffness rule ([`GridStiffness`]), without the rows, the springs' ends or the stiffness
/// list: for a box on a stencil kernel, the law's node-by-node evaluations that a run needs
/// besides its steps (a frame, the forces at prescribed nodes), each the bits of the reference
/// law on the built rows. Only while every spring is intact and undamaged (the state has never
/// changed one) and the material is isotropic (each lever is the rest length).
///
/// Each node walks its links in row order and computes each spring's geometry from its own
/// end: seen from the other end the vector is the exact negation and the length, extension,
/// tension and `e (x) e` terms are the same bits, so it adds what the rows' laws add, in the
/// same order.
pub struct GridLaw<'a> {
    lat: &'a Lattice,
    grid: &'a crate::lattice::GridSprings,
    star: crate::lattice::Star,
    rule: GridStiffness,
    /// The bulk stiffness, and the grid of a rule of cube weights.
    bulk: Real,
    cubes: Option<crate::lattice::GridSprings>,
    q: Real,
}

impl<'a> GridLaw<'a> {
    /// The grid law of `body` in `state`, where it applies.
    pub fn of(body: &'a Body, state: &State) -> Option<Self> {
        let lat = &body.lattice;
        let grid = lat.bonds.grid()?;
        let rule = body.k.rule()?;
        if !state.is_pristine() || body.lever.is_some() {
            return None;
        }
        let (bulk, cubes) = match rule {
            GridStiffness::One(k) => (k, None),
            GridStiffness::Cubes(k, g) => (k, Some(g)),
        };
        Some(GridLaw {
            lat,
            grid,
            star: grid.star(),
            rule,
            bulk,
            cubes,
            q: body.q,
        })
    }

    /// Node `i`'s springs in row order, each as `f(j, k, L, geometry from i)`: the stiffness
    /// is the bulk value, which a cube share of 1 keeps to the bit, about a node inside the
    /// faces.
    #[inline]
    pub fn links(
        &self,
        u: &Coords,
        i: usize,
        mut f: impl FnMut(usize, Real, Real, SpringGeometry),
    ) {
        let inner = self.is_inner(i);
        self.grid.links(&self.star, i, |j, rest| {
            let k = self.stiffness(inner, i, j);
            f(j, k, rest, spring_geometry(self.lat, u, i, j, rest));
        });
    }

    /// The lattice whose grid this law reads.
    pub fn lattice(&self) -> &'a Lattice {
        self.lat
    }

    /// The box's grid of springs.
    pub fn grid(&self) -> &'a crate::lattice::GridSprings {
        self.grid
    }

    /// The grid's neighbour offsets.
    pub fn star(&self) -> &crate::lattice::Star {
        &self.star
    }

    /// Whether every spring of node `i` has the bulk stiffness.
    #[inline]
    pub fn is_inner(&self, i: usize) -> bool {
        self.cubes.is_none_or(|c| c.is_inner(i))
    }

    /// The stiffness of the spring between `i` and `j`, `inner` from [`GridLaw::is_inner`].
    #[inline]
    pub fn stiffness(&self, inner: bool, i: usize, j: usize) -> Real {
        if inner {
            self.bulk
        } else {
            self.rule.between(i.min(j), i.max(j))
        }
    }

    /// [`node_pool`] of node `n`: `Pi_n`, the same bits.
    fn node_pool(&self, u: &Coords, n: usize) -> Real {
        let mut pi = 0.0;
        self.links(u, n, |_, k, rest, g| pi += k * rest * g.dl);
        pi
    }

    /// [`update_forces`]: [`compute_pools`] then [`compute_forces`], the same bits.
    fn update_forces(&self, state: &mut State) {
        let u = &state.u;
        fill_pools(self.q, &state.norm, &mut state.pool, |n| {
            self.node_pool(u, n)
        });
        let pool = &state.pool;
        fill_forces(&mut state.f, |n| self.node_force(u, pool, n));
    }

    /// [`node_force`] of node `n`, the same bits.
    pub fn node_force(&self, u: &Coords, pool: &[Real], n: usize) -> [Real; 3] {
        self.node_force_with(u, |i| pool[i], n)
    }

    /// [`GridLaw::node_force`] with the pools from `pool(i)`.
    #[inline]
    fn node_force_with(&self, u: &Coords, pool: impl Fn(usize) -> Real, n: usize) -> [Real; 3] {
        let mut f = [0.0; 3];
        self.links(u, n, |j, k, rest, g| {
            let s = tension(k, rest, g.dl, self.q, pool(n), pool(j)) / g.l;
            f[0] += s * g.d[0];
            f[1] += s * g.d[1];
            f[2] += s * g.d[2];
        });
        f
    }
}

/// Virial stress at node `n` (Pa in 3D; N/m times 1/h, i.e. Pa, in 2D):
/// `sigma_n = 1/(2 V_n) sum_t T_t l_t e_t (x) e_t` over its springs, each spring's share split
/// evenly between its two ends. `u` and `tension` may be current (finite strain), or zero
/// displacement with linearised tensions (small strain).
pub fn node_virial(body: &Body, u: &Coords, tension: &[Real], n: usize) -> Matrix {
    let bonds = &*body.lattice.bonds;
    let mut s = Matrix::zeros();
    for e in bonds.row(n) {
        let b = bonds.bond[e] as usize;
        let j = bonds.neighbour(n, e);
        let (dx, dy, dz) = spring_vector(&body.lattice, u, n, j);
        let d = Vector::new(dx, dy, dz);
        let l = d.norm();
        s += (0.5 * tension[b] / l) * d * d.transpose();
    }
    s / body.lattice.node_volume(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A box moved away from the origin (as a case's box is, by its lower corner) sheds its
    /// rest lengths only where each is `|X_j - X_i|` of the moved nodes, to the bit: so a
    /// reader that recomputes a shed length from the positions (the frame, the CSR kernel)
    /// finds [`Lattice::rest`]'s, built or not. An offset that rounds some lengths otherwise
    /// keeps them; none (or one that rounds none) sheds them.
    #[test]
    fn a_moved_box_sheds_only_the_lengths_its_nodes_give() {
        let mut kept = 0;
        for offset in [0.0, 0.0347, -1.23e-2, 7.0] {
            for (hex, build) in [(false, false), (false, true), (true, false), (true, true)] {
                let mut l = if hex {
                    Lattice::hex_box(9, 7, 0.1, 0.3).unwrap()
                } else {
                    Lattice::cubic_box([6, 5, 7], 0.1).unwrap()
                };
                let dims = if hex { 2 } else { 3 };
                for c in 0..dims {
                    for x in l.pos.comp_mut(c) {
                        *x += offset * (1.0 + c as Real);
                    }
                }
                if build {
                    let _ = &*l.bonds;
                }
                let shed = l.shed_rest();
                assert!(l.bonds.grid().is_some());
                if !shed {
                    kept += 1;
                    assert!(offset != 0.0, "nodes in place shed their lengths");
                }
                for b in 0..l.bonds.len() {
                    let [i, j] = l.bonds.ends[b].map(|v| v as usize);
                    let (_, rest) =
                        super::spring_geometry_rest(&l, &Coords::zeros(l.len()), b, i, j);
                    assert_eq!(
                        rest.to_bits(),
                        l.rest(b).to_bits(),
                        "offset {offset}, spring {b}"
                    );
                }
            }
        }
        assert!(
            kept > 0,
            "no offset rounded a length otherwise: the test checks nothing"
        );
    }

    /// The forces of a few nodes from the pools of their neighbourhoods alone are the bits of
    /// [`update_forces`] at those nodes: a box from its grid (one stiffness, and without
    /// dispersion), the box with springs broken (its rows), random plates and solids with broken
    /// springs, with and without dispersion; corners, faces and the inside.
    #[test]
    fn forces_at_a_few_nodes_are_update_forces_bits() {
        let spec = crate::random::RandomSpec::default();
        let random = |dim: usize| {
            let hi = if dim == 2 {
                [9.0, 7.0, 0.0]
            } else {
                [5.0, 4.0, 4.0]
            };
            Lattice::random(dim, [0.0; 3], hi, 1.0, 1.0, spec, &|_| true).unwrap()
        };
        let cases = [
            (
                Body::uniform(Lattice::cubic_box([6, 5, 4], 0.1).unwrap(), 3.0, 0.3, 2.0),
                false,
            ),
            (
                Body::uniform(Lattice::cubic_box([6, 5, 4], 0.1).unwrap(), 3.0, 0.3, 2.0),
                true,
            ),
            (
                Body::uniform(Lattice::hex_box(9, 7, 0.1, 0.2).unwrap(), 3.0, 0.0, 2.0),
                false,
            ),
            (Body::uniform(random(2), 1.0, 0.3, 1.0), true),
            (Body::uniform(random(3), 1.0, -0.2, 1.0), true),
            (Body::uniform(random(3), 1.0, 0.0, 1.0), true),
        ];
        for (body, broken) in cases {
            let mut state = State::new(&body);
            let pos = body.lattice.pos.clone();
            for c in 0..body.lattice.dim() {
                for (i, u) in state.u.comp_mut(c).iter_mut().enumerate() {
                    let (x, y, z) = (pos.x()[i], pos.y()[i], pos.z()[i]);
                    *u = 1e-3 * (7.0 * x + 3.0 * c as Real).sin() * (5.0 * y).cos() + 2e-4 * z;
                }
            }
            if broken {
                for b in (0..body.springs()).step_by(7) {
                    state.kill_bond(&body, b);
                }
            }
            let n = body.nodes();
            let nodes = [0, n - 1, n / 2, n / 3, 1, n / 7];
            let some = forces_at(&body, &state, &nodes);
            let mut all = state.clone();
            update_forces(&body, &mut all);
            for (k, &i) in nodes.iter().enumerate() {
                let whole = [0, 1, 2].map(|c| all.f.comp(c)[i].to_bits());
                assert_eq!(
                    some[k].map(Real::to_bits),
                    whole,
                    "{:?}, q {}, node {i}",
                    body.lattice.kind,
                    body.q
                );
            }
        }
    }
}
