//! `hooke run` and `hooke check`: case files end to end.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;
use hooke_case::Simulation;
use hooke_core::dynamics::{Integrator, Interaction};
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
    /// The rigid bodies' surfaces (`STEM_rigid.pvd`), for cases with contact bodies.
    rigid: Option<hooke_io::RigidSeries>,
    /// Half-size of the patch that draws a half-space (the lattice's extent).
    patch: Real,
    #[cfg(feature = "hdf5")]
    h5: Option<hooke_io::H5Series>,
}

impl Output {
    /// One frame into every series: the given velocity, damage from the fracture state, region
    /// ids.
    fn write(
        &mut self,
        body: &hooke_core::Body,
        state: &hooke_core::State,
        velocity: &hooke_core::Coords,
        fr: Option<&hooke_fracture::Fracture>,
        regions: &[u32],
    ) -> Result<()> {
        let damage = fr.map(|f| f.damage(body, state));
        let extras = FrameExtras {
            velocity: Some(velocity),
            damage: damage.as_deref(),
            region: Some(regions),
        };
        if let Some(series) = self.vtk.as_mut() {
            series.write(body, state, extras)?;
        }
        #[cfg(feature = "hdf5")]
        if let Some(h5) = self.h5.as_mut() {
            h5.write(body, state, extras)?;
        }
        Ok(())
    }

    /// The rigid bodies at the current time into their series.
    fn write_rigid(
        &mut self,
        t: Real,
        step: u64,
        contact: Option<&hooke_contact::Contact>,
    ) -> Result<()> {
        let (Some(series), Some(c)) = (self.rigid.as_mut(), contact) else {
            return Ok(());
        };
        let parts: Vec<hooke_io::RigidPart> = c
            .bodies
            .iter()
            .map(|b| {
                let (points, triangles, lines) = b.geometry.surface(b.position, self.patch);
                hooke_io::RigidPart {
                    points,
                    triangles,
                    lines,
                    velocity: b.velocity,
                    reaction: b.reaction,
                }
            })
            .collect();
        series.write(t, step, &parts)?;
        Ok(())
    }
}

/// The series a run writes, new or continued.
fn open_output(
    sim: &Simulation,
    out: &Path,
    name: &str,
    resuming: bool,
    until: Real,
) -> Result<Output> {
    let _ = until;
    let pos = &sim.body.lattice.pos;
    let extent = [&pos.x, &pos.y, &pos.z]
        .iter()
        .map(|v| {
            let lo = v.iter().cloned().fold(Real::INFINITY, Real::min);
            let hi = v.iter().cloned().fold(Real::NEG_INFINITY, Real::max);
            hi - lo
        })
        .fold(0.0, Real::max);
    let with_bodies = sim.contact.as_ref().is_some_and(|c| !c.bodies.is_empty());
    Ok(Output {
        rigid: (with_bodies && sim.vtk && !resuming)
            .then(|| hooke_io::RigidSeries::create(out, name)),
        patch: 0.6 * extent,
        vtk: if !sim.vtk {
            None
        } else if resuming {
            Some(
                VtkSeries::reopen(out, name, sim.springs, until)
                    .map_err(|e| InputError(e.to_string()))?,
            )
        } else {
            Some(VtkSeries::create(out, name, sim.springs).map_err(|e| InputError(e.to_string()))?)
        },
        #[cfg(feature = "hdf5")]
        h5: if !sim.hdf5 {
            None
        } else if resuming {
            Some(
                hooke_io::H5Series::reopen(out, name, &sim.body, until)
                    .map_err(|e| InputError(e.to_string()))?,
            )
        } else {
            Some(
                hooke_io::H5Series::create(out, name, &sim.body)
                    .map_err(|e| InputError(e.to_string()))?,
            )
        },
    })
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
    // One output frame and a checkpoint into a scratch folder, so that the peak measured below
    // includes what writing them costs (both are assembled in memory before they are written).
    let scratch = std::env::temp_dir().join(format!("hooke-check-{}", std::process::id()));
    std::fs::create_dir_all(&scratch).with_context(|| format!("creating {}", scratch.display()))?;
    let written = open_output(&sim, &scratch, "probe", false, 0.0)
        .and_then(|mut o| {
            let zero = hooke_core::Coords::zeros(n);
            o.write(
                &sim.body,
                &probe,
                &zero,
                sim.fracture.as_ref(),
                &sim.regions,
            )
        })
        .and_then(|_| {
            Checkpoint {
                digest: 0,
                state: probe.clone(),
                integrator: it2.checkpoint(),
                broken: 0,
                released: 0.0,
            }
            .save(&scratch.join("probe.ckpt"))?;
            Ok(())
        });
    let _ = std::fs::remove_dir_all(&scratch);
    written?;
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
    if sim.body.lattice.kind.is_random() {
        let unit = if sim.body.lattice.dim() == 3 {
            "Pa"
        } else {
            "N/m"
        };
        println!(
            "  kappa, q     {:e} {unit} (k_s = kappa V_s / L_s^2), {:.6}",
            sim.k, sim.q
        );
    } else {
        println!("  k, q         {:e} N/m, {:.6}", sim.k, sim.q);
    }
    println!(
        "  fracture     {}",
        sim.fracture
            .as_ref()
            .map_or("off".to_string(), |f| format!("{:?}", f.criterion()))
    );
    if let Some(c) = &sim.contact {
        println!(
            "  contact      penalty k = {} m/dt^2 per node, node radius {:e} m, fragments {}",
            c.opts.stiffness_factor,
            c.opts.radius,
            c.opts
                .fragment_distance
                .map_or("off".to_string(), |d| format!("below {d:e} m"))
        );
        for b in &c.bodies {
            let motion = match &b.motion {
                hooke_contact::Motion::Dynamic { mass } => format!("dynamic, {mass:.4e} kg"),
                hooke_contact::Motion::Kinematic(_) => "kinematic".to_string(),
            };
            println!(
                "  rigid        {}: {:?}, {motion}, at {:?} m, velocity {:?} m/s, friction {}",
                b.name, b.geometry, b.position, b.velocity, b.friction
            );
        }
    }
    let kind = sim.body.lattice.kind;
    if let Some(c) = &sim.body.lattice.cells {
        if !hooke_core::random::calibration::calibrated(kind, c.sampler) {
            println!(
                "  note         the {:?} sampler is calibrated only at amplitude {}: E and nu \
                 are met only roughly (measure them with hooke moduli --sampler jitter)",
                c.sampler,
                hooke_core::random::calibration::JITTER_CALIBRATED
            );
        }
    }
    if sim.fracture.is_some() && kind == hooke_core::LatticeKind::Random3d {
        println!(
            "  note         the lattice toughness of random3d lattices is not measured: G_c sets \
             the critical stretch of the cubic lattice with the same E, nu and spacing, so \
             the crack's G is matched only roughly"
        );
    } else if sim.fracture.is_some() && !hooke_fracture::stretch::toughness_calibrated(kind, sim.q)
    {
        println!(
            "  note         nu = {:.3} lies outside the range where the lattice toughness was \
             measured (hooke toughness): cracks leave their plane there and G_c is matched \
             only roughly",
            hooke_core::material::nu_from_q(kind, sim.q)
        );
    }
    if let Some(f) = &sim.fracture {
        let nu = hooke_core::material::nu_from_q(kind, sim.q);
        if f.criterion().name() == "spring-energy"
            && !hooke_fracture::energy::energy_calibrated(kind, nu)
        {
            println!(
                "  note         the energy criterion's G_c calibration holds for hex nu_2D in \
                 [-0.9, 0.5] and cubic nu in [-0.1, 0.4]; at nu = {nu:.3} its crack roughens \
                 and G_c is matched only roughly (the stretch criterion covers more)"
            );
        }
    }
    println!(
        "  dt           {:e} s (critical {:e} s), {} steps to {:e} s",
        it.dt, it.stable.dt_critical, steps, sim.end_time
    );
    println!(
        "  memory       about {:.1} MiB for the state; peak {} while checking (set-up, a few \
         steps, one output frame and a checkpoint; a run's own peak, printed at its end, lies within \
         about a third of it)",
        bytes as f64 / (1 << 20) as f64,
        crate::bench::peak_memory().map_or("unknown".to_string(), |b| format!(
            "{:.0} MiB",
            b as f64 / (1 << 20) as f64
        ))
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
    if sim.contact.is_some() && sim.quasi_static.is_some() {
        return Err(InputError(format!(
            "{}: contact ([[rigid]], [contact]) runs with the explicit solver; remove solver.type = \"quasi-static\"",
            args.case.display()
        ))
        .into());
    }
    if sim.contact.is_some() && args.resume.is_some() {
        return Err(InputError(
            "--resume: checkpoints do not hold rigid bodies yet; a case with contact restarts from its case file"
                .into(),
        )
        .into());
    }
    if let Some(steps) = sim.quasi_static {
        if args.resume.is_some() {
            return Err(InputError(
                "--resume continues explicit runs; a quasi-static run restarts from its case"
                    .into(),
            )
            .into());
        }
        let output = open_output(&sim, &out, &name, false, 0.0)?;
        return quasi_static(&args, sim, steps, output, &out, &name);
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
    let mut output = open_output(&sim, &out, &name, resuming, until)?;
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = stop.clone();
        // A second handler cannot be installed in one process; tests call run() once per process.
        let _ = ctrlc::set_handler(move || stop.store(true, Ordering::SeqCst));
    }
    let (energy_path, contact_path) = start_histories(&sim, &out, &name, args.resume.is_none())?;
    let body = &sim.body;
    let regions = sim.regions.clone();
    let write_frame = |it: &Integrator,
                       state: &mut hooke_core::State,
                       fr: Option<&hooke_fracture::Fracture>,
                       output: &mut Output|
     -> Result<()> {
        let v = it.full_velocity(body, state);
        output.write(body, state, &v, fr, &regions)?;
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
        output.write_rigid(sim.state.time, sim.state.step, sim.contact.as_ref())?;
    }
    let interactive = std::io::stderr().is_terminal();
    let bar = progress_bar(interactive, BAR_LEN);
    let start = Instant::now();
    let (t_start, step_start) = (sim.state.time, sim.state.step);
    let mut next_frame =
        (sim.state.time / sim.output_every).floor() * sim.output_every + sim.output_every;
    let mut next_ckpt = (sim.state.time / sim.checkpoint_every).floor() * sim.checkpoint_every
        + sim.checkpoint_every;
    let mut last_report = Instant::now();
    while sim.state.time < sim.end_time - 0.5 * it.dt {
        match sim.contact.as_mut() {
            Some(c) => it.step_with(body, &mut sim.state, Some(c as &mut dyn Interaction)),
            None => it.step(body, &mut sim.state),
        }
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
            output.write_rigid(sim.state.time, sim.state.step, sim.contact.as_ref())?;
            if let Some(c) = sim.contact.as_mut() {
                flush_contact(c, &contact_path)?;
            }
            next_frame += sim.output_every;
        }
        if sim.state.time >= next_ckpt - 0.5 * it.dt || done {
            save(&it, &sim.state, sim.fracture.as_ref())?;
            next_ckpt += sim.checkpoint_every;
        }
        if stop.load(Ordering::SeqCst) {
            bar.abandon();
            write_frame(&it, &mut sim.state, sim.fracture.as_ref(), &mut output)?;
            output.write_rigid(sim.state.time, sim.state.step, sim.contact.as_ref())?;
            save(&it, &sim.state, sim.fracture.as_ref())?;
            return Err(Interrupted(format!("interrupted at step {} (t = {:e} s); the last frame and a checkpoint are written: continue with\n  hooke run {} --resume {}{}", sim.state.step, sim.state.time, args.case.display(), ckpt_path.display(), if args.out.is_some() { format!(" --out {}", out.display()) } else { String::new() })).into());
        }
        if interactive && last_report.elapsed().as_secs_f64() > 0.5 {
            last_report = Instant::now();
            let frac = (sim.state.time - t_start) / (sim.end_time - t_start);
            let wall = start.elapsed().as_secs_f64();
            let rate = (sim.state.step - step_start) as f64 / wall;
            let broken = sim.fracture.as_ref().map_or(0, |f| f.broken_total);
            // Twice a second at most: one extra force evaluation, on terminals only.
            let b = it.energy(body, &mut sim.state);
            bar.set_position((frac * BAR_LEN as f64) as u64);
            bar.set_message(format!(
                "t = {:.3e} s  {:.0} steps/s  broken springs {}  energy {:.3e} J (balance {:.1e})",
                sim.state.time,
                rate,
                broken,
                b.kinetic + b.strain.total(),
                b.relative_error
            ));
        }
    }
    bar.finish_and_clear();
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
    if let Some(c) = sim.contact.as_mut() {
        flush_contact(c, &contact_path)?;
    }
    if let Some(c) = &sim.contact {
        for b in &c.bodies {
            println!(
                "  rigid {}: at {:?} m, velocity {:?} m/s",
                b.name, b.position, b.velocity
            );
        }
        println!(
            "  contact: {} list builds, deepest penetration {:.3e} m ({:.3} of the contact radius)",
            c.rebuilds,
            c.max_penetration,
            c.max_penetration / c.opts.radius
        );
        if !c.bodies.is_empty() {
            println!("  reactions over time: {}", contact_path.display());
        }
        if let Some(r) = &output.rigid {
            println!("  rigid bodies: {}", r.pvd_path().display());
        }
    }
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
    if let Some(b) = crate::bench::peak_memory() {
        println!("  peak memory {:.0} MiB", b as f64 / (1 << 20) as f64);
    }
    Ok(())
}

/// A quasi-static run: load steps, each brought to equilibrium (Newton-CG), springs beyond the
/// criterion broken in rounds with a new equilibrium after each round.
fn quasi_static(
    args: &RunArgs,
    mut sim: Simulation,
    steps: usize,
    mut output: Output,
    out: &Path,
    name: &str,
) -> Result<()> {
    use hooke_core::loading::Motion;
    use hooke_core::statics::{self, Constraints, StaticOptions};
    use hooke_core::{law, Coords};
    let body = &sim.body;
    let (n, dim) = (body.nodes(), body.lattice.dim());
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
    // Prescribed displacement at time t; a prescribed velocity is integrated (trapezoid).
    let disp_at = |m: &Motion, u0: Real, t: Real| match m {
        Motion::Fixed => u0,
        Motion::Displacement(f) => f.value(t),
        Motion::Velocity(f) => {
            let k = 256;
            let h = t / k as Real;
            u0 + (0..k)
                .map(|j| 0.5 * h * (f.value(j as Real * h) + f.value((j + 1) as Real * h)))
                .sum::<Real>()
        }
    };
    // A translation along an axis that no boundary condition touches is a free rigid motion:
    // project it out rather than leave the stiffness singular.
    for c in 0..dim {
        if !dofs.iter().any(|&(_, axis, _)| axis == c) {
            let mut mode = Coords::zeros(n);
            mode.comp_mut(c).fill(1.0);
            cons.add_null_mode(mode);
        }
    }
    let u0: Vec<Real> = dofs
        .iter()
        .map(|&(i, c, _)| sim.state.u.comp(c)[i])
        .collect();
    // Quasi-static runs have no contact (refused before), so no contact history.
    let (energy_path, _) = start_histories(&sim, out, name, true)?;
    let zero = Coords::zeros(n);
    let regions = sim.regions.clone();
    let (mut w_ext, mut w_bc, mut dissipated) = (0.0, 0.0, 0.0);
    let write = |state: &mut hooke_core::State,
                 fr: Option<&hooke_fracture::Fracture>,
                 output: &mut Output,
                 w_ext: Real,
                 w_bc: Real,
                 dissipated: Real|
     -> Result<()> {
        output.write(body, state, &zero, fr, &regions)?;
        let e = law::energy(body, &state.u, &state.alive, &state.norm);
        let released = fr.map_or(0.0, |f| f.released_total);
        let mut f = std::fs::OpenOptions::new()
            .append(true)
            .open(&energy_path)?;
        writeln!(
            f,
            "{:e},0e0,{:e},{:e},{:e},{:e},0e0,{:e},{:e},{:e}",
            state.time,
            e.direct,
            e.dispersive,
            w_ext,
            w_bc,
            dissipated,
            released,
            e.total() + released + dissipated - w_ext - w_bc
        )?;
        Ok(())
    };
    write(
        &mut sim.state,
        sim.fracture.as_ref(),
        &mut output,
        0.0,
        0.0,
        0.0,
    )?;
    let every = ((sim.output_every / (sim.end_time / steps as Real)).round() as usize).max(1);
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = stop.clone();
        let _ = ctrlc::set_handler(move || stop.store(true, Ordering::SeqCst));
    }
    let mut fext = Coords::zeros(n);
    let mut fext_prev = Coords::zeros(n);
    let mut reactions_prev = vec![0.0; dofs.len()];
    let mut peak: Real = 0.0;
    let start = Instant::now();
    let interactive = std::io::stderr().is_terminal();
    let bar = progress_bar(interactive, steps as u64);
    for k in 1..=steps {
        let t = sim.end_time * k as Real / steps as Real;
        let u_prev = sim.state.u.clone();
        for (m, &(i, c, ref mo)) in dofs.iter().enumerate() {
            sim.state.u.comp_mut(c)[i] = disp_at(mo, u0[m], t);
        }
        fext.fill_zero();
        let g = sim.loading.body_acceleration;
        for i in 0..n {
            fext.set(i, body.mass[i] * g);
        }
        for l in &sim.loading.loads {
            for &i in &l.nodes {
                let i = i as usize;
                fext.set(i, fext.get(i) + l.force * l.scale.value(t));
            }
        }
        // Newton-CG first; where it cannot (a mechanism or a loose fragment after breaking,
        // a buckling tangent), adaptive dynamic relaxation, which tolerates both.
        let solve = |state: &mut hooke_core::State,
                     peak: Real,
                     fr: Option<&mut hooke_fracture::Fracture>|
         -> Result<()> {
            let opts = StaticOptions {
                reference_force: Some((1e-6 * peak).max(1e-300)),
                ..Default::default()
            };
            let before = state.u.clone();
            match statics::solve(body, state, &cons, Some(&fext), &opts) {
                Ok(_) => Ok(()),
                Err(newton) => {
                    state.u = before;
                    // Springs break while the body relaxes: an unstable crack runs through.
                    let mut fr = fr;
                    let mut hook = |s: &mut hooke_core::State| match fr.as_deref_mut() {
                        Some(f) => {
                            f.decide(body, s);
                            f.commit(body, s, None).broken > 0
                        }
                        None => false,
                    };
                    let ropts = hooke_core::relax::RelaxOptions {
                        tolerance: 1e-4,
                        max_iterations: 100_000,
                        reference_force: Some((1e-3 * peak).max(1e-300)),
                    };
                    hooke_core::relax::relax_with(body, state, &cons, Some(&fext), &ropts, &mut hook)
                        .map(|_| ())
                        .with_context(|| format!("load step {k} of {steps} (t = {t:e} s): Newton-CG failed ({newton}) and dynamic relaxation did not converge either"))
                }
            }
        };
        // The load increment first, elastically (no spring breaks): its work is the trapezoid
        // of the loads and of the supports' reactions between the two equilibria, exact for a
        // linear response.
        solve(&mut sim.state, peak, None)?;
        for c in 0..3 {
            for i in 0..n {
                w_ext += 0.5
                    * (fext_prev.comp(c)[i] + fext.comp(c)[i])
                    * (sim.state.u.comp(c)[i] - u_prev.comp(c)[i]);
            }
        }
        for (m, &(i, c, _)) in dofs.iter().enumerate() {
            let r = -sim.state.f.comp(c)[i] - fext.comp(c)[i];
            w_bc += 0.5 * (reactions_prev[m] + r) * (sim.state.u.comp(c)[i] - u_prev.comp(c)[i]);
        }
        // Then breaking rounds at fixed supports and loads. A break releases the energy its
        // springs held (booked by the fracture crate); the re-equilibration that follows lowers
        // the potential `U - f_ext . u` further, and that drop is what a running crack radiates
        // and a real solid turns into heat: booked here as dissipated. With both terms the
        // balance closes through unstable crack growth too.
        let potential = |state: &hooke_core::State| {
            let e = law::energy(body, &state.u, &state.alive, &state.norm).total();
            let mut w = 0.0;
            for c in 0..3 {
                for i in 0..n {
                    w += fext.comp(c)[i] * state.u.comp(c)[i];
                }
            }
            e - w
        };
        for _ in 0..10_000 {
            let Some(fr) = sim.fracture.as_mut() else {
                break;
            };
            fr.decide(body, &sim.state);
            if fr.commit(body, &mut sim.state, None).broken == 0 {
                break;
            }
            let before = potential(&sim.state);
            let released_before = fr.released_total;
            solve(&mut sim.state, peak, sim.fracture.as_mut())?;
            // Springs that break inside the solve (dynamic relaxation with breaking) booked
            // their own release.
            let released_during = sim
                .fracture
                .as_ref()
                .map_or(0.0, |f| f.released_total - released_before);
            dissipated += before - potential(&sim.state) - released_during;
        }
        for (m, &(i, c, _)) in dofs.iter().enumerate() {
            let r = -sim.state.f.comp(c)[i] - fext.comp(c)[i];
            reactions_prev[m] = r;
            peak = peak.max(r.abs());
        }
        std::mem::swap(&mut fext_prev, &mut fext);
        sim.state.time = t;
        sim.state.step = k as u64;
        // An interrupted run writes its last step as a frame too (once, even on a frame step).
        let stopping = stop.load(Ordering::SeqCst);
        if k % every == 0 || k == steps || stopping {
            write(
                &mut sim.state,
                sim.fracture.as_ref(),
                &mut output,
                w_ext,
                w_bc,
                dissipated,
            )?;
        }
        if stopping {
            bar.abandon();
            return Err(Interrupted(format!("interrupted after load step {k} of {steps}; the last frame is written (quasi-static runs restart from the case)")).into());
        }
        bar.set_position(k as u64);
        bar.set_message(format!(
            "load step {k}/{steps}  broken springs {}",
            sim.fracture.as_ref().map_or(0, |f| f.broken_total)
        ));
    }
    bar.finish_and_clear();
    #[cfg(feature = "hdf5")]
    if let Some(h5) = output.h5.as_mut() {
        h5.finish()?;
    }
    let e = law::energy(body, &sim.state.u, &sim.state.alive, &sim.state.norm);
    let released = sim.fracture.as_ref().map_or(0.0, |f| f.released_total);
    println!(
        "{}: {steps} quasi-static load steps in {:.1} s",
        args.case.display(),
        start.elapsed().as_secs_f64()
    );
    println!(
        "  springs broken {}, strain energy {:.4e} J, work in {:.4e} J, released {:.4e} J, dissipated in re-equilibration {:.4e} J, balance error {:.2e}",
        sim.fracture.as_ref().map_or(0, |f| f.broken_total),
        e.total(),
        w_ext + w_bc,
        released,
        dissipated,
        (e.total() + released + dissipated - w_ext - w_bc).abs() / (w_ext + w_bc).abs().max(e.total()).max(1e-300)
    );
    if let Some(series) = &output.vtk {
        println!(
            "  output: {} ({} frames)",
            series.pvd_path().display(),
            series.frames().len()
        );
    }
    println!("  energy history {}", energy_path.display());
    Ok(())
}

/// The run's history files, `NAME_energy.csv` and `NAME_contact.csv`; a fresh run (not a
/// resumed one) starts them with their headers (the contact history only with rigid bodies).
fn start_histories(
    sim: &Simulation,
    out: &Path,
    name: &str,
    fresh: bool,
) -> Result<(PathBuf, PathBuf)> {
    let energy_path = out.join(format!("{name}_energy.csv"));
    let contact_path = out.join(format!("{name}_contact.csv"));
    if !fresh {
        return Ok((energy_path, contact_path));
    }
    if sim.contact.as_ref().is_some_and(|c| !c.bodies.is_empty()) {
        std::fs::write(
            &contact_path,
            "time,body,name,reaction_x,reaction_y,reaction_z,x,y,z,vx,vy,vz\n",
        )
        .with_context(|| format!("writing {}", contact_path.display()))?;
    }
    std::fs::write(&energy_path, "time,kinetic,strain_direct,strain_dispersive,external_work,boundary_work,body_work,dissipated,released,balance_error\n").with_context(|| format!("writing {}", energy_path.display()))?;
    Ok((energy_path, contact_path))
}

/// Append the contact history recorded since the last call to the CSV (one line per body and
/// step) and forget it.
fn flush_contact(c: &mut hooke_contact::Contact, path: &Path) -> Result<()> {
    if c.bodies.is_empty() || c.history.is_empty() {
        c.history.clear();
        return Ok(());
    }
    let mut text = String::new();
    for r in &c.history {
        let name = &c.bodies[r.body].name;
        text.push_str(&format!(
            "{:e},{},{},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e}\n",
            r.time,
            r.body,
            name,
            r.reaction[0],
            r.reaction[1],
            r.reaction[2],
            r.position[0],
            r.position[1],
            r.position[2],
            r.velocity[0],
            r.velocity[1],
            r.velocity[2]
        ));
    }
    c.history.clear();
    let mut f = std::fs::OpenOptions::new()
        .append(true)
        .open(path)
        .with_context(|| format!("appending to {}", path.display()))?;
    f.write_all(text.as_bytes())?;
    Ok(())
}

/// Resolution of the explicit run's progress bar (it shows simulated time, not steps).
const BAR_LEN: u64 = 1000;

/// A progress bar on stderr when it is a terminal (ETA from the progress rate, the message
/// carrying step rate, broken springs and energy); hidden otherwise, so logs stay clean.
fn progress_bar(interactive: bool, len: u64) -> indicatif::ProgressBar {
    if !interactive {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(len);
    let style =
        indicatif::ProgressStyle::with_template("  [{bar:32}] {percent:>3} %  ETA {eta:>4}  {msg}")
            .map(|s| s.progress_chars("=> "))
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar());
    bar.set_style(style);
    bar
}
