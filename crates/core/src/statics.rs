//! Static equilibrium under prescribed displacements: Newton's method with a matrix-free,
//! Jacobi-preconditioned conjugate-gradient inner solve using the exact tangent
//! ([`crate::Tangent`]).
//!
//! The unknowns are the free degrees of freedom; prescribed ones keep the positions the caller
//! put in `state.u`. Residual: the internal (plus external) force on the free DOFs. Its size is
//! reported relative to the force scale of the problem, the norm of the reactions at the
//! prescribed DOFs plus the external load:
//!
//! ```text
//! relative residual = |f_free| / (|f_prescribed| + |f_ext|)
//! ```
//!
//! Rigid motions the constraints leave free (e.g. sliding ends) are removed by projecting them
//! out of every residual and search direction: no artificial support is added, so the solution
//! is the minimum-norm one and the measured moduli are not biased by a pinned node.

use crate::body::Body;
use crate::error::{Error, Result};
use crate::law;
use crate::math::{Coords, Real};
use crate::state::State;
use crate::tangent::Tangent;

/// Settings of the Newton-CG solve. Defaults in brackets.
#[derive(Clone, Debug)]
pub struct StaticOptions {
    /// Relative residual to reach [1e-9].
    pub tolerance: Real,
    /// Newton iterations allowed (default 30); a near-linear problem needs 2 to 4.
    pub max_newton: usize,
    /// CG iterations allowed per Newton iteration [20 000]; a 70-spacing bar needs a few hundred.
    pub max_cg: usize,
    /// Inexact Newton: each inner solve reduces the residual by this factor [1e-3]. Smaller
    /// wastes CG iterations on a linearisation that is about to change; larger costs Newton steps.
    pub forcing: Real,
    /// A force scale (N) to measure the residual against when the reactions are not a good
    /// one, e.g. once a body has been cut through and carries no load (default: none).
    pub reference_force: Option<Real>,
}

impl Default for StaticOptions {
    fn default() -> Self {
        StaticOptions {
            tolerance: 1e-9,
            max_newton: 30,
            max_cg: 20_000,
            forcing: 1e-3,
            reference_force: None,
        }
    }
}

/// What a converged solve did.
#[derive(Clone, Debug, Default)]
pub struct StaticReport {
    /// Newton iterations taken.
    pub newton_iterations: usize,
    /// CG iterations over all Newton iterations.
    pub cg_iterations: usize,
    /// Final relative residual.
    pub residual: Real,
    /// Force scale the residual is relative to (N).
    pub force_scale: Real,
}

/// Which DOFs are free (1.0) or prescribed (0.0), per node and axis, plus the rigid motions the
/// constraints leave free.
#[derive(Clone, Debug)]
pub struct Constraints {
    pub free: Coords,
    /// Orthonormal (over the free DOFs) zero-energy modes to project out.
    null_modes: Vec<Coords>,
}

impl Constraints {
    /// Every DOF free: the caller then fixes some with [`Constraints::fix`].
    pub fn all_free(n: usize) -> Self {
        let mut free = Coords::zeros(n);
        for c in 0..3 {
            free.comp_mut(c).fill(1.0);
        }
        Constraints {
            free,
            null_modes: Vec::new(),
        }
    }

    /// Prescribe axis `c` of node `i`.
    pub fn fix(&mut self, i: usize, c: usize) {
        self.free.comp_mut(c)[i] = 0.0;
    }

    /// Add a zero-energy mode the constraints do not hold (e.g. a rigid translation along a free
    /// axis). It is restricted to the free DOFs and orthonormalised against earlier modes.
    pub fn add_null_mode(&mut self, mut mode: Coords) {
        self.mask(&mut mode);
        for m in &self.null_modes {
            let d = mode.dot(m);
            mode.axpy(-d, m);
        }
        let n = mode.norm();
        if n > 0.0 {
            for c in 0..3 {
                mode.comp_mut(c).iter_mut().for_each(|v| *v /= n);
            }
            self.null_modes.push(mode);
        }
    }

    fn mask(&self, v: &mut Coords) {
        for c in 0..3 {
            for (a, m) in v.comp_mut(c).iter_mut().zip(self.free.comp(c)) {
                *a *= m;
            }
        }
    }

    /// Restrict `v` to the free DOFs and remove the null modes.
    pub fn project(&self, v: &mut Coords) {
        self.mask(v);
        for m in &self.null_modes {
            let d = v.dot(m);
            v.axpy(-d, m);
        }
    }
}

/// Norm of `f` on the prescribed DOFs (the reactions).
fn prescribed_norm(f: &Coords, cons: &Constraints) -> Real {
    let mut s = 0.0;
    for c in 0..3 {
        for (v, m) in f.comp(c).iter().zip(cons.free.comp(c)) {
            if *m == 0.0 {
                s += v * v;
            }
        }
    }
    s.sqrt()
}

/// Solve for static equilibrium; on success `state.u` is the equilibrium and `state.f` its
/// internal forces (the reactions on the prescribed DOFs).
pub fn solve(
    body: &Body,
    state: &mut State,
    cons: &Constraints,
    external: Option<&Coords>,
    opts: &StaticOptions,
) -> Result<StaticReport> {
    let n = body.nodes();
    let ext_norm = external.map_or(0.0, |f| f.norm());
    let residual = |state: &mut State| -> (Coords, Real) {
        law::update_forces(body, state);
        let mut r = state.f.clone();
        if let Some(fe) = external {
            r.axpy(1.0, fe);
        }
        let scale =
            (prescribed_norm(&state.f, cons) + ext_norm).max(opts.reference_force.unwrap_or(0.0));
        cons.project(&mut r);
        (r, scale)
    };
    let (mut r, mut scale) = residual(state);
    let mut report = StaticReport::default();
    let mut du = Coords::zeros(n);
    for newton in 0..=opts.max_newton {
        let rn = r.norm();
        let rel = if scale > 0.0 {
            rn / scale
        } else if rn == 0.0 {
            0.0
        } else {
            Real::INFINITY
        };
        report.residual = rel;
        report.force_scale = scale;
        if rel <= opts.tolerance {
            report.newton_iterations = newton;
            return Ok(report);
        }
        if newton == opts.max_newton {
            break;
        }
        let mut tangent = Tangent::new(body, state);
        let target = (opts.forcing * rn).max(0.1 * opts.tolerance * scale);
        report.cg_iterations += pcg(
            body,
            &mut tangent,
            cons,
            &r,
            &mut du,
            target,
            opts.max_cg,
            newton,
        )?;
        // Newton update with a backtracking safeguard: far from equilibrium a full step can
        // overshoot; near it the full step is always taken.
        let u0 = state.u.clone();
        let mut alpha = 1.0;
        loop {
            state.u.copy_from(&u0);
            state.u.axpy(alpha, &du);
            let (r_new, s_new) = residual(state);
            if r_new.norm() < rn || alpha < 1.0 / 64.0 {
                r = r_new;
                scale = s_new;
                break;
            }
            alpha *= 0.5;
        }
    }
    Err(Error::NotConverged {
        solver: "Newton",
        iterations: opts.max_newton,
        residual: report.residual,
        tolerance: opts.tolerance,
        hint: "reduce the prescribed displacement or raise the iteration limit",
    })
}

/// Preconditioned CG for `K du = r` on the free DOFs; returns the iterations taken.
#[allow(clippy::too_many_arguments)]
fn pcg(
    body: &Body,
    k: &mut Tangent,
    cons: &Constraints,
    r0: &Coords,
    du: &mut Coords,
    target: Real,
    max_iter: usize,
    newton: usize,
) -> Result<usize> {
    let n = r0.len();
    let mut inv_diag = k.diagonal(body);
    for c in 0..3 {
        for (d, m) in inv_diag.comp_mut(c).iter_mut().zip(cons.free.comp(c)) {
            *d = if *m != 0.0 && *d > 0.0 { 1.0 / *d } else { 0.0 };
        }
    }
    let precondition = |r: &Coords, z: &mut Coords| {
        for c in 0..3 {
            for ((zv, rv), dv) in z
                .comp_mut(c)
                .iter_mut()
                .zip(r.comp(c))
                .zip(inv_diag.comp(c))
            {
                *zv = rv * dv;
            }
        }
        cons.project(z);
    };
    du.fill_zero();
    let mut r = r0.clone();
    let mut z = Coords::zeros(n);
    precondition(&r, &mut z);
    let mut p = z.clone();
    let mut kp = Coords::zeros(n);
    let mut rz = r.dot(&z);
    for it in 0..max_iter {
        if r.norm() <= target {
            return Ok(it);
        }
        k.apply(body, &p, &mut kp);
        cons.project(&mut kp);
        let pkp = p.dot(&kp);
        if pkp <= 0.0 {
            return Err(Error::NotPositiveDefinite {
                curvature: pkp / p.dot(&p),
                newton,
                cg: it,
            });
        }
        let alpha = rz / pkp;
        du.axpy(alpha, &p);
        r.axpy(-alpha, &kp);
        precondition(&r, &mut z);
        let rz_new = r.dot(&z);
        let beta = rz_new / rz;
        rz = rz_new;
        for c in 0..3 {
            for (pv, zv) in p.comp_mut(c).iter_mut().zip(z.comp(c)) {
                *pv = zv + beta * *pv;
            }
        }
    }
    if r.norm() <= target {
        return Ok(max_iter);
    }
    Err(Error::NotConverged {
        solver: "conjugate gradient (inner solve)",
        iterations: max_iter,
        residual: r.norm() / r0.norm(),
        tolerance: target / r0.norm(),
        hint: "the body is very slender or nearly unconstrained; raise max_cg",
    })
}
