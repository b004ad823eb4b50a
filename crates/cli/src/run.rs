//! `hooke run` and `hooke check`: case files end to end.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;
use hooke_case::Simulation;
use hooke_core::dynamics::Integrator;
use hooke_core::Real;
use hooke_io::checkpoint::digest;
use hooke_io::{Checkpoint, FrameExtras, VtkSeries};

use crate::InputError;

#[derive(Debug, Args)]
pub struct RunArgs {
    /// The case file (TOML).
    pub case: PathBuf,
    /// Output directory (default: next to the case, CASE_STEM.out). An existing run there is
    /// never overwritten silently.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Resolution factor: the lattice spacing is divided by it (0.25: a quick, coarse look).
    #[arg(long, default_value_t = 1.0)]
    pub scale: Real,
    /// Continue from a checkpoint written by an earlier run of the same case and scale.
    #[arg(long)]
    pub resume: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub struct CheckArgs {
    /// The case file (TOML).
    pub case: PathBuf,
    /// Resolution factor, as for `hooke run`.
    #[arg(long, default_value_t = 1.0)]
    pub scale: Real,
}

/// Free bytes on the file system that holds `dir` (or its nearest existing ancestor).
fn free_space(dir: &Path) -> Option<u64> {
    let mut p = dir;
    while !p.exists() {
        p = p.parent()?;
    }
    let c = std::ffi::CString::new(p.as_os_str().as_encoded_bytes()).ok()?;
    let mut s = std::mem::MaybeUninit::<libc::statvfs>::uninit();
    // SAFETY: `c` is a valid NUL-terminated path and `s` points to writable memory of the right
    // type; statvfs only writes through it and reports failure by its return value.
    let r = unsafe { libc::statvfs(c.as_ptr(), s.as_mut_ptr()) };
    if r != 0 {
        return None;
    }
    // SAFETY: statvfs succeeded, so it filled the struct.
    let s = unsafe { s.assume_init() };
    Some(s.f_bavail as u64 * s.f_frsize as u64)
}

/// What a run will write (bytes): frames (VTK base64 and/or HDF5), the energy history and the
/// checkpoint (twice, while it is renamed into place).
fn output_estimate(sim: &Simulation) -> f64 {
    let (n, s) = (sim.body.nodes() as f64, sim.body.springs() as f64);
    let frames = (sim.end_time / sim.output_every).ceil() + 2.0;
    // Per node: coordinates and 17 values of 8 bytes (vectors, scalars, stress), a u32 region
    // id, and a vertex cell; base64 adds a third.
    let mut per_frame = 0.0;
    if sim.vtk {
        per_frame += n * (4.0 / 3.0) * (20.0 * 8.0 + 4.0 + 17.0)
            + if sim.springs {
                s * (4.0 / 3.0) * 25.0
            } else {
                0.0
            };
    }
    if sim.hdf5 {
        per_frame += n * 18.0 * 8.0;
    }
    frames * (per_frame + 200.0) + 2.0 * (48.0 * n + s + 200.0)
}

/// The series a run writes.
struct Output {
    vtk: Option<VtkSeries>,
    #[cfg(feature = "hdf5")]
    h5: Option<hooke_io::H5Series>,
}

/// A run stopped by Ctrl-C (exit code 130, the shell's convention for SIGINT).
#[derive(Debug)]
pub struct Interrupted(pub String);

impl std::fmt::Display for Interrupted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Interrupted {}

fn load(case: &Path, scale: Real) -> Result<(Simulation, u64)> {
    let sim = hooke_case::load(case, scale).map_err(|e| InputError(e.to_string()))?;
    let text = std::fs::read(case).with_context(|| format!("reading {}", case.display()))?;
    let mut key = text;
    key.extend_from_slice(format!("\nscale={scale:e}").as_bytes());
    Ok((sim, digest(&key)))
}

fn stem(case: &Path) -> String {
    case.file_stem()
        .map_or_else(|| "run".into(), |s| s.to_string_lossy().into_owned())
}

pub fn check(args: CheckArgs) -> Result<()> {
    let (mut sim, _) = load(&args.case, args.scale)?;
    let it = Integrator::new(&sim.body, &mut sim.state, sim.loading.clone(), &sim.options)
        .map_err(|e| InputError(format!("{}: {e}", args.case.display())))?;
    let (n, s) = (sim.body.nodes(), sim.body.springs());
    let steps = (sim.end_time / it.dt).ceil();
    // Time a few steps on a copy, for the estimate.
    let mut probe = sim.state.clone();
    let mut it2 = Integrator::new(&sim.body, &mut probe, sim.loading.clone(), &sim.options)?;
    let t0 = Instant::now();
    let trial = 5;
    for _ in 0..trial {
        it2.step(&sim.body, &mut probe);
    }
    let per_step = t0.elapsed().as_secs_f64() / trial as f64;
    let bytes = 168 * n + 41 * s;
    println!("{}: valid", args.case.display());
    println!(
        "  lattice      {} ({} kernel), spacing {:e} m",
        sim.body.lattice.kind.name(),
        it.kernel.name(),
        sim.body.lattice.spacing
    );
    println!("  nodes        {n}");
    println!(
        "  springs      {s} ({} removed by pre-cracks)",
        sim.precracked
    );
    println!("  k, q         {:e} N/m, {:.6}", sim.k, sim.q);
    println!(
        "  fracture     {}",
        sim.fracture
            .as_ref()
            .map_or("off".to_string(), |f| format!("{:?}", f.criterion()))
    );
    println!(
        "  dt           {:e} s (critical {:e} s), {} steps to {:e} s",
        it.dt, it.stable.dt_critical, steps, sim.end_time
    );
    println!(
        "  memory       about {:.1} MiB",
        bytes as f64 / (1 << 20) as f64
    );
    println!(
        "  time         {:.3} ms per step, about {:.1} s in all",
        per_step * 1e3,
        per_step * steps
    );
    Ok(())
}

pub fn run(args: RunArgs) -> Result<()> {
    let (mut sim, case_digest) = load(&args.case, args.scale)?;
    let name = stem(&args.case);
    let out = args.out.clone().unwrap_or_else(|| {
        let dir = args.case.parent().unwrap_or(Path::new("."));
        if args.scale == 1.0 {
            dir.join(format!("{name}.out"))
        } else {
            dir.join(format!("{name}.scale{}.out", args.scale))
        }
    });
    let pvd = out.join(format!("{name}.pvd"));
    let ckpt_path = out.join(format!("{name}.ckpt"));
    if args.resume.is_none()
        && [
            pvd.clone(),
            out.join(format!("{name}.xdmf")),
            ckpt_path.clone(),
        ]
        .iter()
        .any(|p| p.exists())
    {
        return Err(InputError(format!("{} already holds a run; choose another --out, remove it, or continue it with --resume {}", out.display(), ckpt_path.display())).into());
    }
    let need = output_estimate(&sim);
    if let Some(free) = free_space(&out) {
        if need > free as f64 {
            return Err(InputError(format!(
                "the run would write about {:.1} MB but only {:.1} MB are free under {}; write fewer frames (output.every), use --out on a larger disk, or a coarser --scale",
                need / 1e6,
                free as f64 / 1e6,
                out.display()
            ))
            .into());
        }
    }
    #[cfg(not(feature = "hdf5"))]
    if sim.hdf5 {
        return Err(InputError(format!("{}: output.format asks for \"hdf5\", but this hooke was built without HDF5; install the library (tools/install-hdf5.sh) and build with --features hdf5", args.case.display())).into());
    }
    let it = match &args.resume {
        None => Integrator::new(&sim.body, &mut sim.state, sim.loading.clone(), &sim.options)
            .map_err(|e| InputError(e.to_string()))?,
        Some(path) => {
            let ck = Checkpoint::load(path, &sim.body, case_digest)
                .map_err(|e| InputError(e.to_string()))?;
            sim.state = ck.state.clone();
            if let Some(fr) = sim.fracture.as_mut() {
                fr.broken_total = ck.broken as usize;
                fr.released_total = ck.released;
            }
            Integrator::resume(
                &sim.body,
                &sim.state,
                sim.loading.clone(),
                &sim.options,
                &ck.integrator,
            )?
        }
    };
    let mut it = it;
    let until = sim.state.time;
    let resuming = args.resume.is_some();
    let mut output = Output {
        vtk: if !sim.vtk {
            None
        } else if resuming {
            Some(
                VtkSeries::reopen(&out, &name, sim.springs, until)
                    .map_err(|e| InputError(e.to_string()))?,
            )
        } else {
            Some(
                VtkSeries::create(&out, &name, sim.springs)
                    .map_err(|e| InputError(e.to_string()))?,
            )
        },
        #[cfg(feature = "hdf5")]
        h5: if !sim.hdf5 {
            None
        } else if resuming {
            Some(
                hooke_io::H5Series::reopen(&out, &name, &sim.body, until)
                    .map_err(|e| InputError(e.to_string()))?,
            )
        } else {
            Some(
                hooke_io::H5Series::create(&out, &name, &sim.body)
                    .map_err(|e| InputError(e.to_string()))?,
            )
        },
    };
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = stop.clone();
        // A second handler cannot be installed in one process; tests call run() once per process.
        let _ = ctrlc::set_handler(move || stop.store(true, Ordering::SeqCst));
    }
    let energy_path = out.join(format!("{name}_energy.csv"));
    if args.resume.is_none() {
        std::fs::write(&energy_path, "time,kinetic,strain_direct,strain_dispersive,external_work,boundary_work,body_work,dissipated,released,balance_error\n").with_context(|| format!("writing {}", energy_path.display()))?;
    }
    let body = &sim.body;
    let regions = sim.regions.clone();
    let write_frame = |it: &Integrator,
                       state: &mut hooke_core::State,
                       fr: Option<&hooke_fracture::Fracture>,
                       output: &mut Output|
     -> Result<()> {
        let v = it.full_velocity(body, state);
        let damage = fr.map(|f| f.damage(body, state));
        let extras = FrameExtras {
            velocity: Some(&v),
            damage: damage.as_deref(),
            region: Some(&regions),
        };
        if let Some(series) = output.vtk.as_mut() {
            series.write(body, state, extras)?;
        }
        #[cfg(feature = "hdf5")]
        if let Some(h5) = output.h5.as_mut() {
            h5.write(body, state, extras)?;
        }
        let b = it.energy(body, state);
        let l = b.ledger;
        let mut f = std::fs::OpenOptions::new()
            .append(true)
            .open(&energy_path)
            .with_context(|| format!("appending to {}", energy_path.display()))?;
        writeln!(
            f,
            "{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e}",
            state.time,
            b.kinetic,
            b.strain.direct,
            b.strain.dispersive,
            l.external_work,
            l.boundary_work,
            l.body_work,
            l.dissipated,
            l.released,
            b.error
        )?;
        Ok(())
    };
    let save = |it: &Integrator,
                state: &hooke_core::State,
                fr: Option<&hooke_fracture::Fracture>|
     -> Result<()> {
        let (broken, released) = fr.map_or((0, 0.0), |f| (f.broken_total as u64, f.released_total));
        Checkpoint {
            digest: case_digest,
            state: state.clone(),
            integrator: it.checkpoint(),
            broken,
            released,
        }
        .save(&ckpt_path)?;
        Ok(())
    };
    if args.resume.is_none() {
        write_frame(&it, &mut sim.state, sim.fracture.as_ref(), &mut output)?;
    }
    let interactive = std::io::stderr().is_terminal();
    let start = Instant::now();
    let (t_start, step_start) = (sim.state.time, sim.state.step);
    let mut next_frame =
        (sim.state.time / sim.output_every).floor() * sim.output_every + sim.output_every;
    let mut next_ckpt = (sim.state.time / sim.checkpoint_every).floor() * sim.checkpoint_every
        + sim.checkpoint_every;
    let mut last_report = Instant::now();
    while sim.state.time < sim.end_time - 0.5 * it.dt {
        it.step(body, &mut sim.state);
        if let Some(fr) = sim.fracture.as_mut() {
            fr.check(body, &mut sim.state, &mut it);
        }
        if sim.state.step % 64 == 0 {
            it.check(body, &sim.state)?;
        }
        let done = sim.state.time >= sim.end_time - 0.5 * it.dt;
        if sim.state.time >= next_frame - 0.5 * it.dt || done {
            it.check(body, &sim.state)?;
            write_frame(&it, &mut sim.state, sim.fracture.as_ref(), &mut output)?;
            next_frame += sim.output_every;
        }
        if sim.state.time >= next_ckpt - 0.5 * it.dt || done {
            save(&it, &sim.state, sim.fracture.as_ref())?;
            next_ckpt += sim.checkpoint_every;
        }
        if stop.load(Ordering::SeqCst) {
            write_frame(&it, &mut sim.state, sim.fracture.as_ref(), &mut output)?;
            save(&it, &sim.state, sim.fracture.as_ref())?;
            return Err(Interrupted(format!("interrupted at step {} (t = {:e} s); the last frame and a checkpoint are written: continue with\n  hooke run {} --resume {}{}", sim.state.step, sim.state.time, args.case.display(), ckpt_path.display(), if args.out.is_some() { format!(" --out {}", out.display()) } else { String::new() })).into());
        }
        if interactive && last_report.elapsed().as_secs_f64() > 1.0 {
            last_report = Instant::now();
            let frac = (sim.state.time - t_start) / (sim.end_time - t_start);
            let wall = start.elapsed().as_secs_f64();
            let rate = (sim.state.step - step_start) as f64 / wall;
            let eta = wall * (1.0 - frac) / frac.max(1e-9);
            let broken = sim.fracture.as_ref().map_or(0, |f| f.broken_total);
            eprint!(
                "\r  t = {:.3e} s ({:5.1} %)  {:.0} steps/s  ETA {:.0} s  broken springs {}   ",
                sim.state.time,
                100.0 * frac,
                rate,
                eta,
                broken
            );
        }
    }
    if interactive {
        eprintln!();
    }
    #[cfg(feature = "hdf5")]
    if let Some(h5) = output.h5.as_mut() {
        h5.finish()?;
    }
    let b = it.energy(body, &mut sim.state);
    let wall = start.elapsed().as_secs_f64();
    println!(
        "{}: {} steps to t = {:e} s in {:.1} s ({:.0} steps/s)",
        args.case.display(),
        sim.state.step - step_start,
        sim.state.time,
        wall,
        (sim.state.step - step_start) as f64 / wall.max(1e-9)
    );
    println!("  springs broken {}, energy: kinetic {:.4e} J, strain {:.4e} J, released {:.4e} J, balance error {:.2e}", sim.fracture.as_ref().map_or(0, |f| f.broken_total), b.kinetic, b.strain.total(), b.ledger.released, b.relative_error);
    if let Some(series) = &output.vtk {
        println!(
            "  output: {} ({} frames)",
            series.pvd_path().display(),
            series.frames().len()
        );
    }
    #[cfg(feature = "hdf5")]
    if let Some(h5) = &output.h5 {
        println!("  output: {}", h5.xdmf_path().display());
    }
    println!(
        "  energy history {}, checkpoint {}",
        energy_path.display(),
        ckpt_path.display()
    );
    Ok(())
}
