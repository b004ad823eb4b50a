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
//! q > -1/2 on any damaged graph, `design/MODEL.md`); the second is the geometric stiffness of
//! the current tensions. Applying `K` is the same two gathers as a force evaluation.

use rayon::prelude::*;

use crate::body::Body;
use crate::math::{Coords, Real};
use crate::state::State;

const MIN_NODES_PER_TASK: usize = 1024;

/// The tangent stiffness at one state, frozen for repeated products (one Newton iteration).
#[derive(Clone, Debug)]
pub struct Tangent {
    q: Real,
    offsets: Vec<u32>,
    nbr: Vec<u32>,
    /// Unit vector from the row's node to the neighbour, per directed entry.
    ex: Vec<Real>,
    ey: Vec<Real>,
    ez: Vec<Real>,
    /// `k_t` (0 for a broken spring), per entry.
    k: Vec<Real>,
    /// `k_t L_t` (0 for a broken spring), per entry.
    kl: Vec<Real>,
    /// `T_t / l_t`, per entry.
    geo: Vec<Real>,
    /// `1 / S_n` (0 for a node with no intact spring).
    inv_norm: Vec<Real>,
    /// Scratch: `delta p_n` of the last product.
    dpool: Vec<Real>,
}

impl Tangent {
    /// Freeze the tangent at `state` (its pools must be current: call
    /// [`crate::law::update_forces`] first).
    pub fn new(body: &Body, state: &State) -> Self {
        let bonds = &body.lattice.bonds;
        let m = bonds.nbr.len();
        let (mut ex, mut ey, mut ez) = (vec![0.0; m], vec![0.0; m], vec![0.0; m]);
        let (mut k, mut kl, mut geo) = (vec![0.0; m], vec![0.0; m], vec![0.0; m]);
        for n in 0..body.nodes() {
            for e in bonds.row(n) {
                let b = bonds.bond[e] as usize;
                let j = bonds.nbr[e] as usize;
                let (dx, dy, dz) = crate::law::spring_vector(&body.lattice, &state.u, n, j);
                let d = crate::math::Vector::new(dx, dy, dz);
                let l = d.norm();
                ex[e] = d.x / l;
                ey[e] = d.y / l;
                ez[e] = d.z / l;
                if state.alive[b] {
                    let rest = bonds.rest[b];
                    let dl = crate::law::spring_geometry(&body.lattice, &state.u, n, j, rest).dl;
                    let t = crate::law::tension(
                        body.k[b],
                        rest,
                        dl,
                        body.q,
                        state.pool[n],
                        state.pool[j],
                    );
                    k[e] = body.k[b];
                    kl[e] = body.k[b] * rest;
                    geo[e] = t / l;
                }
            }
        }
        let inv_norm = state
            .norm
            .iter()
            .map(|&s| if s > 0.0 { 1.0 / s } else { 0.0 })
            .collect();
        Tangent {
            q: body.q,
            offsets: bonds.offsets.clone(),
            nbr: bonds.nbr.clone(),
            ex,
            ey,
            ez,
            k,
            kl,
            geo,
            inv_norm,
            dpool: vec![0.0; body.nodes()],
        }
    }

    /// Number of nodes.
    pub fn nodes(&self) -> usize {
        self.inv_norm.len()
    }

    #[inline]
    fn delta(&self, v: &Coords, n: usize, e: usize) -> (Real, Real, Real, Real) {
        let j = self.nbr[e] as usize;
        let (dx, dy, dz) = (v.x[j] - v.x[n], v.y[j] - v.y[n], v.z[j] - v.z[n]);
        (
            self.ex[e] * dx + self.ey[e] * dy + self.ez[e] * dz,
            dx,
            dy,
            dz,
        )
    }

    fn compute_dpool(&mut self, v: &Coords) {
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
                    for e in this.offsets[n] as usize..this.offsets[n + 1] as usize {
                        s += this.kl[e] * this.delta(v, n, e).0;
                    }
                    *dp = s * this.inv_norm[n];
                });
        }
        self.dpool = dpool;
    }

    /// `out = K v`.
    pub fn apply(&mut self, v: &Coords, out: &mut Coords) {
        self.compute_dpool(v);
        let this = &*self;
        out.x
            .par_iter_mut()
            .zip(out.y.par_iter_mut())
            .zip(out.z.par_iter_mut())
            .with_min_len(MIN_NODES_PER_TASK)
            .enumerate()
            .for_each(|(n, ((ox, oy), oz))| {
                let (mut sx, mut sy, mut sz) = (0.0, 0.0, 0.0);
                for e in this.offsets[n] as usize..this.offsets[n + 1] as usize {
                    let j = this.nbr[e] as usize;
                    let (d, dx, dy, dz) = this.delta(v, n, e);
                    let dt = this.k[e] * d + this.q * this.kl[e] * (this.dpool[n] + this.dpool[j]);
                    let g = this.geo[e];
                    sx += dt * this.ex[e] + g * (dx - this.ex[e] * d);
                    sy += dt * this.ey[e] + g * (dy - this.ey[e] * d);
                    sz += dt * this.ez[e] + g * (dz - this.ez[e] * d);
                }
                *ox = -sx;
                *oy = -sy;
                *oz = -sz;
            });
    }

    /// Linearised tension change `delta T_b` of every spring for a perturbation `v` (indexed by
    /// undirected spring id). Used to measure small-strain stresses exactly.
    pub fn tension_changes(&mut self, body: &Body, v: &Coords) -> Vec<Real> {
        self.compute_dpool(v);
        let bonds = &body.lattice.bonds;
        let mut out = vec![0.0; bonds.len()];
        for n in 0..self.nodes() {
            for e in bonds.row(n) {
                let j = bonds.nbr[e] as usize;
                if n < j {
                    let d = self.delta(v, n, e).0;
                    out[bonds.bond[e] as usize] =
                        self.k[e] * d + self.q * self.kl[e] * (self.dpool[n] + self.dpool[j]);
                }
            }
        }
        out
    }

    /// The diagonal of `K` (exact), for Jacobi preconditioning.
    pub fn diagonal(&self) -> Coords {
        let n_nodes = self.nodes();
        let mut d = Coords::zeros(n_nodes);
        for n in 0..n_nodes {
            let row = self.offsets[n] as usize..self.offsets[n + 1] as usize;
            // Moving node n by a unit along axis c changes delta_t by -e_t,c on each of its
            // springs, its own pool by -sum_t k_t L_t e_t,c / S_n, and each neighbour j's pool by
            // -k_t L_t e_t,c / S_j (the spring's direction seen from j flips, and so does the
            // displacement difference).
            for c in 0..3 {
                let comp = |e: usize| match c {
                    0 => self.ex[e],
                    1 => self.ey[e],
                    _ => self.ez[e],
                };
                let mut direct = 0.0;
                let mut own = 0.0;
                let mut others = 0.0;
                for e in row.clone() {
                    let ec = comp(e);
                    direct += self.k[e] * ec * ec + self.geo[e] * (1.0 - ec * ec);
                    own += self.kl[e] * ec;
                    let j = self.nbr[e] as usize;
                    others += (self.kl[e] * ec).powi(2) * self.inv_norm[j];
                }
                d.comp_mut(c)[n] = direct + self.q * (own * own * self.inv_norm[n] + others);
            }
        }
        d
    }
}
