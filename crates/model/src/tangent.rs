//! The exact tangent stiffness `K = d^2 U / dx^2` of the dispersive law, applied matrix-free.
//!
//! With `e_t` the unit vector of spring `t` from node `n` to its neighbour, a perturbation `v`
//! of the positions changes the extension by `delta_t = e_t . (v_j - v_n)`, the pool ratios by
//! `delta p_n = sum_t k_t L_t delta_t / S_n`, and the tension by
//! `delta T_t = k_t delta_t + q k_t L_t (delta p_n + delta p_j)`. The force on node n,
//! `f_n = sum_t T_t e_t`, changes by
//!
//! ```text
//! delta f_n = sum_t [ delta T_t e_t + (T_t / l_t) ((v_j - v_n) - e_t delta_t) ]
//! ```
//!
//! and `K v = -delta f`. The first term is the material stiffness (positive semidefinite for
//! q > -1/2 on any damaged graph, `docs/model.md`); the second is the geometric stiffness of
//! the current tensions. Applying `K` is the same two gathers as a force evaluation.

use rayon::prelude::*;

use crate::body::Body;
use crate::math::{Coords, Real};
use crate::state::State;

const MIN_NODES_PER_TASK: usize = 1024;

/// The tangent stiffness at one state, frozen for repeated products (one Newton iteration).
///
/// Stored per undirected spring (unit vector from its lower to its higher end node, `k`, `k L`,
/// `T / l`: 48 bytes) and applied through the body's CSR rows, the direction of entry `n -> j`
/// being `+e` when `n < j` and `-e` otherwise. Half the memory traffic of per-entry storage, and
/// the product is memory-bound.
#[derive(Clone, Debug)]
pub struct Tangent {
    q: Real,
    /// Per spring: unit vector x, y, z, k (0 when broken), k L (0 when broken), T / l.
    data: Vec<[Real; 6]>,
    /// `1 / S_n` (0 for a node with no intact spring).
    inv_norm: Vec<Real>,
    /// Scratch: `delta p_n` of the last product.
    dpool: Vec<Real>,
}

impl Tangent {
    /// Freeze the tangent at `state` (its pools must be current: call
    /// [`crate::law::update_forces`] first).
    pub fn new(body: &Body, state: &State) -> Self {
        let bonds = &*body.lattice.bonds;
        let kk = state.springs(body).k;
        let lever = body.levers();
        let data = (0..bonds.len())
            .into_par_iter()
            .with_min_len(4096)
            .map(|b| {
                let [i, j] = bonds.ends[b].map(|v| v as usize);
                let rest = body.lattice.rest(b);
                let g = crate::law::spring_geometry(&body.lattice, &state.u, i, j, rest);
                let e = [g.d[0] / g.l, g.d[1] / g.l, g.d[2] / g.l];
                if state.alive[b] {
                    let t = crate::law::tension(
                        kk[b],
                        lever.get(b),
                        g.dl,
                        body.q,
                        state.pool[i],
                        state.pool[j],
                    );
                    [e[0], e[1], e[2], kk[b], kk[b] * lever.get(b), t / g.l]
                } else {
                    [e[0], e[1], e[2], 0.0, 0.0, 0.0]
                }
            })
            .collect();
        let inv_norm = state
            .norm
            .iter()
            .map(|&s| if s != 0.0 { 1.0 / s } else { 0.0 })
            .collect();
        Tangent {
            q: body.q,
            data,
            inv_norm,
            dpool: vec![0.0; body.nodes()],
        }
    }

    /// Number of nodes.
    pub fn nodes(&self) -> usize {
        self.inv_norm.len()
    }

    /// Unit vector of entry `n -> j` for spring data `d`.
    #[inline(always)]
    fn unit(d: &[Real; 6], n: usize, j: usize) -> [Real; 3] {
        if n < j {
            [d[0], d[1], d[2]]
        } else {
            [-d[0], -d[1], -d[2]]
        }
    }

    fn compute_dpool(&mut self, body: &Body, v: &Coords) {
        let bonds = &*body.lattice.bonds;
        let mut dpool = std::mem::take(&mut self.dpool);
        if self.q == 0.0 {
            dpool.fill(0.0);
        } else {
            let this = &*self;
            dpool
                .par_iter_mut()
                .with_min_len(MIN_NODES_PER_TASK)
                .enumerate()
                .for_each(|(n, dp)| {
                    let mut s = 0.0;
                    for e in bonds.row(n) {
                        let j = bonds.neighbour(n, e);
                        let d = &this.data[bonds.bond[e] as usize];
                        let u = Self::unit(d, n, j);
                        s += d[4]
                            * (u[0] * (v.x()[j] - v.x()[n])
                                + u[1] * (v.y()[j] - v.y()[n])
                                + u[2] * (v.z()[j] - v.z()[n]));
                    }
                    *dp = s * this.inv_norm[n];
                });
        }
        self.dpool = dpool;
    }

    /// `out = K v`.
    pub fn apply(&mut self, body: &Body, v: &Coords, out: &mut Coords) {
        self.compute_dpool(body, v);
        let bonds = &*body.lattice.bonds;
        let this = &*self;
        let [ox, oy, oz] = out.xyz_mut();
        ox.par_iter_mut()
            .zip(oy.par_iter_mut())
            .zip(oz.par_iter_mut())
            .with_min_len(MIN_NODES_PER_TASK)
            .enumerate()
            .for_each(|(n, ((ox, oy), oz))| {
                let mut acc = [0.0; 3];
                for e in bonds.row(n) {
                    let j = bonds.neighbour(n, e);
                    let d = &this.data[bonds.bond[e] as usize];
                    let u = Self::unit(d, n, j);
                    let w = [
                        v.x()[j] - v.x()[n],
                        v.y()[j] - v.y()[n],
                        v.z()[j] - v.z()[n],
                    ];
                    let delta = u[0] * w[0] + u[1] * w[1] + u[2] * w[2];
                    let dt = d[3] * delta + this.q * d[4] * (this.dpool[n] + this.dpool[j]);
                    for c in 0..3 {
                        acc[c] += dt * u[c] + d[5] * (w[c] - u[c] * delta);
                    }
                }
                *ox = -acc[0];
                *oy = -acc[1];
                *oz = -acc[2];
            });
    }

    /// Linearised tension change `delta T_b` of every spring for a perturbation `v` (indexed by
    /// undirected spring id). Used to measure small-strain stresses exactly.
    pub fn tension_changes(&mut self, body: &Body, v: &Coords) -> Vec<Real> {
        self.compute_dpool(body, v);
        let bonds = &*body.lattice.bonds;
        (0..bonds.len())
            .map(|b| {
                let [i, j] = bonds.ends[b].map(|x| x as usize);
                let d = &self.data[b];
                let delta = d[0] * (v.x()[j] - v.x()[i])
                    + d[1] * (v.y()[j] - v.y()[i])
                    + d[2] * (v.z()[j] - v.z()[i]);
                d[3] * delta + self.q * d[4] * (self.dpool[i] + self.dpool[j])
            })
            .collect()
    }

    /// The diagonal of `K` (exact), for Jacobi preconditioning.
    pub fn diagonal(&self, body: &Body) -> Coords {
        let bonds = &*body.lattice.bonds;
        let n_nodes = self.nodes();
        let mut diag = Coords::zeros(n_nodes);
        for n in 0..n_nodes {
            // Moving node n by a unit along axis c changes delta_t by -e_t,c on each of its
            // springs, its own pool by -sum_t k_t L_t e_t,c / S_n, and each neighbour j's pool by
            // -k_t L_t e_t,c / S_j (the spring's direction seen from j flips, and so does the
            // displacement difference).
            for c in 0..3 {
                let (mut direct, mut own, mut others) = (0.0, 0.0, 0.0);
                for e in bonds.row(n) {
                    let j = bonds.neighbour(n, e);
                    let d = &self.data[bonds.bond[e] as usize];
                    let ec = Self::unit(d, n, j)[c];
                    direct += d[3] * ec * ec + d[5] * (1.0 - ec * ec);
                    own += d[4] * ec;
                    others += (d[4] * ec).powi(2) * self.inv_norm[j];
                }
                diag.comp_mut(c)[n] = direct + self.q * (own * own * self.inv_norm[n] + others);
            }
        }
        diag
    }
}
