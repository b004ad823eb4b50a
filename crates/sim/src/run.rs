//! Running a simulation: the output folder, the explicit driver with its schedule (frames,
//! checkpoints, reactions, progress, interruption), and the dispatch to the quasi-static driver.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use hooke_core::dynamics::{EnergyBalance, Integrator, Interaction};
use hooke_core::team::Team;
use hooke_core::{Coords, Real};
use hooke_io::{Checkpoint, VtkSeries};

use crate::error::{Error, Result};
use crate::observer::{Observer, Progress};
use crate::output::{
    ContactHistory, EnergyHistory, EnergyRow, Frame, ReactionHistory, RegionReaction, RigidSink,
    Sink, VtkSink,
};
use crate::provenance::Provenance;
use crate::{Boundary, Simulation};

/// Where and how a run writes.
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// The output folder (created if needed). An earlier run there is never overwritten.
    pub out: PathBuf,
    /// File stem of everything written (`NAME.pvd`, `NAME_energy.csv`, ...).
    pub name: String,
    /// Continue from this checkpoint of the same case (explicit runs).
    pub resume: Option<PathBuf>,
    /// A digest of the case's physics: a checkpoint of another case is refused.
    pub digest: u64,
    /// Written to `run.json`: the command line and the case text (may be empty).
    pub command: Vec<String>,
    pub case_text: String,
    /// The case's physics as `key = value` lines (what the digest covers), kept in `run.json`
    /// so that a resume with other physics can name the key that differs.
    pub physics: String,
    /// Processes that share the run (MPI ranks, [`hooke_core::team`]): each builds the same
    /// simulation and runs it with this option; the sweeps are split, rank 0 alone writes, and
    /// the results are the bits of one process. `None`: this process alone.
    pub team: Option<std::sync::Arc<dyn Team>>,
    /// With a team: after set-up each process keeps only its piece of the body and state
    /// (its own nodes and ghosts, [`hooke_core::team::Piece`]) and drops the rest, so that a
    /// body too large for one machine's memory runs on several (`hooke run --pieces`). The
    /// results are the same bits; each process writes its own checkpoint
    /// ([`RunOptions::piece_checkpoint_path`]). Random lattices (bodies swept by rows); HDF5
    /// output is refused with the reason until it runs on pieces.
    pub pieces: bool,
}

impl RunOptions {
    pub fn new(out: impl Into<PathBuf>, name: impl Into<String>) -> Self {
        RunOptions {
            out: out.into(),
            name: name.into(),
            ..Default::default()
        }
    }

    /// The checkpoint the run writes.
    pub fn checkpoint_path(&self) -> PathBuf {
        self.out.join(format!("{}.ckpt", self.name))
    }

    /// The checkpoint process `rank` of `size` writes in a run on pieces
    /// ([`RunOptions::pieces`]) for the checkpoint `path` of a run: `NAME.ckpt` becomes
    /// `NAME.RANKofSIZE.ckpt`, e.g. `run.1of4.ckpt`; a resume names `NAME.ckpt` and each
    /// process reads its own.
    pub fn piece_checkpoint_path(path: &Path, rank: usize, size: usize) -> PathBuf {
        let mut name = path
            .file_stem()
            .map_or_else(Default::default, |s| s.to_os_string());
        name.push(format!(".{rank}of{size}.ckpt"));
        path.with_file_name(name)
    }

    /// This process's rank and the team's size when processes hold pieces: a team of several
    /// with [`RunOptions::pieces`].
    fn on_pieces(&self) -> Option<(usize, usize)> {
        let t = self.team.as_ref().filter(|t| self.pieces && t.size() > 1)?;
        Some((t.rank(), t.size()))
    }

    /// Whether this process writes the outputs: rank 0 of a team, or a process alone.
    pub fn writes(&self) -> bool {
        self.team.as_ref().is_none_or(|t| t.rank() == 0)
    }

    /// Whether any member of the team (this process alone: this one) says `flag`. Every member
    /// must call it at the same point.
    fn anyone(&self, flag: bool) -> bool {
        let mut f = [flag];
        if let Some(t) = &self.team {
            t.any(&mut f);
        }
        f[0]
    }
}

/// What a process that did not fail reports when another member of its team did (that one
/// prints the reason); `input`: the failure was the user's input (a folder that holds a run, a
/// format this build lacks), so that every rank exits with the same code.
fn elsewhere(input: bool) -> Error {
    let msg = "another process of this run failed (rank 0 names the reason)".to_string();
    if input {
        Error::Input(msg)
    } else {
        Error::Failed(msg)
    }
}

/// How a run ended, for printing.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Summary {
    /// Steps taken by this process (load steps for quasi-static runs) and the time reached.
    pub steps: u64,
    pub time: Real,
    pub wall_seconds: f64,
    pub quasi_static: bool,
    pub broken_springs: usize,
    /// The last row of the energy history.
    pub energy: EnergyRow,
    /// Explicit runs: relative balance error; quasi-static: |error| / work.
    pub balance: Real,
    /// Rigid bodies at the end: name, position, velocity.
    pub rigid: Vec<(String, [Real; 3], [Real; 3])>,
    /// Contact: candidate-list builds and the deepest penetration over the node radius.
    pub contact: Option<(usize, Real, Real)>,
    /// What was written: description and path.
    pub outputs: Vec<(String, PathBuf)>,
    pub reactions: Vec<RegionReaction>,
    /// A body of several materials held whole: the strain energy (J) each material holds at
    /// the end, by name ([`Simulation::strain_by_material`]).
    pub strain_by_material: Vec<(String, Real)>,
}

/// Free bytes on the file system that holds `dir` (or its nearest existing ancestor).
pub fn free_space(dir: &Path) -> Option<u64> {
    hooke_sys::free_space(dir)
}

/// A run on pieces drops the whole body and state here, every process alike (cutting its
/// piece, and reading its own checkpoint when resuming); one set up from parts never held them,
/// and resumes here. A failure on any process stops every one.
fn onto_pieces(
    sim: &mut Simulation,
    it: &mut Integrator,
    opts: &RunOptions,
    on_parts: bool,
    piece_resume: Option<&Path>,
) -> Result<()> {
    if on_parts {
        if let (Some(c), Some(piece)) = (sim.contact.as_mut(), it.piece()) {
            c.cut(piece)
                .map_err(|e| Error::Input(format!("--parts: {e}")))?;
        }
        let resumed = match piece_resume {
            Some(path) => resume_piece(
                it,
                &sim.body,
                &mut sim.state,
                (sim.contact.as_mut(), sim.fracture.as_mut()),
                opts,
                path,
            ),
            None => Ok(()),
        };
        if opts.anyone(resumed.is_err()) {
            resumed?;
            return Err(elsewhere(true));
        }
    } else if opts.on_pieces().is_some() {
        let cut = cut_to_piece(sim, it, opts, piece_resume);
        if opts.anyone(cut.is_err()) {
            cut?;
            return Err(elsewhere(true));
        }
        hooke_sys::alloc::release_free_memory();
    }
    Ok(())
}

/// A run resumed from a whole checkpoint: the state, the rigid bodies and the fracture totals
/// restored in place (readers that view the state's buffers keep seeing it), and the
/// integrator with the checkpoint's step. A changed physics is refused with the key.
fn resume_from_whole(sim: &mut Simulation, opts: &RunOptions, path: &Path) -> Result<Integrator> {
    let ck = Checkpoint::load(path, &sim.body, opts.digest).map_err(|e| {
        let mut msg = e.to_string();
        if let hooke_io::IoError::DigestMismatch { .. } = e {
            if let Some(key) = changed_physics(&opts.out, &opts.physics) {
                msg = format!("{msg}; the physics changed at {key} (a resumed run may change solver.end_time and [output] only)");
            }
        }
        Error::Input(msg)
    })?;
    // In place: readers that view the state's buffers (numpy) keep seeing it.
    sim.state.clone_from(&ck.state);
    match sim.contact.as_mut() {
        Some(c) => c
            .restore(&ck.extra)
            .map_err(|e| Error::Input(format!("{}: {e}", path.display())))?,
        None if !ck.extra.is_empty() => {
            return Err(Error::Input(format!(
                "{}: the checkpoint holds rigid bodies, this case has none",
                path.display()
            )))
        }
        None => {}
    }
    if let Some(fr) = sim.fracture.as_mut() {
        fr.broken_total = ck.broken as usize;
        fr.released_total = ck.released;
    }
    Ok(Integrator::resume(
        &sim.body,
        &sim.state,
        sim.loading.clone(),
        &sim.options,
        &ck.integrator,
    )?)
}

/// The sinks, the contact history and the provenance of a run.
type Outputs = (
    Vec<Box<dyn Sink>>,
    Option<ContactHistory>,
    Option<Provenance>,
);

/// The run's outputs: the sinks (frames in pieces when shared), the contact history and the
/// provenance, opened by the writer; the other processes open only their frames' pieces.
fn open_outputs(
    sim: &Simulation,
    opts: &RunOptions,
    it: &Integrator,
    until: Real,
    pieces: Option<(usize, Vec<std::ops::Range<usize>>)>,
) -> Result<Outputs> {
    let resuming = opts.resume.is_some();
    if opts.writes() {
        (|| -> Result<_> {
            let sinks =
                open_sinks_in_pieces(sim, &opts.out, &opts.name, resuming, until, pieces.clone())?;
            let contact_history = if sim.has_rigid_bodies() {
                Some(ContactHistory::open(
                    &opts.out,
                    &opts.name,
                    resuming.then_some(until),
                )?)
            } else {
                None
            };
            let provenance = Provenance::start(sim, opts, Some(it))?;
            Ok((sinks, contact_history, Some(provenance)))
        })()
    } else {
        open_sinks_in_pieces(sim, &opts.out, &opts.name, resuming, until, pieces.clone())
            .map(|s| (s, None, None))
    }
}

/// Checks before anything is written: no earlier run in the folder (unless resuming), room on
/// the disk, a build that has the formats asked for, no contact in quasi-static runs.
fn preflight(sim: &Simulation, opts: &RunOptions) -> Result<()> {
    let out = &opts.out;
    let name = &opts.name;
    let ckpt = opts.checkpoint_path();
    if opts.resume.is_none()
        && [
            out.join(format!("{name}.pvd")),
            out.join(format!("{name}.xdmf")),
            ckpt.clone(),
        ]
        .iter()
        .any(|p| p.exists())
    {
        return Err(Error::Input(format!(
            "{} already holds a run; choose another --out, remove it, or continue it with --resume {}",
            out.display(),
            ckpt.display()
        )));
    }
    let need = sim.output_estimate();
    if let Some(free) = free_space(out) {
        if need > free as f64 {
            return Err(Error::Input(format!(
                "the run would write about {:.1} MB but only {:.1} MB are free under {}; write fewer frames (output.every), use --out on a larger disk, or a coarser --scale",
                need / 1e6,
                free as f64 / 1e6,
                out.display()
            )));
        }
    }
    if sim.hdf5 && !cfg!(feature = "hdf5") {
        return Err(Error::Input("output.format asks for \"hdf5\", but this hooke was built without HDF5; install the library (tools/install-hdf5.sh) and build with --features hdf5".into()));
    }
    if sim.contact.is_some() && sim.solver.is_quasi_static() {
        return Err(Error::Input(
            "contact ([[rigid]], [contact]) runs with the explicit solver; remove solver.type = \"quasi-static\""
                .into(),
        ));
    }
    if opts.resume.is_some() && sim.solver.is_quasi_static() {
        return Err(Error::Input(
            "--resume continues explicit runs; a quasi-static run restarts from its case".into(),
        ));
    }
    Ok(())
}

/// The first key whose value differs between the physics recorded in `out/run.json` and
/// `physics`.
fn changed_physics(out: &Path, physics: &str) -> Option<String> {
    let text = std::fs::read_to_string(out.join("run.json")).ok()?;
    let doc: serde_json::Value = serde_json::from_str(&text).ok()?;
    let then = doc["physics"].as_str()?;
    crate::provenance::physics_difference(then, physics)
}

/// The field and history sinks of a run, new or continued.
pub(crate) fn open_sinks(
    sim: &Simulation,
    out: &Path,
    name: &str,
    resuming: bool,
    until: Real,
) -> Result<Vec<Box<dyn Sink>>> {
    open_sinks_in_pieces(sim, out, name, resuming, until, None)
}

/// The sinks of process `pieces.0` of a run whose VTK frames are written in pieces, one per
/// process (`pieces.1`: every process's nodes); a process other than 0 writes only its pieces.
pub(crate) fn open_sinks_in_pieces(
    sim: &Simulation,
    out: &Path,
    name: &str,
    resuming: bool,
    until: Real,
    pieces: Option<(usize, Vec<std::ops::Range<usize>>)>,
) -> Result<Vec<Box<dyn Sink>>> {
    let mut sinks: Vec<Box<dyn Sink>> = Vec::new();
    let input = |e: hooke_io::IoError| Error::Input(e.to_string());
    let rank = pieces.as_ref().map_or(0, |p| p.0);
    if sim.vtk {
        let series = if resuming && rank == 0 {
            VtkSeries::reopen(out, name, sim.springs, until).map_err(input)?
        } else {
            VtkSeries::create(out, name, sim.springs).map_err(input)?
        };
        let mut series = series;
        series.set_fields(sim.fields);
        match pieces {
            Some((rank, nodes)) => series.set_pieces(rank, nodes),
            // Frames are encoded and written while the run goes on.
            None => series.set_background(true),
        }
        sinks.push(Box::new(VtkSink(series)));
    }
    if rank != 0 {
        return Ok(sinks);
    }
    #[cfg(feature = "hdf5")]
    if sim.hdf5 {
        let series = if resuming {
            hooke_io::H5Series::reopen(out, name, &sim.body, until).map_err(input)?
        } else {
            hooke_io::H5Series::create(out, name, &sim.body).map_err(input)?
        };
        let mut series = series;
        series.set_fields(sim.fields);
        sinks.push(Box::new(crate::output::H5Sink(series)));
    }
    std::fs::create_dir_all(out).map_err(Error::file(format!("creating {}", out.display())))?;
    // A resumed run continues the histories from its checkpoint: rows after it (written before
    // a crash, or by a run resumed from an earlier checkpoint) are dropped.
    let keep = resuming.then_some(until);
    sinks.push(Box::new(EnergyHistory::open(out, name, keep)?));
    if !sim.boundaries.is_empty() {
        sinks.push(Box::new(ReactionHistory::open(out, name, keep)?));
    }
    if sim.has_rigid_bodies() && sim.vtk {
        sinks.push(Box::new(RigidSink {
            series: if resuming {
                hooke_io::RigidSeries::reopen(out, name, until)
            } else {
                hooke_io::RigidSeries::create(out, name)
            },
            patch: 0.6 * sim.extent(),
        }));
    }
    Ok(sinks)
}

/// Sum per boundary region of the nodes' boundary forces, and the regions' mean displacement.
pub(crate) fn region_reactions(sim: &Simulation, forces: &Coords) -> Vec<RegionReaction> {
    let u = &sim.state.u;
    sim.boundaries
        .iter()
        .map(|b| {
            region_sum(
                b,
                b.nodes.iter().map(|&i| {
                    let i = i as usize;
                    (forces.get(i).into(), u.get(i).into())
                }),
            )
        })
        .collect()
}

/// Boundary `b`'s reaction from its nodes' (force, displacement), in its nodes' order.
fn region_sum(b: &Boundary, nodes: impl Iterator<Item = ([Real; 3], [Real; 3])>) -> RegionReaction {
    let mut force = [0.0; 3];
    let mut displacement = [0.0; 3];
    for (f, u) in nodes {
        for c in 0..3 {
            force[c] += f[c];
            displacement[c] += u[c];
        }
    }
    let n = b.nodes.len().max(1) as Real;
    RegionReaction {
        name: b.name.clone(),
        force,
        displacement: displacement.map(|d| d / n),
    }
}

/// What a run on pieces refuses, and why.
fn pieces_refuse(what: &str) -> Error {
    Error::Input(format!(
        "--pieces: {what} reads the whole state, which a process holding its piece does not have; run without --pieces (each process then holds the whole body)"
    ))
}

/// Cut this process's piece out of the simulation ([`RunOptions::pieces`]): the integrator
/// steps the piece from now on, the body, state, node regions and fracture are the piece's,
/// and the whole ones are dropped. `resume`: this process's checkpoint of a run on pieces.
fn cut_to_piece(
    sim: &mut Simulation,
    it: &mut Integrator,
    opts: &RunOptions,
    resume: Option<&Path>,
) -> Result<()> {
    if sim.hdf5 {
        return Err(pieces_refuse(
            "HDF5 output (output.format = \"hdf5\"), whose frames are written whole,",
        ));
    }
    let (body, mut state) = it.cut(&sim.body, &sim.state).map_err(|e| {
        let why = match e {
            hooke_core::Error::InvalidInput { why, .. } => why,
            e => e.to_string(),
        };
        Error::Input(format!(
            "--pieces: {why}; run without --pieces (each process then holds the whole body)"
        ))
    })?;
    if let Some(path) = resume {
        let records = (sim.contact.as_mut(), sim.fracture.as_mut());
        resume_piece(it, &body, &mut state, records, opts, path)?;
    }
    let piece = it.piece().expect("cut");
    if let Some(fr) = sim.fracture.as_mut() {
        fr.cut(piece, &body);
    }
    if let Some(c) = sim.contact.as_mut() {
        c.cut(piece)
            .map_err(|e| Error::Input(format!("--pieces: {e}")))?;
    }
    let pad = hooke_core::team::PAD;
    sim.regions = piece
        .global
        .iter()
        .map(|&g| if g == pad { 0 } else { sim.regions[g as usize] })
        .collect();
    sim.held = Some(crate::Held {
        own: piece.own.clone(),
        first: piece.first,
        nodes: sim.body.nodes(),
        springs: sim.body.springs(),
        extent: sim.extent(),
    });
    sim.body = body;
    sim.state = state;
    Ok(())
}

/// Resume this process's piece (`body`, `state`) from its own checkpoint `path` of a run on
/// pieces: the state, the integrator's, contact's and fracture's records.
fn resume_piece(
    it: &mut Integrator,
    body: &hooke_core::Body,
    state: &mut hooke_core::State,
    (contact, fracture): (
        Option<&mut hooke_contact::Contact>,
        Option<&mut hooke_fracture::Fracture>,
    ),
    opts: &RunOptions,
    path: &Path,
) -> Result<()> {
    let ck = Checkpoint::load(path, body, opts.digest).map_err(|e| {
        Error::Input(format!(
            "{e} (a run on pieces resumes on as many processes as wrote it, each from its own checkpoint)"
        ))
    })?;
    *state = ck.state;
    it.restore(body, state, &ck.integrator);
    if let Some(c) = contact {
        c.restore(&ck.extra)
            .map_err(|e| Error::Input(format!("{}: {e}", path.display())))?;
    }
    if let Some(fr) = fracture {
        fr.broken_total = ck.broken as usize;
        fr.released_total = ck.released;
    }
    Ok(())
}

/// [`region_reactions`] on a piece: each boundary's nodes' forces and displacements from their
/// owners (an all-gather per boundary), summed in the boundary's order as one process sums
/// them. `forces` must hold the boundary forces at the process's own nodes.
fn region_reactions_piece(
    sim: &Simulation,
    it: &Integrator,
    forces: &Coords,
) -> Vec<RegionReaction> {
    let (Some(held), Some(team), Some(share)) = (&sim.held, it.team(), it.share()) else {
        return region_reactions(sim, forces);
    };
    let u = &sim.state.u;
    let mine = held.first..held.first + held.own.len();
    sim.boundaries
        .iter()
        .map(|b| {
            // Laid out in node order, so that each owner's nodes are one run.
            let mut order: Vec<usize> = (0..b.nodes.len()).collect();
            order.sort_by_key(|&k| b.nodes[k]);
            let sorted: Vec<usize> = order.iter().map(|&k| b.nodes[k] as usize).collect();
            let at = |end: usize| 6 * sorted.partition_point(|&g| g < end);
            let parts: Vec<_> = share.nodes.iter().map(|r| at(r.start)..at(r.end)).collect();
            let mut values = vec![0.0; 6 * sorted.len()];
            for (k, &g) in sorted.iter().enumerate().filter(|(_, g)| mine.contains(g)) {
                let i = held.own.start + (g - held.first);
                for c in 0..3 {
                    values[6 * k + c] = forces.comp(c)[i];
                    values[6 * k + 3 + c] = u.comp(c)[i];
                }
            }
            team.gather(&mut values, &parts);
            let mut slot = vec![0; b.nodes.len()];
            for (k, &o) in order.iter().enumerate() {
                slot[o] = k;
            }
            region_sum(
                b,
                slot.iter().map(|&k| {
                    let v = &values[6 * k..6 * k + 6];
                    ([v[0], v[1], v[2]], [v[3], v[4], v[5]])
                }),
            )
        })
        .collect()
}

/// A run of an explicit simulation, stepped by the caller or to its end.
///
/// ```no_run
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// # use hooke_sim::{Bc, Builder, Region, Solid};
/// # let sim = Builder::new(hooke_core::LatticeKind::Hex, 1e-3)
/// #     .thickness(1e-3)
/// #     .solid(Solid::cuboid([0.0; 3], [20e-3, 10e-3, 0.0]))
/// #     .material(70e9, 0.22, 2500.0)
/// #     .boundary(Bc::on(Region::All).fixed(0))
/// #     .end_time(40e-6)
/// #     .build()?;
/// let mut run = hooke_sim::Run::start(sim, hooke_sim::RunOptions::new("out", "plate"))?;
/// run.advance(20e-6, &mut hooke_sim::Silent)?; // to t = 20 us, writing on schedule
/// println!("{} springs broken", run.simulation().broken().0);
/// let summary = run.finish(&mut hooke_sim::Silent)?;
/// # Ok(()) }
/// ```
pub struct Run {
    sim: Simulation,
    it: Integrator,
    opts: RunOptions,
    sinks: Vec<Box<dyn Sink>>,
    contact_history: Option<ContactHistory>,
    next_frame: Real,
    next_ckpt: Real,
    next_reactions: Option<Real>,
    started: Instant,
    t_start: Real,
    step_start: u64,
    last_report: Instant,
    /// The progress reports' last energy evaluation (see [`Progress::energy_time`]).
    report_energy: Option<ReportEnergy>,
    /// The step of the last frame with its energy balance and reactions: the summary of a run
    /// that ends on a frame (every run does) takes them from it, the same bits, rather than
    /// evaluate the forces twice more by the reference law.
    last_frame: Option<(u64, EnergyBalance, Vec<RegionReaction>)>,
    provenance: Option<Provenance>,
}

/// A progress report evaluates the energy again once at least this many times the previous
/// evaluation's cost has passed, so that the evaluations take at most about 5 % of a run. Each
/// is a force evaluation by the reference law: on a terminal (a report every half second) a
/// glass plate of 224 000 nodes ran 17-19 % slower than in a batch job when every report made
/// one.
const REPORT_SHARE: u32 = 20;

/// The energy a progress report shows, and when and at what cost it was evaluated.
struct ReportEnergy {
    time: Real,
    energy: Real,
    balance: Real,
    at: Instant,
    cost: std::time::Duration,
}

/// The run's integrator: on the pieces a simulation set up from parts holds, fresh (sharing
/// its stable-step estimate with the team and coming back distributed), or resumed from a
/// whole checkpoint (`resume_here`: the checkpoint is read here, not by each piece later).
fn integrator(sim: &mut Simulation, opts: &RunOptions, resume_here: bool) -> Result<Integrator> {
    // A fresh integrator shares its stable-step estimate with the team and comes back
    // distributed; a resumed one takes its step from the checkpoint.
    let resume_whole = opts.resume.as_ref().filter(|_| resume_here);
    // A simulation set up from parts is on its pieces already.
    let from_parts = sim.from_parts.take();
    if from_parts.is_some() {
        let why = match (opts.on_pieces(), resume_whole) {
            (None, _) => Some("it was set up from parts: run it on the team that set it up, with pieces (RunOptions::pieces, team)"),
            (_, Some(_)) => Some("a run set up from parts resumes from its processes' own checkpoints (NAME.rankR-of-N.ckpt), on as many processes as wrote them"),
            _ => None,
        };
        if opts.anyone(why.is_some()) {
            return Err(why.map_or_else(|| elsewhere(true), |w| Error::Input(w.into())));
        }
    }
    Ok(match (from_parts, resume_whole) {
        (Some(parts), _) => {
            let team = opts.team.clone().expect("a team");
            Integrator::on_piece(
                &sim.body,
                &mut sim.state,
                sim.loading.clone(),
                parts.piece,
                parts.share,
                team,
                &sim.options,
            )
            .map_err(|e| Error::Input(e.to_string()))?
        }
        (None, None) => Integrator::new_shared(
            &sim.body,
            &mut sim.state,
            sim.loading.clone(),
            &sim.options,
            opts.team.clone(),
        )
        .map_err(|e| Error::Input(e.to_string()))?,
        (None, Some(path)) => resume_from_whole(sim, opts, path)?,
    })
}

impl Run {
    /// Check the folder, open the outputs, prepare the integrator (or load the checkpoint to
    /// resume from) and write the first frame. Quasi-static simulations run through [`run`].
    pub fn start(mut sim: Simulation, opts: RunOptions) -> Result<Run> {
        if sim.solver.is_quasi_static() {
            return Err(Error::Input(
                "a quasi-static simulation runs to its end through hooke_sim::run".into(),
            ));
        }
        let checked = if opts.writes() {
            preflight(&sim, &opts)
        } else {
            Ok(())
        };
        if opts.anyone(checked.is_err()) {
            checked?;
            return Err(elsewhere(true));
        }
        // A run on pieces resumes from its processes' own checkpoints, read once each has cut
        // its piece (the integrator is built as for a fresh run, then restored).
        let piece_resume = match (&opts.resume, opts.on_pieces()) {
            (Some(path), Some((rank, size))) => {
                let own = RunOptions::piece_checkpoint_path(path, rank, size);
                // A whole checkpoint (of a run that did not hold pieces) is resumed whole and
                // then cut.
                (own.exists() || !path.exists()).then_some(own)
            }
            _ => None,
        };
        let it = integrator(&mut sim, &opts, piece_resume.is_none())?;
        let mut it = it;
        let on_parts = sim.held.is_some();
        if let Some(team) = &opts.team {
            if opts.resume.is_some() && !on_parts {
                it.distribute(&sim.body, team.clone());
            }
            if let Some(c) = sim.contact.as_mut() {
                c.distribute(team.clone());
            }
        }
        // The set-up's temporaries are gone: give their memory back for the run.
        hooke_sys::alloc::release_free_memory();
        let resuming = opts.resume.is_some();
        // A process of a run on pieces has not read its checkpoint yet (it needs the piece).
        let until = piece_resume
            .as_deref()
            .and_then(Checkpoint::time_of)
            .unwrap_or(sim.state.time);
        // VTK frames in pieces, one per process, when shared.
        let pieces = it.share().map(|s| (s.rank, s.nodes.clone()));
        // Only the writer opens files (and the other processes their frames' pieces); a
        // failure there stops every member.
        let opened = open_outputs(&sim, &opts, &it, until, pieces);
        if opts.anyone(opened.is_err()) {
            opened?;
            return Err(elsewhere(true));
        }
        let (sinks, contact_history, provenance) = opened?;
        onto_pieces(&mut sim, &mut it, &opts, on_parts, piece_resume.as_deref())?;
        // The next output times after t. A frame is taken at the first step within half a step
        // of its time, so one due just after t may already have been taken just before it (a
        // resumed run): count t + dt/2 as passed.
        let t = sim.state.time + 0.5 * it.dt();
        let next = |every: Real| (t / every).floor() * every + every;
        let next_frame = next(sim.output_every);
        let next_ckpt = next(sim.checkpoint_every);
        let next_reactions = sim.reactions_every.map(next);
        let mut run = Run {
            t_start: sim.state.time,
            step_start: sim.state.step,
            sim,
            it,
            opts,
            sinks,
            contact_history,
            next_frame,
            next_ckpt,
            next_reactions,
            started: Instant::now(),
            last_report: Instant::now(),
            report_energy: None,
            last_frame: None,
            provenance,
        };
        if !resuming {
            let first = run.write_frame();
            if run.opts.anyone(first.is_err()) {
                first?;
                return Err(elsewhere(false));
            }
        }
        Ok(run)
    }

    /// The simulation as it stands (state, fracture, contact).
    pub fn simulation(&self) -> &Simulation {
        &self.sim
    }

    /// The integrator (time step, stable step, kernel, energy ledger).
    pub fn integrator(&self) -> &Integrator {
        &self.it
    }

    /// Add an output; it receives every frame from the next one on.
    pub fn add_sink(&mut self, sink: Box<dyn Sink>) {
        self.sinks.push(sink);
    }

    /// Whether the simulation has reached its end time.
    pub fn done(&self) -> bool {
        self.sim.state.time >= self.sim.end_time - 0.5 * self.it.dt()
    }

    /// Commit the breaks that are due at the current state (a screened criterion decides them
    /// at the next step's start, see `Fracture::step`): what is written or reported then shows
    /// them. Never changes the run. [`Run::steps`] and [`Run::advance`] end with it; after
    /// [`Run::step`] the state may still hold springs that the next step breaks first.
    pub fn settle(&mut self) {
        let sim = &mut self.sim;
        // Everything that settles goes on to read the whole state (output, energy, reactions):
        // a shared run's velocities are made current here.
        self.it.gather_state(&mut sim.state);
        if let Some(fr) = sim.fracture.as_mut() {
            fr.settle(&sim.body, &mut sim.state, &mut self.it);
        }
    }

    /// Keeps the displacements in the allocation that starts at `home` (an address taken from
    /// `simulation().state.u.as_flat()`), for readers that view them without a copy: the
    /// integrator alternates two buffers from step to step (except where its kernel drifts in
    /// place, with one buffer), and this moves the values back (one copy) when they are in the
    /// other one. False if `home` is neither buffer.
    pub fn keep_displacement_in(&mut self, home: *const Real) -> bool {
        if self.sim.state.u.as_flat().as_ptr() != home {
            self.it.swap_displacement_buffers(&mut self.sim.state);
        }
        self.sim.state.u.as_flat().as_ptr() == home
    }

    /// The velocities at the current time into `out` (the full step: `v(t - dt/2) + dt/2 a(t)`
    /// on free DOFs, the prescribed velocity on prescribed ones), in place.
    pub fn full_velocity_into(&mut self, out: &mut Coords) {
        self.settle();
        let v = self.it.full_velocity(&self.sim.body, &mut self.sim.state);
        out.copy_from(&v);
    }

    /// The energy balance now (one force evaluation).
    pub fn energy(&mut self) -> hooke_core::dynamics::EnergyBalance {
        self.settle();
        self.it.energy(&self.sim.body, &mut self.sim.state)
    }

    /// The reactions of the boundary regions now (the forces of the prescribed nodes alone:
    /// [`Integrator::boundary_forces_now`]).
    pub fn reactions(&mut self) -> Vec<RegionReaction> {
        self.settle();
        let f = self.it.boundary_forces_now(&self.sim.body, &self.sim.state);
        region_reactions_piece(&self.sim, &self.it, &f)
    }

    /// One step: forces, contact, breaking, then whatever the schedule wants written.
    pub fn step(&mut self, obs: &mut dyn Observer) -> Result<()> {
        let sim = &mut self.sim;
        let body = &sim.body;
        let contact = sim.contact.as_mut().map(|c| c as &mut dyn Interaction);
        match sim.fracture.as_mut() {
            Some(fr) => {
                fr.step(body, &mut sim.state, &mut self.it, contact);
            }
            None => self.it.step_with(body, &mut sim.state, contact),
        }
        if sim.state.step.is_multiple_of(64) {
            // Every member checks its own nodes, and an instability stops all of them alike.
            self.it.check_shared(&sim.body, &mut sim.state)?;
        }
        let written = self.write_due();
        // What only one member may know (a failed write, Ctrl-C, the progress clock) becomes
        // every member's decision, so that all of them take the same path.
        let progress_due = obs
            .progress_interval()
            .is_some_and(|every| self.last_report.elapsed() >= every);
        let mut flags = [written.is_err(), obs.interrupted(), progress_due];
        if let Some(t) = &self.opts.team {
            t.any(&mut flags);
        }
        if let Err(e) = written {
            if let Some(p) = self.provenance.as_mut() {
                p.end(&format!("failed: {e}"), &self.opts.out);
            }
            return Err(e);
        }
        if flags[0] {
            return Err(elsewhere(false));
        }
        if flags[1] {
            self.write_frame()?;
            self.save()?;
            self.flush_outputs()?;
            let e = Error::Interrupted {
                step: self.sim.state.step,
                time: self.sim.state.time,
                checkpoint: Some(self.opts.checkpoint_path()),
                load_steps: None,
            };
            if let Some(p) = self.provenance.as_mut() {
                p.end(&e.to_string(), &self.opts.out);
            }
            return Err(e);
        }
        if flags[2] {
            self.last_report = Instant::now();
            let p = self.progress();
            if self.opts.writes() {
                obs.progress(&p);
            }
        }
        Ok(())
    }

    /// Frames, reactions and checkpoints that are due after the step just taken.
    fn write_due(&mut self) -> Result<()> {
        let half = 0.5 * self.it.dt();
        let done = self.sim.state.time >= self.sim.end_time - half;
        let time = self.sim.state.time;
        let reactions_due = self.next_reactions.is_some_and(|n| time >= n - half);
        if reactions_due {
            let every = self.sim.reactions_every.unwrap_or(Real::INFINITY);
            self.next_reactions = self.next_reactions.map(|n| n + every);
        }
        if time >= self.next_frame - half || done {
            self.it.gather_state(&mut self.sim.state);
            if self.sim.held.is_some() {
                self.it.check_shared(&self.sim.body, &mut self.sim.state)?;
            } else {
                self.it.check(&self.sim.body, &self.sim.state)?;
            }
            self.next_frame += self.sim.output_every;
            self.write_frame()?;
        } else if reactions_due {
            let r = self.reactions();
            for s in &mut self.sinks {
                s.reactions(time, &r)?;
            }
        }
        if time >= self.next_ckpt - half || done {
            self.next_ckpt += self.sim.checkpoint_every;
            self.save()?;
        }
        Ok(())
    }

    fn progress(&mut self) -> Progress {
        self.settle();
        let sim = &self.sim;
        let frac =
            ((sim.state.time - self.t_start) / (sim.end_time - self.t_start)).clamp(0.0, 1.0);
        let wall = self.started.elapsed().as_secs_f64();
        let rate = (sim.state.step - self.step_start) as f64 / wall.max(1e-9);
        let broken = sim.broken().0;
        let due = self
            .report_energy
            .as_ref()
            .is_none_or(|e| e.at.elapsed() >= REPORT_SHARE * e.cost);
        if due {
            let began = Instant::now();
            let b = self.it.energy(&self.sim.body, &mut self.sim.state);
            let at = Instant::now();
            self.report_energy = Some(ReportEnergy {
                time: self.sim.state.time,
                energy: b.kinetic + b.strain.total(),
                balance: b.relative_error,
                at,
                cost: at - began,
            });
        }
        let e = self.report_energy.as_ref().expect("evaluated above");
        Progress {
            time: self.sim.state.time,
            end_time: self.sim.end_time,
            fraction: frac,
            step: self.sim.state.step,
            steps_per_second: rate,
            eta_seconds: (frac > 0.0).then(|| wall * (1.0 - frac) / frac),
            broken_springs: broken,
            energy: e.energy,
            balance: e.balance,
            energy_time: e.time,
            load_step: None,
        }
    }

    /// Step until `time` (s) or the end time, whichever comes first.
    pub fn advance(&mut self, time: Real, obs: &mut dyn Observer) -> Result<()> {
        let r = self.advance_inner(time, obs);
        if let Err(e) = &r {
            if !matches!(e, Error::Interrupted { .. }) {
                if let Some(p) = self.provenance.as_mut() {
                    p.end(&format!("failed: {e}"), &self.opts.out);
                }
            }
        }
        r
    }

    fn advance_inner(&mut self, time: Real, obs: &mut dyn Observer) -> Result<()> {
        let until = time.min(self.sim.end_time);
        while !self.done() && self.sim.state.time < until - 0.5 * self.it.dt() {
            self.step(obs)?;
        }
        self.settle();
        Ok(())
    }

    /// Take `n` steps (fewer if the end time comes first).
    pub fn steps(&mut self, n: u64, obs: &mut dyn Observer) -> Result<()> {
        for _ in 0..n {
            if self.done() {
                break;
            }
            self.step(obs)?;
        }
        self.settle();
        Ok(())
    }

    /// Run to the end time, make the outputs final and say how it went.
    pub fn finish(self, obs: &mut dyn Observer) -> Result<Summary> {
        self.finish_keeping(obs).map(|(s, _)| s)
    }

    /// As [`Run::finish`], and hand back the simulation as it ended (for callers that go on
    /// reading its state, such as the Python package).
    pub fn finish_keeping(mut self, obs: &mut dyn Observer) -> Result<(Summary, Simulation)> {
        self.advance(Real::INFINITY, obs)?;
        for s in &mut self.sinks {
            s.finish()?;
        }
        // The last frame's, when it shows this state (`Integrator::frame_view` gives the bits
        // of `Integrator::energy` and of the reactions' `full_velocity`).
        let step = self.sim.state.step;
        let at_frame = self.last_frame.take().filter(|f| f.0 == step);
        let b = match &at_frame {
            Some((_, b, _)) => *b,
            None => self.it.energy(&self.sim.body, &mut self.sim.state),
        };
        let wall = self.started.elapsed().as_secs_f64();
        let sim = &mut self.sim;
        if let (Some(c), Some(h)) = (sim.contact.as_mut(), &self.contact_history) {
            h.flush(c)?;
        }
        let mut outputs: Vec<(String, PathBuf)> =
            self.sinks.iter().filter_map(|s| s.describe()).collect();
        if let Some(h) = &self.contact_history {
            outputs.push(("contact history".into(), h.path.clone()));
        }
        outputs.push(match self.opts.on_pieces() {
            Some((_, size)) => (
                format!("checkpoints, one per process (.RofN: rank R of {size})"),
                RunOptions::piece_checkpoint_path(&self.opts.checkpoint_path(), 0, size),
            ),
            None => ("checkpoint".into(), self.opts.checkpoint_path()),
        });
        let energy = EnergyRow::from_balance(sim.state.time, &b);
        let reactions = match at_frame {
            Some((_, _, r)) => r,
            None => self.reactions(),
        };
        let sim = &self.sim;
        let summary = Summary {
            steps: sim.state.step - self.step_start,
            time: sim.state.time,
            wall_seconds: wall,
            quasi_static: false,
            broken_springs: sim.broken().0,
            energy,
            balance: b.relative_error,
            rigid: sim.contact.as_ref().map_or(Vec::new(), |c| {
                c.bodies
                    .iter()
                    .map(|b| (b.name.clone(), b.position, b.velocity))
                    .collect()
            }),
            contact: sim.contact.as_ref().map(|c| {
                (
                    c.rebuilds,
                    c.max_penetration,
                    c.max_penetration / c.opts.radius,
                )
            }),
            outputs,
            reactions,
            // (A shared run's ranks hold current state only at their own nodes.)
            strain_by_material: match &self.opts.team {
                Some(t) if t.size() > 1 => Vec::new(),
                _ => sim.strain_by_material(),
            },
        };
        if let Some(p) = self.provenance.as_mut() {
            p.end("completed", &self.opts.out);
        }
        Ok((summary, self.sim))
    }

    /// Wait until every frame written so far is on disk (VTK frames are written in the
    /// background; [`Run::finish`] and dropping the run wait too). Call it before reading the
    /// output folder of a run that goes on.
    pub fn flush_outputs(&mut self) -> Result<()> {
        for s in &mut self.sinks {
            s.flush()?;
        }
        Ok(())
    }

    /// Write a frame of the current state into every sink now, besides the schedule (what
    /// `hooke bench --frame` times; a caller that wants a picture at a moment of its choosing).
    pub fn frame(&mut self) -> Result<()> {
        self.write_frame()
    }

    /// One frame into every sink, the contact history flushed.
    fn write_frame(&mut self) -> Result<()> {
        self.settle();
        let body = &self.sim.body;
        // One evaluation for the velocity, the energy and the derived fields.
        // Pieces need their own nodes' fields; whole frames (HDF5, written by rank 0) every
        // node's.
        let whole = self.sim.hdf5;
        let (v, b, fields) = self.it.frame_view(body, &mut self.sim.state, whole);
        let forces = self.it.boundary_forces(body, &self.sim.state, &v);
        let reactions = region_reactions_piece(&self.sim, &self.it, &forces);
        self.last_frame = Some((self.sim.state.step, b, reactions.clone()));
        let sim = &self.sim;
        let damage = sim.fracture.as_ref().map(|f| f.damage(body, &sim.state));
        let frame = Frame {
            body,
            state: &sim.state,
            velocity: &v,
            damage: damage.as_deref(),
            derived: &fields.into(),
            regions: &sim.regions,
            energy: EnergyRow::from_balance(sim.state.time, &b),
            reactions: &reactions,
            contact: sim.contact.as_ref(),
            piece: sim.held.as_ref().map(|h| h.own.clone()),
        };
        let written: Result<()> = self.sinks.iter_mut().try_for_each(|s| s.frame(&frame));
        if self.it.share().is_some() {
            // Pieces: listed once every process has written its own.
            if self.opts.anyone(written.is_err()) {
                written?;
                return Err(elsewhere(false));
            }
            for s in &mut self.sinks {
                s.publish()?;
            }
        }
        written?;
        match (self.sim.contact.as_mut(), &self.contact_history) {
            (Some(c), Some(h)) => h.flush(c)?,
            // A member that does not write drops the rows the writer writes.
            (Some(c), None) => c.history.clear(),
            _ => {}
        }
        Ok(())
    }

    fn save(&mut self) -> Result<()> {
        self.settle();
        let path = match self.opts.on_pieces() {
            // Each process its piece's.
            Some((rank, size)) => {
                RunOptions::piece_checkpoint_path(&self.opts.checkpoint_path(), rank, size)
            }
            None if !self.opts.writes() => return Ok(()),
            None => self.opts.checkpoint_path(),
        };
        let (broken, released) = self.sim.broken();
        Checkpoint {
            digest: self.opts.digest,
            state: self.sim.state.clone(),
            integrator: self.it.checkpoint(),
            broken: broken as u64,
            released,
            extra: self
                .sim
                .contact
                .as_ref()
                .map_or(Vec::new(), |c| c.snapshot()),
        }
        .save(&path)?;
        Ok(())
    }
}

/// Run a simulation to its end: explicit dynamics or quasi-static load steps, whichever it is.
pub fn run(sim: Simulation, opts: RunOptions, obs: &mut dyn Observer) -> Result<Summary> {
    run_keeping(sim, opts, obs).map(|(s, _)| s)
}

/// As [`run`], and hand back the simulation as it ended (for callers that go on reading its
/// state, such as the Python package).
pub fn run_keeping(
    mut sim: Simulation,
    opts: RunOptions,
    obs: &mut dyn Observer,
) -> Result<(Summary, Simulation)> {
    match sim.solver.quasi_static_steps() {
        Some(_) if opts.team.as_ref().is_some_and(|t| t.size() > 1) => Err(Error::Input(
            "quasi-static runs (solver.type = \"quasi-static\") run in one process: their static solves are not shared between processes yet; run without mpirun (or with -np 1)".into(),
        )),
        Some(steps) => {
            preflight(&sim, &opts)?;
            let s = crate::quasi_static::run(&mut sim, steps, &opts, obs)?;
            Ok((s, sim))
        }
        None => Run::start(sim, opts)?.finish_keeping(obs),
    }
}

/// Wall-clock interval helper for observers: `secs` seconds.
pub fn seconds(secs: f64) -> Duration {
    Duration::from_secs_f64(secs.max(0.0))
}

/// Write one frame of `state` and a checkpoint into `dir`, as a run would (what `hooke check`
/// does to measure the memory a run needs).
pub fn write_probe(
    sim: &Simulation,
    state: &hooke_core::State,
    it: &Integrator,
    dir: &Path,
) -> Result<()> {
    let mut sinks = open_sinks(sim, dir, "probe", false, 0.0)?;
    let n = sim.body.nodes();
    let zero = Coords::zeros(n);
    let damage = sim.fracture.as_ref().map(|f| f.damage(&sim.body, state));
    let reactions = region_reactions(sim, &zero);
    let frame = Frame {
        body: &sim.body,
        state,
        velocity: &zero,
        damage: damage.as_deref(),
        derived: &hooke_io::fields::derived(&sim.body, state),
        regions: &sim.regions,
        energy: EnergyRow::default(),
        reactions: &reactions,
        contact: sim.contact.as_ref(),
        piece: None,
    };
    for s in &mut sinks {
        s.frame(&frame)?;
    }
    Checkpoint {
        digest: 0,
        state: state.clone(),
        integrator: it.checkpoint(),
        broken: 0,
        released: 0.0,
        extra: sim.contact.as_ref().map_or(Vec::new(), |c| c.snapshot()),
    }
    .save(&dir.join("probe.ckpt"))?;
    Ok(())
}
