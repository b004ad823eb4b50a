//! Adaptive dynamic relaxation (Kilic and Madenci, 2010): quasi-static equilibrium with an
//! explicit, matrix-free iteration. It is the explicit codes' alternative to [`crate::statics`]
//! (which is faster and more accurate on intact bodies; ADR needs no linear solve and keeps
//! going through softening and bond loss).
//!
//! With a unit pseudo time step, fictitious diagonal masses `lambda_i >= 1/4 sum_j |K_ij|`
//! (Gershgorin, so the iteration is stable) and the residual `F = f_int + f_ext`:
//!
//! ```text
//! c^n       = 2 sqrt( u.K1.u / u.u ),  K1_ii = -(F_i^n - F_i^{n-1}) / (lambda_i V_i^{n-1/2})
//! V^{n+1/2} = ((2 - c^n) V^{n-1/2} + 2 F^n / lambda) / (2 + c^n),   V^{1/2} = F^0 / (2 lambda)
//! u^{n+1}   = u^n + V^{n+1/2}
//! ```
//!
//! The damping `c` follows the lowest participating frequency (`c` is clamped to [0, 2)).
//! Our Gershgorin bound for the dispersive law, per node n with `A_m = sum_t k_t L_t` over m's
//! intact springs: `sum_j |K_nj| <= 2 sqrt(3) [ sum_t (k_t + |T_t|/l_t)
//!   + |q| (A_n^2 / S_n + sum_t k_t L_t A_j / S_j) ]`.

use crate::body::Body;
use crate::error::{Error, Result};
use crate::law;
use crate::math::{Coords, Real};
use crate::state::State;
use crate::statics::Constraints;

/// Settings of the relaxation. Defaults: tolerance 1e-6, 200 000 iterations.
#[derive(Clone, Debug)]
pub struct RelaxOptions {
    pub tolerance: Real,
    pub max_iterations: usize,
    /// A force scale (N) for the residual when the reactions are not a good one, e.g. once a
    /// body has been cut through (default: none).
    pub reference_force: Option<Real>,
}

impl Default for RelaxOptions {
    fn default() -> Self {
        RelaxOptions {
            tolerance: 1e-6,
            max_iterations: 200_000,
            reference_force: None,
        }
    }
}

/// What a relaxation did.
#[derive(Clone, Copy, Debug, Default)]
pub struct RelaxReport {
    pub iterations: usize,
    /// Relative residual `|F_free| / (|f_prescribed| + |f_ext|)`.
    pub residual: Real,
}

/// Fictitious masses (Gershgorin bound on the tangent's rows) at the current state.
fn fictitious_mass(body: &Body, state: &State) -> Vec<Real> {
    let bonds = &*body.lattice.bonds;
    let kk = state.springs(body).k;
    let lever = body.levers();
    let n = body.nodes();
    let a: Vec<Real> = (0..n)
        .map(|m| {
            bonds
                .row(m)
                .filter(|&e| state.alive[bonds.bond[e] as usize])
                .map(|e| {
                    let b = bonds.bond[e] as usize;
                    kk[b] * lever.get(b)
                })
                .sum()
        })
        .collect();
    let inv_s = |m: usize| {
        if state.norm[m] > 0.0 {
            1.0 / state.norm[m]
        } else {
            0.0
        }
    };
    (0..n)
        .map(|i| {
            let mut direct = 0.0;
            let mut disp = a[i] * a[i] * inv_s(i);
            for e in bonds.row(i) {
                let b = bonds.bond[e] as usize;
                if !state.alive[b] {
                    continue;
                }
                let j = bonds.neighbour(i, e);
                let rest = body.lattice.rest(b);
                let g = law::spring_geometry(&body.lattice, &state.u, i, j, rest);
                let (k, pools) = (kk[b], (state.pool[i], state.pool[j]));
                let t = law::tension(k, lever.get(b), g.dl, body.q, pools.0, pools.1);
                direct += kk[b] + (t / g.l).abs();
                disp += kk[b] * lever.get(b) * a[j] * inv_s(j);
            }
            let row = 2.0 * (3.0 as Real).sqrt() * (direct + body.q_abs_max() * disp);
            // A node with no intact spring gets a unit mass: it has no stiffness to bound.
            if row > 0.0 {
                0.25 * row
            } else {
                1.0
            }
        })
        .collect()
}

/// Relax `state` to equilibrium under the constraints (prescribed DOFs keep their values) and
/// optional external forces.
pub fn relax(
    body: &Body,
    state: &mut State,
    cons: &Constraints,
    external: Option<&Coords>,
    opts: &RelaxOptions,
) -> Result<RelaxReport> {
    relax_with(body, state, cons, external, opts, &mut |_| false)
}

/// [`relax`] with a hook called every 10 iterations on the current state, e.g. to break springs
/// as the body relaxes (unstable crack growth settles only if springs break on the way). The
/// hook returns true when it changed the springs; the fictitious masses stay valid because
/// breaking only lowers the stiffness.
pub fn relax_with(
    body: &Body,
    state: &mut State,
    cons: &Constraints,
    external: Option<&Coords>,
    opts: &RelaxOptions,
    hook: &mut dyn FnMut(&mut State) -> bool,
) -> Result<RelaxReport> {
    let n = body.nodes();
    law::update_forces(body, state);
    let lambda = fictitious_mass(body, state);
    let ext_norm = external.map_or(0.0, |f| f.norm());
    let residual = |state: &State, r: &mut Coords| -> Real {
        r.clone_from(&state.f);
        if let Some(fe) = external {
            r.axpy(1.0, fe);
        }
        let mut fixed = 0.0;
        for c in 0..3 {
            for (v, m) in state.f.comp(c).iter().zip(cons.free.comp(c)) {
                if *m == 0.0 {
                    fixed += v * v;
                }
            }
        }
        cons.project(r);
        (fixed.sqrt() + ext_norm).max(opts.reference_force.unwrap_or(0.0))
    };
    let mut r = Coords::zeros(n);
    let mut r_old = Coords::zeros(n);
    let mut vel = Coords::zeros(n);
    let mut scale = residual(state, &mut r);
    let mut report = RelaxReport::default();
    for it in 0..opts.max_iterations {
        let rel = if scale > 0.0 {
            r.norm() / scale
        } else if r.norm() == 0.0 {
            0.0
        } else {
            Real::INFINITY
        };
        report = RelaxReport {
            iterations: it,
            residual: rel,
        };
        if rel <= opts.tolerance {
            return Ok(report);
        }
        let c = if it == 0 {
            0.0
        } else {
            // Local (Rayleigh-quotient) stiffness estimate along the current displacement.
            let (mut num, mut den) = (0.0, 0.0);
            for comp in 0..3 {
                for i in 0..n {
                    let v = vel.comp(comp)[i];
                    let u = state.u.comp(comp)[i] * cons.free.comp(comp)[i];
                    if v != 0.0 {
                        let k1 = -(r.comp(comp)[i] - r_old.comp(comp)[i]) / (lambda[i] * v);
                        num += u * k1 * u;
                    }
                    den += u * u;
                }
            }
            if den > 0.0 && num > 0.0 {
                (2.0 * (num / den).sqrt()).min(1.99)
            } else {
                0.0
            }
        };
        for comp in 0..3 {
            for i in 0..n {
                let f = r.comp(comp)[i] / lambda[i];
                let v = &mut vel.comp_mut(comp)[i];
                *v = if it == 0 {
                    0.5 * f
                } else {
                    ((2.0 - c) * *v + 2.0 * f) / (2.0 + c)
                };
                state.u.comp_mut(comp)[i] += *v;
            }
        }
        r_old.clone_from(&r);
        if it % 10 == 9 {
            hook(state);
        }
        law::update_forces(body, state);
        scale = residual(state, &mut r);
        if !r.norm().is_finite() {
            return Err(Error::Unstable {
                step: it as u64,
                time: 0.0,
                node: 0,
                reason: "the relaxation residual became non-finite".into(),
                hint: "check the loads; dynamic relaxation cannot pass a loss of stability",
            });
        }
    }
    Err(Error::NotConverged {
        solver: "adaptive dynamic relaxation",
        iterations: opts.max_iterations,
        residual: report.residual,
        tolerance: opts.tolerance,
        hint: "raise max_iterations or loosen the tolerance; for intact bodies use the Newton-CG solver",
    })
}
