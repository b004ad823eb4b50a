//! The quasi-static driver: load steps, each brought to equilibrium (Newton-CG, with adaptive
//! dynamic relaxation where Newton cannot), then springs beyond the criterion broken in rounds
//! with a new equilibrium after each round.
//!
//! Energy booking: each load step first applies its increment elastically; its work is the
//! trapezoid of the loads and of the supports' reactions between the two equilibria (exact for
//! a linear response). The breaking rounds run at fixed supports and loads: a break releases the
//! energy its springs held (booked by the fracture crate), and the re-equilibration that follows
//! lowers the potential `U - f_ext . u` further. That drop is what a running crack radiates and
//! a real solid turns into heat, booked as `dissipated`, so the balance closes through unstable
//! crack growth too.

use std::time::Instant;

use hooke_core::loading::Motion;
use hooke_core::statics::{self, Constraints, StaticOptions};
use hooke_core::{law, Body, Coords, Real, State};
use hooke_fracture::Fracture;

use crate::error::{Error, Result};
use crate::observer::{Observer, Progress};
use crate::output::{EnergyRow, Frame, Sink};
use crate::provenance::Provenance;
use crate::run::{open_sinks, region_reactions, RunOptions, Summary};
use crate::Simulation;

/// Run `steps` load steps of `sim` to its end time.
pub(crate) fn run(
    sim: &mut Simulation,
    steps: usize,
    opts: &RunOptions,
    obs: &mut dyn Observer,
) -> Result<Summary> {
    let mut sinks = open_sinks(sim, &opts.out, &opts.name, false, 0.0)?;
    let mut provenance = Provenance::start(sim, opts, None)?;
    let r = drive(sim, steps, &mut sinks, obs);
    match &r {
        Ok(_) => provenance.end("completed", &opts.out),
        Err(e @ Error::Interrupted { .. }) => provenance.end(&e.to_string(), &opts.out),
        Err(e) => provenance.end(&format!("failed: {e}"), &opts.out),
    }
    r
}

/// The supports: every prescribed DOF fixed (with its motion), a plate's z fixed, and each
/// translation that no boundary condition touches projected out as a free rigid motion rather
/// than left singular.
fn supports(sim: &Simulation) -> (Constraints, Vec<(usize, usize, Motion)>) {
    let n = sim.body.nodes();
    let dim = sim.body.lattice.dim();
    let mut cons = Constraints::all_free(n);
    if dim == 2 {
        for i in 0..n {
            cons.fix(i, 2);
        }
    }
    let mut dofs: Vec<(usize, usize, Motion)> = Vec::new();
    for p in &sim.loading.prescribed {
        for &i in &p.nodes {
            cons.fix(i as usize, p.axis);
            dofs.push((i as usize, p.axis, p.motion.clone()));
        }
    }
    // A translation along an axis that no boundary condition touches is a free rigid motion:
    // project it out rather than leave the stiffness singular.
    for c in 0..dim {
        if !dofs.iter().any(|&(_, axis, _)| axis == c) {
            let mut mode = Coords::zeros(n);
            mode.comp_mut(c).fill(1.0);
            cons.add_null_mode(mode);
        }
    }
    (cons, dofs)
}

/// Prescribed displacement at time `t` from `u0`; a prescribed velocity is integrated
/// (trapezoid rule, 256 intervals).
fn prescribed_displacement(m: &Motion, u0: Real, t: Real) -> Real {
    match m {
        Motion::Fixed => u0,
        Motion::Displacement(f) => f.value(t),
        Motion::Velocity(f) => {
            let k = 256;
            let h = t / k as Real;
            u0 + (0..k)
                .map(|j| 0.5 * h * (f.value(j as Real * h) + f.value((j + 1) as Real * h)))
                .sum::<Real>()
        }
    }
}

/// A progress report after load step `k` of `steps`: the energy balance from the work of the
/// loads and supports and the energy dissipated so far.
fn report(
    sim: &Simulation,
    obs: &mut dyn Observer,
    (k, steps): (usize, usize),
    start: Instant,
    (w_ext, w_bc, dissipated): (Real, Real, Real),
) {
    let t = sim.state.time;
    let wall = start.elapsed().as_secs_f64();
    let frac = k as f64 / steps as f64;
    let e = law::energy(
        &sim.body,
        &sim.state.u,
        sim.state.springs(&sim.body),
        sim.state.norm(),
    );
    obs.progress(&Progress {
        time: t,
        end_time: sim.end_time,
        fraction: frac,
        step: k as u64,
        steps_per_second: k as f64 / wall.max(1e-9),
        eta_seconds: Some(wall * (1.0 - frac) / frac),
        broken_springs: sim.broken().0,
        energy: e.total(),
        balance: (e.total() + sim.broken().1 + dissipated - w_ext - w_bc).abs()
            / (w_ext + w_bc).abs().max(e.total()).max(1e-300),
        energy_time: t,
        load_step: Some((k, steps)),
    });
}

/// The work of the loads and of the supports over a load increment from `u_prev`, added term
/// by term (trapezoid rule: the mean of the forces at its two ends).
fn add_work(
    (w_ext, w_bc): (&mut Real, &mut Real),
    (fext_prev, fext): (&Coords, &Coords),
    (state, u_prev): (&State, &Coords),
    dofs: &[(usize, usize, Motion)],
    reactions_prev: &[Real],
) {
    for c in 0..3 {
        for i in 0..u_prev.len() {
            *w_ext += 0.5
                * (fext_prev.comp(c)[i] + fext.comp(c)[i])
                * (state.u.comp(c)[i] - u_prev.comp(c)[i]);
        }
    }
    for (m, &(i, c, _)) in dofs.iter().enumerate() {
        let r = -state.f.comp(c)[i] - fext.comp(c)[i];
        *w_bc += 0.5 * (reactions_prev[m] + r) * (state.u.comp(c)[i] - u_prev.comp(c)[i]);
    }
}

/// The potential energy at fixed loads: the strain energy minus the loads' work `f . u`.
fn potential_energy(body: &hooke_core::Body, state: &State, fext: &Coords) -> Real {
    let e = law::energy(body, &state.u, state.springs(body), state.norm()).total();
    let mut w = 0.0;
    for c in 0..3 {
        for i in 0..state.u.len() {
            w += fext.comp(c)[i] * state.u.comp(c)[i];
        }
    }
    e - w
}

fn drive(
    sim: &mut Simulation,
    steps: usize,
    sinks: &mut [Box<dyn Sink>],
    obs: &mut dyn Observer,
) -> Result<Summary> {
    let n = sim.body.nodes();
    let (cons, dofs) = supports(sim);
    let u0: Vec<Real> = dofs
        .iter()
        .map(|&(i, c, _)| sim.state.u.comp(c)[i])
        .collect();
    let (mut w_ext, mut w_bc, mut dissipated) = (0.0, 0.0, 0.0);
    let mut fext = Coords::zeros(n);
    let mut fext_prev = Coords::zeros(n);
    let mut last = write(sim, sinks, &fext, &dofs, 0.0, 0.0, 0.0)?;
    let every = ((sim.output_every / (sim.end_time / steps as Real)).round() as usize).max(1);
    let mut reactions_prev = vec![0.0; dofs.len()];
    let mut peak: Real = 0.0;
    let start = Instant::now();
    let mut last_report = Instant::now();
    for k in 1..=steps {
        let t = sim.end_time * k as Real / steps as Real;
        let u_prev = sim.state.u.clone();
        for (m, &(i, c, ref mo)) in dofs.iter().enumerate() {
            sim.state.u.comp_mut(c)[i] = prescribed_displacement(mo, u0[m], t);
        }
        external_forces(sim, t, &mut fext);
        let at = LoadStep { k, steps, t, peak };
        // The load increment first, elastically (no spring breaks).
        equilibrate(&sim.body, &mut sim.state, &cons, &fext, None, at)?;
        add_work(
            (&mut w_ext, &mut w_bc),
            (&fext_prev, &fext),
            (&sim.state, &u_prev),
            &dofs,
            &reactions_prev,
        );
        break_rounds(sim, &cons, &fext, at, &mut dissipated)?;
        for (m, &(i, c, _)) in dofs.iter().enumerate() {
            let r = -sim.state.f.comp(c)[i] - fext.comp(c)[i];
            reactions_prev[m] = r;
            peak = peak.max(r.abs());
        }
        std::mem::swap(&mut fext_prev, &mut fext);
        sim.state.time = t;
        sim.state.step = k as u64;
        // An interrupted run writes its last step as a frame too (once, even on a frame step).
        let stopping = obs.interrupted();
        if k % every == 0 || k == steps || stopping {
            last = write(sim, sinks, &fext_prev, &dofs, w_ext, w_bc, dissipated)?;
        }
        if stopping {
            return Err(Error::Interrupted {
                step: k as u64,
                time: t,
                checkpoint: None,
                load_steps: Some((k, steps)),
            });
        }
        if let Some(interval) = obs.progress_interval() {
            if last_report.elapsed() >= interval || k == steps {
                last_report = Instant::now();
                report(sim, obs, (k, steps), start, (w_ext, w_bc, dissipated));
            }
        }
    }
    for s in sinks.iter_mut() {
        s.finish()?;
    }
    let (energy, reactions) = last;
    let work = energy.external_work + energy.boundary_work;
    let strain = energy.strain_direct + energy.strain_dispersive;
    Ok(Summary {
        steps: steps as u64,
        time: sim.state.time,
        wall_seconds: start.elapsed().as_secs_f64(),
        quasi_static: true,
        broken_springs: sim.broken().0,
        energy,
        balance: energy.balance_error.abs() / work.abs().max(strain).max(1e-300),
        rigid: Vec::new(),
        contact: None,
        outputs: sinks.iter().filter_map(|s| s.describe()).collect(),
        reactions,
        strain_by_material: sim.strain_by_material(),
    })
}

/// Where a quasi-static run stands: load step `k` of `steps`, at time `t`, with the largest
/// reaction so far `peak` (the solvers' force scale).
#[derive(Clone, Copy)]
struct LoadStep {
    k: usize,
    steps: usize,
    t: Real,
    peak: Real,
}

/// Equilibrium at fixed supports and loads: Newton-CG first; where it cannot (a mechanism or a
/// loose fragment after breaking, a buckling tangent), adaptive dynamic relaxation, which
/// tolerates both, with springs breaking (through `fr`) while the body relaxes, so that an
/// unstable crack runs through.
fn equilibrate(
    body: &Body,
    state: &mut State,
    cons: &Constraints,
    fext: &Coords,
    fr: Option<&mut Fracture>,
    at: LoadStep,
) -> Result<()> {
    let LoadStep { k, steps, t, peak } = at;
    let opts = StaticOptions {
        reference_force: Some((1e-6 * peak).max(1e-300)),
        ..Default::default()
    };
    let before = state.u.clone();
    match statics::solve(body, state, cons, Some(fext), &opts) {
        Ok(_) => Ok(()),
        Err(newton) => {
            state.u.copy_from(&before);
            let mut fr = fr;
            let mut hook = |s: &mut State| match fr.as_deref_mut() {
                Some(f) => f.break_alone(body, s).broken > 0,
                None => false,
            };
            let ropts = hooke_core::relax::RelaxOptions {
                tolerance: 1e-4,
                max_iterations: 100_000,
                reference_force: Some((1e-3 * peak).max(1e-300)),
            };
            hooke_core::relax::relax_with(body, state, cons, Some(fext), &ropts, &mut hook)
                .map(|_| ())
                .map_err(|e| Error::Failed(format!("load step {k} of {steps} (t = {t:e} s): Newton-CG failed ({newton}) and dynamic relaxation did not converge either: {e}")))
        }
    }
}

/// Breaking rounds at fixed supports and loads (see the module's docs): break, re-solve,
/// until no spring breaks. Adds to `dissipated` the energy each round dissipates beyond what
/// its broken springs released (J), round by round.
fn break_rounds(
    sim: &mut Simulation,
    cons: &Constraints,
    fext: &Coords,
    at: LoadStep,
    dissipated: &mut Real,
) -> Result<()> {
    let body = &sim.body;
    let potential = |state: &State| potential_energy(body, state, fext);
    for _ in 0..10_000 {
        let Some(fr) = sim.fracture.as_mut() else {
            break;
        };
        if fr.break_alone(body, &mut sim.state).broken == 0 {
            break;
        }
        let before = potential(&sim.state);
        let released_before = fr.released_total;
        equilibrate(body, &mut sim.state, cons, fext, sim.fracture.as_mut(), at)?;
        // Springs that break inside the solve (dynamic relaxation with breaking) booked
        // their own release.
        let released_during = sim
            .fracture
            .as_ref()
            .map_or(0.0, |f| f.released_total - released_before);
        *dissipated += before - potential(&sim.state) - released_during;
    }
    Ok(())
}

/// Body force and loads at time `t` into `fext`.
fn external_forces(sim: &Simulation, t: Real, fext: &mut Coords) {
    fext.fill_zero();
    let g = sim.loading.body_acceleration;
    for i in 0..sim.body.nodes() {
        fext.set(i, sim.body.mass[i] * g);
    }
    for l in &sim.loading.loads {
        for &i in &l.nodes {
            let i = i as usize;
            fext.set(i, fext.get(i) + l.force * l.scale.value(t));
        }
    }
}

/// One frame at equilibrium: fields (zero velocity), the energy row and the regions' reactions
/// (supports hold `-f_int - f_ext` on their DOFs; loads act where they are applied).
fn write(
    sim: &mut Simulation,
    sinks: &mut [Box<dyn Sink>],
    fext: &Coords,
    dofs: &[(usize, usize, Motion)],
    w_ext: Real,
    w_bc: Real,
    dissipated: Real,
) -> Result<(EnergyRow, Vec<crate::output::RegionReaction>)> {
    let body = &sim.body;
    let n = body.nodes();
    let t = sim.state.time;
    let zero = Coords::zeros(n);
    let mut forces = Coords::zeros(n);
    for l in &sim.loading.loads {
        for &i in &l.nodes {
            let i = i as usize;
            forces.set(i, forces.get(i) + l.force * l.scale.value(t));
        }
    }
    for &(i, c, _) in dofs {
        forces.comp_mut(c)[i] += -sim.state.f.comp(c)[i] - fext.comp(c)[i];
    }
    let reactions = region_reactions(sim, &forces);
    let e = law::energy(
        body,
        &sim.state.u,
        sim.state.springs(body),
        sim.state.norm(),
    );
    let released = sim.broken().1;
    let energy = EnergyRow {
        time: sim.state.time,
        kinetic: 0.0,
        strain_direct: e.direct,
        strain_dispersive: e.dispersive,
        external_work: w_ext,
        boundary_work: w_bc,
        body_work: 0.0,
        dissipated,
        released,
        balance_error: e.total() + released + dissipated - w_ext - w_bc,
    };
    let damage = sim.fracture.as_ref().map(|f| f.damage(body, &sim.state));
    let frame = Frame {
        body,
        state: &sim.state,
        velocity: &zero,
        damage: damage.as_deref(),
        derived: &hooke_io::fields::derived(&sim.body, &sim.state),
        regions: &sim.regions,
        energy,
        reactions: &reactions,
        contact: None,
        piece: None,
    };
    for s in sinks.iter_mut() {
        s.frame(&frame)?;
    }
    Ok((energy, reactions))
}
