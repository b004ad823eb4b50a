//! What the parts of a run cost against its step (`hooke bench --fracture`, `--frame`,
//! `--static`): a fracture criterion that finds nothing to break, a running crack, an output
//! frame with every sink a case writes, and the static solver on the paper's block. Each
//! alternates the things compared in one process and reports medians; nothing here prints.

use std::time::Instant;

use anyhow::Result;
use hooke_core::dynamics::{Integrator, IntegratorOptions};
use hooke_core::loading::Loading;
use hooke_core::material::q_from_nu;
use hooke_core::moduli::{block_test, BlockTest};
use hooke_core::{Body, LatticeKind, Real, State};
use hooke_fracture::Fracture;
use hooke_sim::{Run, RunOptions, Simulation};
use serde::{Deserialize, Serialize};

use crate::bench::{alternate, block, integrator_options, median, moving, BenchOptions};
use crate::InputError;

/// A fracture criterion against the intact step (`hooke bench --fracture --json`'s keys): on
/// the bench's block with a criterion no spring reaches, and with a case, on its running
/// crack. Medians of alternating windows of `steps` steps.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FractureReport {
    pub lattice: String,
    pub kernel: String,
    pub nodes: usize,
    pub springs: usize,
    pub threads: usize,
    pub repeats: usize,
    pub steps: u64,
    pub intact_seconds_per_step: f64,
    pub fracture_seconds_per_step: f64,
    /// The stretch criterion's step over the intact one, nothing breaking.
    pub fracture_overhead: f64,
    /// On a case's running crack, where one was given.
    #[serde(flatten, skip_serializing_if = "Option::is_none")]
    pub running: Option<RunningCrack>,
}

/// A case's running crack against the same state stepped without breaking.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RunningCrack {
    pub case: String,
    pub case_nodes: usize,
    pub case_kernel: String,
    /// Simulated time the case ran to before the windows (s).
    pub crack_time: Real,
    pub springs_broken_while_timed: usize,
    pub case_intact_seconds_per_step: f64,
    pub case_fracture_seconds_per_step: f64,
    pub running_crack_overhead: f64,
}

fn check_windows(repeats: usize, steps: u64) -> Result<()> {
    if repeats == 0 || steps == 0 {
        return Err(InputError("--repeats and --steps must be at least 1".into()).into());
    }
    Ok(())
}

/// The stretch criterion with nothing breaking against the intact step, on the bench's block
/// (random3d or the lattice asked for), and with `case` (its name and its simulation) on its
/// running crack from `crack_time` (default: half its end time).
pub fn fracture(
    args: &BenchOptions,
    case: Option<(&str, Simulation)>,
    crack_time: Option<Real>,
) -> Result<FractureReport> {
    check_windows(args.repeats, args.steps)?;
    let lattice = block(args)?;
    let kind = lattice.kind;
    let q = q_from_nu(kind, if kind.dim() == 3 { 0.3 } else { 0.45 })?;
    let (body, mut state, mut it) = moving(args, lattice, q)?;
    let mut fr =
        hooke_fracture::Fracture::new(&body, Box::new(hooke_fracture::CriticalStretch::new(1.0)?));
    let steps = args.steps;
    let plain = (Loading::default(), integrator_options(args));
    let (with, without) = against_intact(&body, (&mut state, &mut it, &mut fr), &plain, args)?;
    if fr.broken_total > 0 {
        anyhow::bail!("{} springs broke in the intact benchmark", fr.broken_total);
    }
    let running = match case {
        Some((name, sim)) => Some(running_crack(name, sim, args, crack_time)?),
        None => None,
    };
    Ok(FractureReport {
        lattice: kind.name().into(),
        kernel: it.kernel().name().into(),
        nodes: body.nodes(),
        springs: body.springs(),
        threads: rayon::current_num_threads(),
        repeats: args.repeats,
        steps,
        intact_seconds_per_step: without / steps as f64,
        fracture_seconds_per_step: with / steps as f64,
        fracture_overhead: with / without,
        running,
    })
}

/// A case run to `crack_time`, then its fracture step against a copy of the same state and
/// integrator stepped without breaking.
fn running_crack(
    name: &str,
    mut sim: Simulation,
    args: &BenchOptions,
    crack_time: Option<Real>,
) -> Result<RunningCrack> {
    let until = crack_time.unwrap_or(0.5 * sim.end_time);
    let steps = args.steps;
    let body = &sim.body;
    let mut it = Integrator::new(body, &mut sim.state, sim.loading.clone(), &sim.options)?;
    let Some(mut fr) = sim.fracture.take() else {
        return Err(InputError(format!("{name}: the case has no fracture")).into());
    };
    let mut state = sim.state.clone();
    while state.time < until {
        fr.step(body, &mut state, &mut it, None);
    }
    let before = fr.broken_total;
    let plain = (sim.loading.clone(), sim.options.clone());
    let (with, without) = against_intact(body, (&mut state, &mut it, &mut fr), &plain, args)?;
    Ok(RunningCrack {
        case: name.into(),
        case_nodes: body.nodes(),
        case_kernel: it.kernel().name().into(),
        crack_time: until,
        springs_broken_while_timed: fr.broken_total - before,
        case_intact_seconds_per_step: without / steps as f64,
        case_fracture_seconds_per_step: with / steps as f64,
        running_crack_overhead: with / without,
    })
}

/// Medians of alternating windows of `args.steps` steps: the fracture step from `state` and
/// `it` against a copy of the same state and integrator (resumed from its checkpoint, with
/// `plain`'s loading and options) stepped without breaking.
fn against_intact(
    body: &Body,
    (state, it, fr): (&mut State, &mut Integrator, &mut Fracture),
    plain: &(Loading, IntegratorOptions),
    args: &BenchOptions,
) -> Result<(f64, f64)> {
    let mut plain_state = state.clone();
    let mut plain_it = Integrator::resume(
        body,
        &plain_state,
        plain.0.clone(),
        &plain.1,
        &it.checkpoint(),
    )?;
    let steps = args.steps;
    alternate(
        args.repeats,
        || {
            for _ in 0..steps {
                fr.step(body, state, it, None);
            }
            Ok(())
        },
        || {
            for _ in 0..steps {
                plain_it.step(body, &mut plain_state);
            }
            Ok(())
        },
    )
}

/// One static solve of the paper's block (`hooke bench --static --json`'s rows).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct StaticSolve {
    pub nu: Real,
    /// The best of three solves (s): the solver's time, not the machine's noise.
    pub seconds: f64,
    pub newton: usize,
    pub cg: usize,
    pub residual: Real,
    pub nodes: usize,
}

/// The static solves of the paper's 71x16x16 Ladd block at nu = -0.9, 0.3 and 0.49, each the
/// best of three.
pub fn static_solves() -> Result<Vec<StaticSolve>> {
    let mut rows = Vec::new();
    for nu in [-0.9, 0.3, 0.49] {
        let t = BlockTest::paper(LatticeKind::Cubic, nu);
        let mut best = f64::INFINITY;
        let mut last = None;
        for _ in 0..3 {
            let start = Instant::now();
            let r = block_test(&t)?;
            best = best.min(start.elapsed().as_secs_f64());
            last = Some(r);
        }
        let r = last.expect("ran three times");
        rows.push(StaticSolve {
            nu,
            seconds: best,
            newton: r.solve.newton_iterations,
            cg: r.solve.cg_iterations,
            residual: r.solve.residual,
            nodes: r.nodes,
        });
    }
    Ok(rows)
}

/// What an output frame costs a run (`hooke bench --frame --json`'s keys).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FrameReport {
    pub case: String,
    pub nodes: usize,
    pub springs: usize,
    pub kernel: String,
    pub threads: usize,
    pub repeats: usize,
    pub steps: u64,
    pub crack_time: Real,
    pub broken_springs: usize,
    /// Median seconds per step of the windows without a frame.
    pub step_seconds: f64,
    /// What a frame adds to the run's wall time (s), its background writer included.
    pub frame_seconds: f64,
    /// What the stepping thread waits for the frame call (s).
    pub frame_call_seconds: f64,
    pub frame_over_step: f64,
    pub resident_memory_bytes: Option<u64>,
    pub resident_bytes_per_node: Option<f64>,
    /// Whether the body holds its springs' rows after the frames (a box on a stencil kernel
    /// keeps none).
    pub rows_built: bool,
}

/// The cost of an output frame (every sink the case writes) against a step, on `sim` run to
/// `crack_time` (default: half its end time) with `opts` (whose output folder is a
/// temporary one, removed here): windows of a frame plus `steps` steps, waiting for the
/// frame's file at the end, alternate with windows of the steps alone, `repeats` times.
pub fn frame(
    name: &str,
    mut sim: Simulation,
    mut opts: RunOptions,
    args: &BenchOptions,
    crack_time: Option<Real>,
) -> Result<FrameReport> {
    check_windows(args.repeats, args.steps)?;
    // Only the frames the benchmark asks for: none from the case's schedule inside a window.
    sim.output_every = Real::INFINITY;
    sim.checkpoint_every = Real::INFINITY;
    let out = std::env::temp_dir().join(format!("hooke-bench-frame-{}", std::process::id()));
    opts.out = out.clone();
    let until = crack_time.unwrap_or(0.5 * sim.end_time);
    let (nodes, springs) = (sim.body.nodes(), sim.body.springs());
    let windows = frame_windows(sim, opts, args, until);
    let _ = std::fs::remove_dir_all(&out);
    let w = windows?;
    let step = w.without / args.steps as f64;
    let cost = (w.with - w.without).max(0.0);
    Ok(FrameReport {
        case: name.into(),
        nodes,
        springs,
        kernel: w.kernel,
        threads: rayon::current_num_threads(),
        repeats: args.repeats,
        steps: args.steps,
        crack_time: until,
        broken_springs: w.broken,
        step_seconds: step,
        frame_seconds: cost,
        frame_call_seconds: w.call,
        frame_over_step: cost / step,
        resident_memory_bytes: w.resident,
        resident_bytes_per_node: w.resident.map(|r| r as f64 / nodes as f64),
        rows_built: w.rows,
    })
}

/// What the frame windows measured, and what the run holds after them.
struct Windows {
    with: f64,
    without: f64,
    call: f64,
    kernel: String,
    broken: usize,
    resident: Option<u64>,
    rows: bool,
}

fn frame_windows(
    sim: Simulation,
    opts: RunOptions,
    args: &BenchOptions,
    until: Real,
) -> Result<Windows> {
    let mut run = Run::start(sim, opts)?;
    let mut quiet = hooke_sim::Silent;
    run.advance(until, &mut quiet)?;
    // Window A: a frame, --steps steps, and the wait for the frame's file; window B: the same
    // steps alone. A - B is what a frame adds to the run's wall time (the background writer
    // included); the frame call alone is what the stepping thread waits.
    let (mut ta, mut tb, mut tf) = (Vec::new(), Vec::new(), Vec::new());
    // Every window must take its steps: a run that reaches its end time stops stepping, and
    // windows of no steps would time nothing.
    let needed = 2 * args.repeats as u64 * args.steps;
    let left = run.simulation().end_time - run.simulation().state.time;
    let dt = run.integrator().dt();
    if (needed as Real) * dt > left {
        return Err(InputError(format!(
            "the windows need {needed} steps ({:.3e} s) but the case ends {left:.3e} s after --crack-time: use fewer --repeats or --steps, or an earlier --crack-time",
            needed as Real * dt
        ))
        .into());
    }
    for _ in 0..args.repeats {
        let t0 = Instant::now();
        run.frame()?;
        tf.push(t0.elapsed().as_secs_f64());
        run.steps(args.steps, &mut quiet)?;
        run.flush_outputs()?;
        ta.push(t0.elapsed().as_secs_f64());
        let t0 = Instant::now();
        run.steps(args.steps, &mut quiet)?;
        tb.push(t0.elapsed().as_secs_f64());
    }
    Ok(Windows {
        with: median(&mut ta),
        without: median(&mut tb),
        call: median(&mut tf),
        kernel: run.integrator().kernel().name().to_string(),
        broken: run.simulation().broken().0,
        resident: hooke_sys::resident_memory(),
        // What the run holds once it has written frames: a box on a stencil keeps no rows.
        rows: run.simulation().body.lattice.bonds.is_built(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::moduli::LatticeName;

    /// A criterion that finds nothing to break costs a positive, finite factor of the intact
    /// step, on every lattice, and the report carries `hooke bench --fracture --json`'s keys
    /// (no case: none of the running crack's); windows of no steps are refused.
    #[test]
    fn the_fracture_overhead_is_measured_on_every_lattice() {
        for lattice in [
            LatticeName::Cubic,
            LatticeName::Hex,
            LatticeName::Random2d,
            LatticeName::Random3d,
        ] {
            let args = BenchOptions {
                lattice,
                nodes: 2000,
                steps: 3,
                repeats: 1,
                ..Default::default()
            };
            let r = fracture(&args, None, None).unwrap();
            assert!(r.fracture_overhead.is_finite() && r.fracture_overhead > 0.0);
            assert!(r.nodes > 1000 && r.springs > r.nodes && r.running.is_none());
            let json = serde_json::to_value(&r).unwrap();
            for key in [
                "lattice",
                "kernel",
                "fracture_overhead",
                "intact_seconds_per_step",
            ] {
                assert!(json.get(key).is_some(), "{key}");
            }
            assert!(json.get("running_crack_overhead").is_none());
        }
        let none = BenchOptions {
            steps: 0,
            ..Default::default()
        };
        let e = fracture(&none, None, None).unwrap_err().to_string();
        assert!(e.contains("--steps"), "{e}");
    }
}
