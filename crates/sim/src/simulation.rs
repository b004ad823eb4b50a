//! A simulation ready to run: the body, its state and loading, fracture, contact and the
//! schedule of what the run writes.

use hooke_contact::Contact;
use hooke_core::dynamics::IntegratorOptions;
use hooke_core::loading::Loading;
use hooke_core::{Body, Real, State};
use hooke_fracture::Fracture;

/// How a simulation advances in time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Solver {
    /// Explicit dynamics: leapfrog steps of the stable size (`hooke_core::dynamics`).
    #[default]
    Explicit,
    /// Quasi-static loading in `steps` load steps, each solved to equilibrium (static
    /// solves, breaking between them).
    QuasiStatic { steps: usize },
}

impl Solver {
    /// The load steps of a quasi-static simulation; `None` for explicit dynamics.
    pub fn quasi_static_steps(self) -> Option<usize> {
        match self {
            Solver::Explicit => None,
            Solver::QuasiStatic { steps } => Some(steps),
        }
    }

    /// True for quasi-static loading.
    pub fn is_quasi_static(self) -> bool {
        matches!(self, Solver::QuasiStatic { .. })
    }
}

/// A named set of nodes whose reaction and mean displacement the run records
/// (`NAME_reactions.csv`): every boundary condition's region.
#[derive(Clone, Debug, PartialEq)]
pub struct Boundary {
    pub name: String,
    pub nodes: Vec<u32>,
}

/// What a run writes and when.
#[derive(Clone, Debug, PartialEq)]
pub struct Schedule {
    /// Simulated time to reach (s).
    pub end_time: Real,
    /// Time between output frames (s).
    pub output_every: Real,
    /// Time between checkpoints (s).
    pub checkpoint_every: Real,
    /// Time between reaction records (s); `None`: at frames only. Each record costs about one
    /// force evaluation.
    pub reactions_every: Option<Real>,
    /// Write intact springs as line cells.
    pub springs: bool,
    /// Write the VTK series.
    pub vtk: bool,
    /// Write the HDF5 + XDMF series.
    pub hdf5: bool,
}

/// A simulation, built and ready to run (by [`crate::Run`] or [`crate::run`]).
///
/// Built from a case file by `hooke_case::load`, or in code by [`crate::Builder`].
#[derive(Debug)]
pub struct Simulation {
    pub body: Body,
    /// Initial state: pre-cracks applied, initial velocity set.
    pub state: State,
    pub loading: Loading,
    pub fracture: Option<Fracture>,
    pub options: IntegratorOptions,
    /// Simulated time to reach (s).
    pub end_time: Real,
    /// Time between output frames (s).
    pub output_every: Real,
    /// Time between checkpoints (s).
    pub checkpoint_every: Real,
    /// Time between reaction records (s); `None`: at frames only.
    pub reactions_every: Option<Real>,
    /// Write intact springs as line cells.
    pub springs: bool,
    /// The point fields frames carry (`output.fields`; all by default, `node_id` always).
    pub fields: hooke_io::FieldSet,
    /// Region id of every node: 1 + the index of the last boundary whose region holds it, 0 for
    /// none (written as the `region` point field).
    pub regions: Vec<u32>,
    /// The boundary regions, in order, for the reaction history.
    pub boundaries: Vec<Boundary>,
    /// How the simulation advances: explicit dynamics or quasi-static load steps.
    pub solver: Solver,
    /// Write the VTK series.
    pub vtk: bool,
    /// Write the HDF5 + XDMF series.
    pub hdf5: bool,
    /// Spring stiffness k (N/m) of a regular lattice or kappa (Pa, N/m in 2D) of a random one,
    /// and the dispersion ratio q of the material.
    pub k: Real,
    pub q: Real,
    /// Springs removed by pre-cracks.
    pub precracked: usize,
    /// Contact with rigid bodies and between fragments.
    pub contact: Option<Contact>,
    /// An anisotropic material (`[material] kind = "transverse"` or `"orthotropic"`), or
    /// `None` for an isotropic one.
    pub anisotropic: Option<hooke_core::Anisotropic>,
    /// On a random lattice, the anisotropic material's calibrated direction functions and
    /// what the calibration reached ([`hooke_core::random::anisotropic::calibrate`]).
    pub random_design: Option<hooke_core::random::anisotropic::Calibrated>,
    /// Whether the body's springs and nodes are weighted by their cells (regular lattices,
    /// [`crate::Builder::cell_weights`]).
    pub cell_weighted: bool,
    /// How a 2D body stands for its 3D material ([`crate::Builder::plane`]; ignored in 3D).
    pub plane: hooke_core::material::PlaneModel,
    /// Set when this process holds only its piece of the body ([`crate::RunOptions::pieces`]):
    /// `body`, `state` and `regions` are then the piece's, in its numbering.
    pub held: Option<Held>,
    /// Set when this process set its piece up from its part alone ([`crate::Builder::parts`]),
    /// until the run starts on it: what the integrator needs of the piece.
    pub from_parts: Option<FromParts>,
    /// A body of several materials: each phase's material, indexed as [`Body::phase`] (and
    /// the frames' `material` field) number them; empty for a body of one material.
    pub materials: Vec<MaterialInfo>,
}

/// One phase's material in a body of several materials (run.json's `constants.materials`,
/// `hooke check`).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MaterialInfo {
    /// The phase's index: 0 the body's material, `p + 1` the builder's phase `p`.
    pub index: usize,
    pub name: String,
    /// Young's modulus (Pa), Poisson's ratio, density (kg/m^3).
    pub youngs: Real,
    pub poisson: Real,
    pub density: Real,
    /// The dispersion ratio q its nodes take.
    pub q: Real,
}

impl Simulation {
    /// The strain energy (J) each material holds now, by name: each node's share (half of each
    /// intact spring's direct energy and its own dispersive energy, as the frames'
    /// `strain_energy_density` times the node's volume) summed over the nodes of that
    /// material, so that the materials' shares add up to the body's strain energy. Derived
    /// for reports only; empty for a body of one material or a process holding a piece (and
    /// not asked of a shared run, whose ranks keep current state at their own nodes only).
    pub fn strain_by_material(&self) -> Vec<(String, Real)> {
        let Some(phase) = self.body.phase.as_ref().filter(|_| self.held.is_none()) else {
            return Vec::new();
        };
        let f = hooke_core::frame::frame_fields_of(&self.body, &self.state);
        let mut sum = vec![0.0; self.materials.len()];
        for (n, &p) in phase.iter().enumerate() {
            if let Some(s) = sum.get_mut(p as usize) {
                *s += f.energy_density[n] * self.body.lattice.node_volume(n);
            }
        }
        self.materials
            .iter()
            .zip(sum)
            .map(|(m, e)| (m.name.clone(), e))
            .collect()
    }

    /// The nodes of each phase ([`Simulation::materials`]) in this process's body (the whole
    /// body unless it holds a piece).
    pub fn phase_nodes(&self) -> Vec<usize> {
        let mut n = vec![0; self.materials.len()];
        if let Some(p) = &self.body.phase {
            for &p in p {
                if let Some(c) = n.get_mut(p as usize) {
                    *c += 1;
                }
            }
        }
        n
    }
}

/// A piece set up from a part ([`hooke_core::team::parts`]), handed to the run that steps it.
#[derive(Clone, Debug)]
pub struct FromParts {
    pub piece: hooke_core::team::Piece,
    pub share: hooke_core::team::Share,
}

/// Where a process's own nodes are when it holds a piece of the body
/// ([`hooke_core::team::Piece`]; the other nodes of the piece are its ghosts and padding).
#[derive(Clone, Debug, PartialEq)]
pub struct Held {
    /// The own nodes, in the piece's numbering.
    pub own: std::ops::Range<usize>,
    /// The body's index of the first of them (the rest follow in order).
    pub first: usize,
    /// Nodes and springs of the whole body.
    pub nodes: usize,
    pub springs: usize,
    /// The whole body's extent ([`Simulation::extent`]).
    pub extent: Real,
}

impl Simulation {
    /// Bytes the run will write: frames (VTK base64 and/or HDF5), histories and the checkpoint
    /// (twice, while it is renamed into place).
    pub fn output_estimate(&self) -> f64 {
        let (n, s) = (self.nodes() as f64, self.springs() as f64);
        let frames = (self.end_time / self.output_every).ceil() + 2.0;
        // Per node: coordinates and up to 19 values of 8 bytes (vectors, scalars, stress,
        // volume), a u32 region id, a u64 node id and a vertex cell; base64 adds a third.
        let values: f64 = self
            .fields
            .names()
            .map(|f| match f {
                "displacement" | "velocity" => 3.0,
                "stress" => 9.0,
                "region" => 0.5,
                _ => 1.0,
            })
            .sum();
        let mut per_frame = 0.0;
        if self.vtk {
            per_frame += n * (4.0 / 3.0) * ((3.0 + values) * 8.0 + 17.0)
                + if self.springs {
                    s * (4.0 / 3.0) * 25.0
                } else {
                    0.0
                };
        }
        if self.hdf5 {
            per_frame += n * (4.0 + values) * 8.0;
        }
        frames * (per_frame + 200.0 + 160.0 * self.boundaries.len() as f64)
            + 2.0 * (48.0 * n + s + 200.0)
    }

    /// Nodes of the whole body (a piece's process holds fewer: [`Simulation::held`]).
    pub fn nodes(&self) -> usize {
        self.held.as_ref().map_or(self.body.nodes(), |h| h.nodes)
    }

    /// Springs of the whole body.
    pub fn springs(&self) -> usize {
        self.held
            .as_ref()
            .map_or(self.body.springs(), |h| h.springs)
    }

    /// The extent of the body (m): its largest side.
    pub fn extent(&self) -> Real {
        if let Some(h) = &self.held {
            return h.extent;
        }
        let pos = &self.body.lattice.pos;
        [pos.x(), pos.y(), pos.z()]
            .iter()
            .map(|v| {
                let lo = v.iter().cloned().fold(Real::INFINITY, Real::min);
                let hi = v.iter().cloned().fold(Real::NEG_INFINITY, Real::max);
                hi - lo
            })
            .fold(0.0, Real::max)
    }

    /// Whether the case has rigid bodies (their surfaces and history are written).
    pub fn has_rigid_bodies(&self) -> bool {
        self.contact.as_ref().is_some_and(|c| !c.bodies.is_empty())
    }

    /// Springs broken so far and the energy they released (J).
    pub fn broken(&self) -> (usize, Real) {
        self.fracture
            .as_ref()
            .map_or((0, 0.0), |f| (f.broken_total, f.released_total))
    }
}
