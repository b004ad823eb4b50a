//! What a run writes, behind one trait: every output is a [`Sink`] that receives each frame.
//!
//! The drivers assemble a [`Frame`] (state, full-step velocity, damage, the energy ledger, the
//! reactions of every boundary region) only at output times, so nothing derived is computed on
//! the hot path, and hand it to each sink in turn. The shipped sinks are the VTK series, the
//! HDF5 + XDMF series (feature `hdf5`), the rigid bodies' surfaces, the energy history
//! (`NAME_energy.csv`), the reaction history (`NAME_reactions.csv`) and the contact history
//! (`NAME_contact.csv`). Callers add their own (an in-memory recorder, a plot) with
//! [`crate::Run::add_sink`].

use std::io::Write;
use std::path::{Path, PathBuf};

use hooke_contact::Contact;
use hooke_core::{Body, Coords, Real, State};
use hooke_io::{FrameExtras, VtkSeries};

use crate::error::{Error, Result};

/// One row of the energy ledger (J), as written to `NAME_energy.csv`.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct EnergyRow {
    pub time: Real,
    pub kinetic: Real,
    pub strain_direct: Real,
    pub strain_dispersive: Real,
    pub external_work: Real,
    pub boundary_work: Real,
    pub body_work: Real,
    pub dissipated: Real,
    pub released: Real,
    /// Explicit runs: the integrator's balance error (J); quasi-static runs: strain + released +
    /// dissipated - work (J).
    pub balance_error: Real,
}

impl EnergyRow {
    /// The row of an explicit run at `time` from the integrator's energy balance.
    pub fn from_balance(time: Real, b: &hooke_core::dynamics::EnergyBalance) -> Self {
        let l = b.ledger;
        EnergyRow {
            time,
            kinetic: b.kinetic,
            strain_direct: b.strain.direct,
            strain_dispersive: b.strain.dispersive,
            external_work: l.external_work,
            boundary_work: l.boundary_work,
            body_work: l.body_work,
            dissipated: l.dissipated,
            released: l.released,
            balance_error: b.error,
        }
    }
}

/// The force a boundary region exerts on the body and how far it moved.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct RegionReaction {
    /// `boundary[k]` of the case, or the name given to the builder.
    pub name: String,
    /// Sum over the region's nodes of the support reactions on prescribed DOFs and the loads
    /// applied there (N; in 2D per plate of the case's thickness).
    pub force: [Real; 3],
    /// Mean displacement of the region's nodes (m).
    pub displacement: [Real; 3],
}

/// Everything a sink may write at one output time.
pub struct Frame<'a> {
    pub body: &'a Body,
    pub state: &'a State,
    /// Full-step velocity `v(t)` (the state holds half-step velocities).
    pub velocity: &'a Coords,
    pub damage: Option<&'a [Real]>,
    /// Pool ratio, strain energy density and stress, computed once for every sink.
    pub derived: &'a hooke_io::fields::Derived,
    /// Region id per node (`region` point field).
    pub regions: &'a [u32],
    pub energy: EnergyRow,
    pub reactions: &'a [RegionReaction],
    pub contact: Option<&'a Contact>,
    /// The own nodes of a piece ([`crate::Held`]) when `body` and `state` are one.
    pub piece: Option<std::ops::Range<usize>>,
}

impl<'a> Frame<'a> {
    /// What the field writers take beside the state.
    fn extras(&self) -> FrameExtras<'a> {
        FrameExtras {
            velocity: Some(self.velocity),
            damage: self.damage,
            region: Some(self.regions),
            derived: Some(self.derived),
            // Each series writes the fields it was given (`set_fields`).
            fields: hooke_io::FieldSet::ALL,
        }
    }
}

/// An output of a run.
pub trait Sink: Send {
    /// Write one frame.
    fn frame(&mut self, frame: &Frame) -> Result<()>;
    /// Reactions between frames (`output.reactions_every`); most sinks ignore them.
    fn reactions(&mut self, _time: Real, _reactions: &[RegionReaction]) -> Result<()> {
        Ok(())
    }
    /// Wait until everything written so far is on disk (frames may be written in the
    /// background).
    fn flush(&mut self) -> Result<()> {
        Ok(())
    }
    /// The run completed: make the output final (HDF5 merges its frame files here).
    fn finish(&mut self) -> Result<()> {
        self.flush()
    }
    /// What this sink wrote, for the run's summary (a path and a short description).
    fn describe(&self) -> Option<(String, PathBuf)> {
        None
    }
    /// A frame written in pieces by several processes is complete (every process wrote its
    /// piece): list it (the `.pvtu` and the `.pvd` of VTK output, on rank 0).
    fn publish(&mut self) -> Result<()> {
        Ok(())
    }
}

fn append(path: &Path, text: &str) -> Result<()> {
    let mut f = std::fs::OpenOptions::new()
        .append(true)
        .open(path)
        .map_err(Error::file(format!("appending to {}", path.display())))?;
    f.write_all(text.as_bytes())
        .map_err(Error::file(format!("appending to {}", path.display())))
}

fn create(path: &Path, text: &str) -> Result<()> {
    std::fs::write(path, text).map_err(Error::file(format!("writing {}", path.display())))
}

/// Start a history: a fresh run (`keep` None) writes its header; a resumed one keeps the header
/// and the rows whose time (first column) passes `keep`.
fn start_history(path: &Path, header: &str, keep: Option<&dyn Fn(Real) -> bool>) -> Result<()> {
    let Some(keep) = keep else {
        return create(path, header);
    };
    let Ok(text) = std::fs::read_to_string(path) else {
        return create(path, header);
    };
    let mut out = String::with_capacity(text.len());
    for line in text.lines() {
        let t = line.split(',').next().and_then(|v| v.parse::<Real>().ok());
        if t.is_none_or(keep) {
            out.push_str(line);
            out.push('\n');
        }
    }
    create(path, &out)
}

/// The VTK series: `NAME.pvd` and one `.vtu` per frame.
pub struct VtkSink(pub VtkSeries);

impl Sink for VtkSink {
    fn frame(&mut self, f: &Frame) -> Result<()> {
        if let Some(own) = &f.piece {
            self.0.set_piece_nodes(own.clone());
        }
        self.0.write(f.body, f.state, f.extras())?;
        Ok(())
    }
    fn flush(&mut self) -> Result<()> {
        self.0.flush()?;
        Ok(())
    }
    fn describe(&self) -> Option<(String, PathBuf)> {
        Some((
            format!("{} frames", self.0.frames().len()),
            self.0.pvd_path(),
        ))
    }
    fn publish(&mut self) -> Result<()> {
        self.0.publish()?;
        Ok(())
    }
}

/// The HDF5 + XDMF series (one file per frame during the run, merged at its end).
#[cfg(feature = "hdf5")]
pub struct H5Sink(pub hooke_io::H5Series);

#[cfg(feature = "hdf5")]
impl Sink for H5Sink {
    fn frame(&mut self, f: &Frame) -> Result<()> {
        self.0.write(f.body, f.state, f.extras())?;
        Ok(())
    }
    fn finish(&mut self) -> Result<()> {
        self.0.finish()?;
        Ok(())
    }
    fn describe(&self) -> Option<(String, PathBuf)> {
        Some(("XDMF series".into(), self.0.xdmf_path().to_path_buf()))
    }
}

/// The rigid bodies' surfaces as a VTK series of their own (`NAME_rigid.pvd`).
pub struct RigidSink {
    pub series: hooke_io::RigidSeries,
    /// Half-size of the patch that draws a half-space (the lattice's extent).
    pub patch: Real,
}

impl Sink for RigidSink {
    fn frame(&mut self, f: &Frame) -> Result<()> {
        let Some(c) = f.contact else {
            return Ok(());
        };
        let parts: Vec<hooke_io::RigidPart> = c
            .bodies
            .iter()
            .map(|b| {
                let (points, triangles, lines) = b.surface(self.patch);
                hooke_io::RigidPart {
                    points,
                    triangles,
                    lines,
                    velocity: b.velocity,
                    reaction: b.reaction,
                }
            })
            .collect();
        self.series.write(f.state.time, f.state.step, &parts)?;
        Ok(())
    }
    fn describe(&self) -> Option<(String, PathBuf)> {
        Some(("rigid bodies".into(), self.series.pvd_path()))
    }
}

/// `NAME_energy.csv`: the energy ledger at every frame.
pub struct EnergyHistory {
    pub path: PathBuf,
}

impl EnergyHistory {
    pub const HEADER: &'static str = "time,kinetic,strain_direct,strain_dispersive,external_work,boundary_work,body_work,dissipated,released,balance_error\n";

    /// Open the history: a fresh run (`resumed_at` None) writes its header, a resumed one keeps
    /// the rows up to the time it resumes at.
    pub fn open(dir: &Path, name: &str, resumed_at: Option<Real>) -> Result<Self> {
        let path = dir.join(format!("{name}_energy.csv"));
        let keep = resumed_at.map(|u| move |t: Real| t <= u);
        start_history(
            &path,
            Self::HEADER,
            keep.as_ref().map(|k| k as &dyn Fn(Real) -> bool),
        )?;
        Ok(Self { path })
    }
}

impl Sink for EnergyHistory {
    fn frame(&mut self, f: &Frame) -> Result<()> {
        let e = &f.energy;
        append(
            &self.path,
            &format!(
                "{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e}\n",
                e.time,
                e.kinetic,
                e.strain_direct,
                e.strain_dispersive,
                e.external_work,
                e.boundary_work,
                e.body_work,
                e.dissipated,
                e.released,
                e.balance_error
            ),
        )
    }
    fn describe(&self) -> Option<(String, PathBuf)> {
        Some(("energy history".into(), self.path.clone()))
    }
}

/// `NAME_reactions.csv`: per boundary region, the force it exerts on the body and its mean
/// displacement, one line per region and output time (a load-displacement curve per region).
pub struct ReactionHistory {
    pub path: PathBuf,
    /// Time of the last line written: frames and the finer reaction schedule may coincide.
    last: Option<Real>,
}

impl ReactionHistory {
    pub const HEADER: &'static str = "# hooke reactions: force of each boundary region on the body (N; 2D: for the plate's thickness) and the region's mean displacement (m), time in s\ntime,region,name,force_x,force_y,force_z,displacement_x,displacement_y,displacement_z\n";

    /// As [`EnergyHistory::open`].
    pub fn open(dir: &Path, name: &str, resumed_at: Option<Real>) -> Result<Self> {
        let path = dir.join(format!("{name}_reactions.csv"));
        let keep = resumed_at.map(|u| move |t: Real| t <= u);
        start_history(
            &path,
            Self::HEADER,
            keep.as_ref().map(|k| k as &dyn Fn(Real) -> bool),
        )?;
        Ok(Self {
            path,
            last: resumed_at,
        })
    }

    fn write(&mut self, time: Real, reactions: &[RegionReaction]) -> Result<()> {
        if reactions.is_empty() || self.last == Some(time) {
            return Ok(());
        }
        self.last = Some(time);
        let mut text = String::new();
        for (k, r) in reactions.iter().enumerate() {
            text.push_str(&format!(
                "{:e},{},{},{:e},{:e},{:e},{:e},{:e},{:e}\n",
                time,
                k,
                r.name,
                r.force[0],
                r.force[1],
                r.force[2],
                r.displacement[0],
                r.displacement[1],
                r.displacement[2]
            ));
        }
        append(&self.path, &text)
    }
}

impl Sink for ReactionHistory {
    fn frame(&mut self, f: &Frame) -> Result<()> {
        self.write(f.state.time, f.reactions)
    }
    fn reactions(&mut self, time: Real, reactions: &[RegionReaction]) -> Result<()> {
        self.write(time, reactions)
    }
    fn describe(&self) -> Option<(String, PathBuf)> {
        Some(("reactions".into(), self.path.clone()))
    }
}

/// `NAME_contact.csv`: every rigid body's reaction, position and velocity, as recorded by the
/// contact each step, flushed at frames.
pub struct ContactHistory {
    pub path: PathBuf,
}

impl ContactHistory {
    pub const HEADER: &'static str =
        "time,body,name,reaction_x,reaction_y,reaction_z,x,y,z,vx,vy,vz,wx,wy,wz,qw,qx,qy,qz,torque_x,torque_y,torque_z\n";

    /// As [`EnergyHistory::open`]; the rows at the resume time itself are dropped too (the
    /// step that starts there records them again).
    pub fn open(dir: &Path, name: &str, resumed_at: Option<Real>) -> Result<Self> {
        let path = dir.join(format!("{name}_contact.csv"));
        let keep = resumed_at.map(|u| move |t: Real| t < u);
        start_history(
            &path,
            Self::HEADER,
            keep.as_ref().map(|k| k as &dyn Fn(Real) -> bool),
        )?;
        Ok(Self { path })
    }

    /// Append what the contact recorded since the last call and forget it.
    pub fn flush(&self, c: &mut Contact) -> Result<()> {
        if c.bodies.is_empty() || c.history.is_empty() {
            c.history.clear();
            return Ok(());
        }
        let mut text = String::new();
        for r in &c.history {
            let name = &c.bodies[r.body].name;
            text.push_str(&format!(
                "{:e},{},{},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e}\n",
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
                r.velocity[2],
                r.spin[0],
                r.spin[1],
                r.spin[2],
                r.orientation[0],
                r.orientation[1],
                r.orientation[2],
                r.orientation[3],
                r.torque[0],
                r.torque[1],
                r.torque[2]
            ));
        }
        c.history.clear();
        append(&self.path, &text)
    }
}
