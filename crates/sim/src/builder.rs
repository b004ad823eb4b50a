//! Simulations built in code, like a lab protocol: a lattice filled into a shape, a material,
//! pre-cracks, boundary conditions on regions, the solver and what to write.
//!
//! ```
//! use hooke_sim::{Bc, Builder, Region, Solid};
//! use hooke_core::loading::TimeFunction;
//! use hooke_core::LatticeKind;
//!
//! // A 20 mm x 10 mm glass plate, pulled apart at its top and bottom edges.
//! let sim = Builder::new(LatticeKind::Random2d, 1e-3)
//!     .thickness(1e-3)
//!     .solid(Solid::cuboid([0.0, 0.0, 0.0], [20e-3, 10e-3, 0.0]))
//!     .material(70e9, 0.22, 2500.0)
//!     .fracture_energy(3.8)
//!     .boundary(Bc::on(Region::Face(hooke_sim::Face { axis: 1, high: true }))
//!         .velocity(1, TimeFunction::Constant(0.05)))
//!     .boundary(Bc::on(Region::Face(hooke_sim::Face { axis: 1, high: false })).fixed(1))
//!     .end_time(2e-6)
//!     .build()?;
//! assert!(sim.body.nodes() > 100);
//! assert_eq!(sim.boundaries.len(), 2);
//! # Ok::<(), hooke_sim::BuildError>(())
//! ```
//!
//! Bad input gives a [`BuildError`] naming the item (with the keys a case file would use, e.g.
//! `boundary[1].region`) and the fix, never a panic.

use hooke_core::dynamics::{IntegratorOptions, TimeStep};
use hooke_core::loading::{Loading, Motion, Prescribed, TimeFunction};
use hooke_core::material::{self, Elastic, PlaneModel};
use hooke_core::phases::Phase;
use hooke_core::random::anisotropic::Calibrated;
use hooke_core::random::RandomSpec;
use hooke_core::Designs;
use hooke_core::{Anisotropic, Body, LatticeKind, Orthotropic, Real, State, Transverse, Vector};
use hooke_fracture::{
    Crack, Criterion, CriticalStretch, FibreStretch, Fracture, Softening, SofteningShape,
    SpringEnergy, Weibull,
};

use crate::geometry::{fill_lattice, traction_loads, Region, Shape, Solid};
use crate::rigid::{ContactSpec, RigidSpec};
use crate::simulation::{Boundary, Simulation};

mod parts;

/// What is wrong with a simulation being built: the item (a case file's key) and the fix.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{key}: {message}")]
pub struct BuildError {
    pub key: String,
    pub message: String,
}

impl BuildError {
    pub fn new(key: impl Into<String>, message: impl Into<String>) -> Self {
        BuildError {
            key: key.into(),
            message: message.into(),
        }
    }
}

/// Boundary conditions on one region.
#[derive(Clone, Debug)]
pub struct Bc {
    pub region: Region,
    pub fixed: Vec<usize>,
    /// (axis, motion): prescribed velocity or displacement.
    pub motions: Vec<(usize, Motion)>,
    /// (traction in Pa, outward normal axis, time scale).
    pub tractions: Vec<(Vector, usize, TimeFunction)>,
    /// Springs with a node here never break (grips, supports).
    pub no_fail: bool,
    /// Name in the reaction history (default `boundary[k]`).
    pub name: Option<String>,
}

impl Bc {
    pub fn on(region: Region) -> Bc {
        Bc {
            region,
            fixed: Vec::new(),
            motions: Vec::new(),
            tractions: Vec::new(),
            no_fail: false,
            name: None,
        }
    }
    /// Hold the region along `axis` (0 x, 1 y, 2 z).
    pub fn fixed(mut self, axis: usize) -> Bc {
        self.fixed.push(axis);
        self
    }
    /// Prescribe the velocity along `axis` (m/s).
    pub fn velocity(mut self, axis: usize, f: TimeFunction) -> Bc {
        self.motions.push((axis, Motion::Velocity(f)));
        self
    }
    /// Prescribe the displacement along `axis` (m).
    pub fn displacement(mut self, axis: usize, f: TimeFunction) -> Bc {
        self.motions.push((axis, Motion::Displacement(f)));
        self
    }
    /// A traction (Pa) on the face whose outward normal is along `normal`.
    pub fn traction(mut self, t: [Real; 3], normal: usize, scale: TimeFunction) -> Bc {
        self.tractions.push((Vector::from(t), normal, scale));
        self
    }
    pub fn no_fail(mut self) -> Bc {
        self.no_fail = true;
        self
    }
    pub fn named(mut self, name: impl Into<String>) -> Bc {
        self.name = Some(name.into());
        self
    }
}

/// A material of a body of several materials ([`Builder::phase_of`]).
#[derive(Clone, Debug, PartialEq)]
pub struct PhaseMaterial {
    /// Its name (frames' `material` field numbers the phases; run.json names them).
    pub name: String,
    /// Young's modulus, Poisson's ratio and density.
    pub elastic: Elastic,
    /// Its springs' own critical stretch or fracture energy (`None`: the body's criterion's).
    pub toughness: Option<Toughness>,
    /// A Weibull scatter of its springs' critical stretches.
    pub weibull: Option<Weibull>,
}

impl PhaseMaterial {
    /// A material named `name` of Young's modulus (Pa), Poisson's ratio and density
    /// (kg/m^3), breaking as the body's material does.
    pub fn new(name: impl Into<String>, youngs: Real, poisson: Real, density: Real) -> Self {
        PhaseMaterial {
            name: name.into(),
            elastic: Elastic {
                youngs,
                poisson,
                density,
            },
            toughness: None,
            weibull: None,
        }
    }
}

/// A strength of its own, for a material's springs or an interface's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Toughness {
    /// A critical stretch.
    Stretch(Real),
    /// A fracture energy G_c (J/m^2), converted to a critical stretch with the lattice's
    /// measured toughness (`hooke_fracture::stretch`) and the springs' own constants.
    Energy(Real),
}

/// The springs that join two named materials ([`Builder::interface`]): the interfacial
/// transition zone of concrete, a weak or strong bond.
#[derive(Clone, Debug, PartialEq)]
pub struct Interface {
    /// The two materials' names (the body's, [`Builder::material_name`], or a phase's).
    pub between: [String; 2],
    /// The interface springs' own strength (`None`: the weaker material's).
    pub toughness: Option<Toughness>,
    /// A factor on the interface springs' stiffness (1: both materials in series).
    pub stiffness: Real,
}

/// The breaking rule.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BreakRule {
    /// Critical stretch from G_c (J/m^2) through the measured lattice toughness.
    FractureEnergy(Real),
    /// A critical stretch given directly.
    Stretch(Real),
    /// Critical stretches across and along the fibre of a transversely isotropic material
    /// ([`hooke_fracture::FibreStretch`]).
    FibreStretch { across: Real, along: Real },
    /// The spring-energy criterion calibrated to G_c (regular lattices).
    SpringEnergy(Real),
    /// The spring-energy criterion matching a given critical stretch (regular lattices).
    SpringEnergyFromStretch(Real),
    /// Softening springs ([`hooke_fracture::softening`]) from the fracture energy G_f (J/m^2)
    /// and the tensile strength f_t (Pa) or the characteristic length.
    Softening {
        fracture_energy: Real,
        strength: Strength,
        shape: SofteningShape,
    },
    /// Softening springs from their peak and final stretches.
    SofteningStretch {
        peak: Real,
        last: Real,
        shape: SofteningShape,
    },
}

/// How a softening material's strength is given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Strength {
    /// The tensile strength f_t (Pa).
    Tensile(Real),
    /// The characteristic length `l_ch = E G_f / f_t^2` (m).
    CharacteristicLength(Real),
}

/// How [`Builder::loading`] finds a region's nodes: in the whole body, or in a process's
/// piece of it ([`Builder::parts`]).
struct Selector<'a> {
    /// The region's nodes that this process holds, ascending.
    select: &'a dyn Fn(&Region) -> Vec<u32>,
    /// Whether a selection is empty on every process.
    none: &'a dyn Fn(&[u32]) -> bool,
    /// A boundary's nodes in the body's numbering, every process's.
    listed: &'a dyn Fn(&[u32]) -> Vec<u32>,
}

/// A simulation under construction. See the module docs.
#[derive(Clone, Debug)]
pub struct Builder {
    kind: LatticeKind,
    spacing: Real,
    thickness: Option<Real>,
    plane: PlaneModel,
    random: RandomSpec,
    geometry: Solid,
    material: Option<Elastic>,
    /// The body's material's name (phase 0 of a body of several materials).
    name: String,
    /// A Weibull scatter of the body's material's critical stretches.
    weibull: Option<Weibull>,
    /// A lognormal random field of the body's material's Young's modulus.
    field: Option<crate::field::StiffnessField>,
    /// Phases of other materials: the nodes in each shape (the last that holds a node wins).
    phases: Vec<(Shape, PhaseMaterial)>,
    /// The interfaces between named materials.
    interfaces: Vec<Interface>,
    /// Random inclusions: the phase each becomes (placed when the body is built) and what
    /// to place.
    inclusions: Vec<(usize, crate::inclusions::InclusionSpec)>,
    anisotropic: Option<Anisotropic>,
    rotate_to: Option<[Real; 3]>,
    cell_weights: Option<bool>,
    breaking: Option<BreakRule>,
    cracks: Vec<Crack>,
    bcs: Vec<Bc>,
    initial: Vec<(Region, [Real; 3])>,
    gravity: [Real; 3],
    end_time: Option<Real>,
    output_every: Option<Real>,
    checkpoint_every: Option<Real>,
    reactions_every: Option<Real>,
    springs: bool,
    fields: hooke_io::FieldSet,
    formats: (bool, bool),
    time_step: TimeStep,
    damping: Real,
    quasi_static: Option<usize>,
    contact: Option<(ContactSpec, Vec<RigidSpec>)>,
    parts: Option<std::sync::Arc<dyn hooke_core::team::Team>>,
}

impl Builder {
    /// A lattice of `kind` with (mean) spacing `spacing` (m).
    pub fn new(kind: LatticeKind, spacing: Real) -> Builder {
        Builder {
            kind,
            spacing,
            thickness: None,
            plane: PlaneModel::Stress,
            random: RandomSpec::default(),
            geometry: Solid::default(),
            material: None,
            name: "material".into(),
            weibull: None,
            field: None,
            phases: Vec::new(),
            interfaces: Vec::new(),
            inclusions: Vec::new(),
            anisotropic: None,
            rotate_to: None,
            cell_weights: None,
            breaking: None,
            cracks: Vec::new(),
            bcs: Vec::new(),
            initial: Vec::new(),
            gravity: [0.0; 3],
            end_time: None,
            output_every: None,
            checkpoint_every: None,
            reactions_every: None,
            springs: false,
            fields: hooke_io::FieldSet::ALL,
            formats: (true, false),
            time_step: TimeStep::default(),
            damping: 0.0,
            quasi_static: None,
            contact: None,
            parts: None,
        }
    }
    /// Plate thickness of a 2D lattice (m).
    pub fn thickness(mut self, h: Real) -> Self {
        self.thickness = Some(h);
        self
    }
    /// Plane stress (default) or plane strain, for 2D lattices.
    pub fn plane(mut self, p: PlaneModel) -> Self {
        self.plane = p;
        self
    }
    /// How a random lattice scatters its nodes (sampler and seed).
    pub fn random(mut self, spec: RandomSpec) -> Self {
        self.random = spec;
        self
    }
    /// The body's shape.
    pub fn solid(mut self, g: Solid) -> Self {
        self.geometry = g;
        self
    }
    /// Young's modulus (Pa), Poisson's ratio, density (kg/m^3).
    pub fn material(mut self, youngs: Real, poisson: Real, density: Real) -> Self {
        self.material = Some(Elastic {
            youngs,
            poisson,
            density,
        });
        self
    }
    /// A phase of another isotropic material: the nodes inside `shape` are of it (a later
    /// phase overrides an earlier one where they overlap; the [`Builder::material`] fills the
    /// rest). Springs between two materials take both in series (`hooke_core::phases`), and
    /// each node its material's dispersion ratio. Fracture then takes a critical stretch (the
    /// fracture-energy calibrations are one material's).
    pub fn phase(self, shape: Shape, youngs: Real, poisson: Real, density: Real) -> Self {
        let name = format!("phase{}", self.phases.len() + 1);
        self.phase_of(shape, PhaseMaterial::new(name, youngs, poisson, density))
    }
    /// A phase of a named material, which may have its own strength and scatter (see
    /// [`Builder::phase`]). Its springs break by its own critical stretch (or by the one its
    /// fracture energy gives with its constants), else by the body's.
    pub fn phase_of(mut self, shape: Shape, material: PhaseMaterial) -> Self {
        self.phases.push((shape, material));
        self
    }
    /// Random inclusions of `material` ([`crate::inclusions`]): non-overlapping spheres (disks
    /// in 2D) of a grading and a volume fraction, placed inside the body when it is built,
    /// the same on every process. They are one phase, in the order of the phases (a later
    /// phase overrides them where they overlap). A fraction the generator cannot reach is
    /// refused with the fraction it reached.
    pub fn inclusions(
        mut self,
        spec: crate::inclusions::InclusionSpec,
        material: PhaseMaterial,
    ) -> Self {
        self.inclusions.push((self.phases.len(), spec));
        let none = crate::inclusions::Balls::none(self.kind.dim());
        self.phases
            .push((Shape::Balls(std::sync::Arc::new(none)), material));
        self
    }
    /// The name of the body's material (default `material`): phase 0 in frames and reports,
    /// and what an [`Interface`] calls it.
    pub fn material_name(mut self, name: impl Into<String>) -> Self {
        self.name = name.into();
        self
    }
    /// Scatter the critical stretches of the body's material's springs (Weibull; the scale
    /// is its critical stretch). A phase's material scatters by its own
    /// ([`PhaseMaterial::weibull`]).
    pub fn weibull(mut self, w: Weibull) -> Self {
        self.weibull = Some(w);
        self
    }
    /// A spatially correlated lognormal field of the material's Young's modulus
    /// ([`crate::field`]): each spring's stiffness scaled by the field at its two halves, in
    /// series. A body of one isotropic material.
    pub fn stiffness_field(mut self, f: crate::field::StiffnessField) -> Self {
        self.field = Some(f);
        self
    }
    /// The springs between two named materials take their own strength and stiffness factor.
    /// Refused where no spring joins them.
    pub fn interface(mut self, i: Interface) -> Self {
        self.interfaces.push(i);
        self
    }
    /// A transversely isotropic material instead of [`Builder::material`] (the cubic lattice,
    /// its fibre along a lattice axis: [`Body::transverse`]). Fracture then takes a critical
    /// stretch ([`BreakRule::Stretch`]): the G_c calibrations are isotropic.
    pub fn transverse(mut self, t: Transverse) -> Self {
        self.anisotropic = Some(Anisotropic::Transverse(t));
        self
    }
    /// Lay the cubic lattice along `dir` (e.g. a fibre's): the lattice axis nearest to it is
    /// turned onto it ([`hooke_core::anisotropy::lattice_rotation`]) and the turned lattice
    /// filled into the solid. Its faces are then node planes only where they lie along the
    /// lattice; elsewhere they are steps of one spacing.
    pub fn rotate_lattice(mut self, dir: [Real; 3]) -> Self {
        self.rotate_to = Some(dir);
        self
    }
    /// An orthotropic material ([`Body::orthotropic`]), with the same limits as
    /// [`Builder::transverse`]. Its material axes are the body's, or `o.axes`
    /// ([`Orthotropic::axes_from`]): then the cubic lattice is laid along them.
    pub fn orthotropic(mut self, o: Orthotropic) -> Self {
        self.anisotropic = Some(Anisotropic::Orthotropic(o));
        self
    }
    /// Whether the lattice is laid along a fibre or material axes (its faces are then steps).
    /// Weight the springs and nodes of a regular lattice by the share of the bulk's cells each
    /// stands for ([`Body::with_cell_weights`]: no free-surface bias in the moduli; tractions
    /// spread by the trapezoid rule). By default they are, wherever the lattice allows it (a
    /// regular lattice, not periodic, not turned, at least two node planes across); `false`
    /// gives every spring the bulk stiffness and every node the bulk mass, as before. `true`
    /// on a lattice that cannot be weighted is refused with the reason.
    pub fn cell_weights(mut self, on: bool) -> Self {
        self.cell_weights = Some(on);
        self
    }

    fn turned(&self) -> bool {
        self.rotate_to.is_some()
            || matches!(&self.anisotropic, Some(Anisotropic::Orthotropic(o)) if !o.along_body_axes())
    }

    /// Springs break by the critical stretch that dissipates G_c (J/m^2).
    pub fn fracture_energy(mut self, g_c: Real) -> Self {
        self.breaking = Some(BreakRule::FractureEnergy(g_c));
        self
    }
    /// Any breaking rule.
    pub fn breaking(mut self, rule: BreakRule) -> Self {
        self.breaking = Some(rule);
        self
    }
    /// Cut the springs a crack crosses before the run.
    pub fn precrack(mut self, c: Crack) -> Self {
        self.cracks.push(c);
        self
    }
    pub fn boundary(mut self, bc: Bc) -> Self {
        self.bcs.push(bc);
        self
    }
    /// Initial velocity (m/s) of the nodes in a region.
    pub fn initial_velocity(mut self, region: Region, v: [Real; 3]) -> Self {
        self.initial.push((region, v));
        self
    }
    /// Body acceleration, e.g. gravity (m/s^2).
    pub fn body_acceleration(mut self, g: [Real; 3]) -> Self {
        self.gravity = g;
        self
    }
    pub fn end_time(mut self, t: Real) -> Self {
        self.end_time = Some(t);
        self
    }
    pub fn output_every(mut self, t: Real) -> Self {
        self.output_every = Some(t);
        self
    }
    pub fn checkpoint_every(mut self, t: Real) -> Self {
        self.checkpoint_every = Some(t);
        self
    }
    pub fn reactions_every(mut self, t: Real) -> Self {
        self.reactions_every = Some(t);
        self
    }
    /// Write intact springs as line cells.
    pub fn springs(mut self, on: bool) -> Self {
        self.springs = on;
        self
    }
    /// The point fields frames carry (all by default; `node_id` always).
    pub fn fields(mut self, fields: hooke_io::FieldSet) -> Self {
        self.fields = fields;
        self
    }
    /// Output formats: VTK and/or HDF5.
    pub fn formats(mut self, vtk: bool, hdf5: bool) -> Self {
        self.formats = (vtk, hdf5);
        self
    }
    pub fn time_step(mut self, ts: TimeStep) -> Self {
        self.time_step = ts;
        self
    }
    /// Mass-proportional damping (1/s).
    pub fn damping(mut self, c: Real) -> Self {
        self.damping = c;
        self
    }
    /// Solve quasi-statically in `steps` load steps instead of explicit dynamics.
    pub fn quasi_static(mut self, steps: usize) -> Self {
        self.quasi_static = Some(steps);
        self
    }
    /// Set the body up from parts shared by `team`: each process builds only its part of the
    /// body and holds only its piece ([`crate::Simulation::held`]; the run steps it, as
    /// [`crate::RunOptions::pieces`] does, with `team` in [`crate::RunOptions::team`]). The
    /// bits are those of the whole body's set-up. Random lattices sampled on a jittered grid
    /// only, without curved surfaces, HDF5 or the quasi-static solver (each refused with
    /// the reason). A team of one builds the whole body.
    pub fn parts(mut self, team: std::sync::Arc<dyn hooke_core::team::Team>) -> Self {
        self.parts = Some(team);
        self
    }
    /// Rigid bodies and contact (explicit runs); `None`: the lattice's default options.
    pub fn contact(mut self, spec: ContactSpec, bodies: Vec<RigidSpec>) -> Self {
        self.contact = Some((spec, bodies));
        self
    }

    /// Check everything and build the simulation.
    pub fn build(self) -> Result<Simulation, BuildError> {
        let this = self.place_inclusions()?;
        this.build_placed()
    }

    /// The inclusions' phases with their balls placed (the same on every process: one
    /// stream of the seed, in one thread).
    fn place_inclusions(mut self) -> Result<Self, BuildError> {
        let dim = self.kind.dim();
        for (i, &(p, spec)) in self.inclusions.iter().enumerate() {
            use crate::inclusions::InclusionError;
            let balls =
                crate::inclusions::place(&spec, &self.geometry, dim).map_err(|e| match &e {
                    InclusionError::Bad(key, _) => {
                        BuildError::new(format!("inclusions[{i}].{key}"), e.to_string())
                    }
                    InclusionError::Unreached { .. } => {
                        BuildError::new(format!("inclusions[{i}].fraction"), e.to_string())
                    }
                })?;
            self.phases[p].0 = Shape::from(balls);
        }
        Ok(self)
    }

    fn build_placed(self) -> Result<Simulation, BuildError> {
        if let Some(team) = self.parts.clone().filter(|t| t.size() > 1) {
            return self.build_parts(team);
        }
        let (body, k, h, weighted, random_design) = self.body()?;
        let mut state = State::new(&body);
        let (mut fracture, precracked) =
            self.fracture(&body, &mut state, k, h, &|cut| !cut, &|i| i as u64)?;
        let whole = Selector {
            select: &|r: &Region| r.select(&body),
            none: &|nodes: &[u32]| nodes.is_empty(),
            listed: &|nodes: &[u32]| nodes.to_vec(),
        };
        let (loading, regions, boundaries) =
            self.loading(&body, weighted, &mut state, &mut fracture, &whole)?;
        let contact = match &self.contact {
            None => None,
            Some(_) if self.quasi_static.is_some() => {
                return Err(BuildError::new("contact", "contact runs with the explicit solver; remove the quasi-static solver or the contact"))
            }
            Some((spec, bodies)) => Some(crate::rigid::contact(&body, spec, bodies)?),
        };
        let mut sim = self.simulation(body, state, loading, fracture, (regions, boundaries), k)?;
        sim.precracked = precracked;
        sim.contact = contact;
        sim.random_design = random_design;
        sim.cell_weighted = weighted;
        Ok(sim)
    }

    /// The simulation of a body set up (the whole body or a process's piece): what the
    /// builder gives of the solver and output, the loading checked, the set-up's arrays shed.
    fn simulation(
        &self,
        mut body: Body,
        state: State,
        loading: Loading,
        fracture: Option<Fracture>,
        (regions, boundaries): (Vec<u32>, Vec<Boundary>),
        k: Real,
    ) -> Result<Simulation, BuildError> {
        let (end_time, output_every, checkpoint_every, reactions_every) = self.times()?;
        loading
            .validate(body.nodes())
            .map_err(|e| BuildError::new("boundary", e.to_string()))?;
        let materials = self.material_infos(&body)?;
        // Stiffnesses, masses and tractions are set: what only they read goes.
        body.lattice.shed_setup();
        let options = IntegratorOptions {
            time_step: self.time_step,
            damping: self.damping,
            damage_proof: fracture.is_some(),
            ..Default::default()
        };
        Ok(Simulation {
            // A body of several materials has no one q (each node's is its material's).
            q: if body.q_node.is_some() {
                Real::NAN
            } else {
                body.q
            },
            body,
            state,
            loading,
            fracture,
            options,
            end_time,
            output_every,
            checkpoint_every,
            reactions_every,
            springs: self.springs,
            fields: self.fields,
            regions,
            boundaries,
            solver: match self.quasi_static {
                Some(steps) => crate::Solver::QuasiStatic { steps },
                None => crate::Solver::Explicit,
            },
            vtk: self.formats.0,
            hdf5: self.formats.1,
            k,
            precracked: 0,
            contact: None,
            anisotropic: self.anisotropic,
            random_design: None,
            cell_weighted: false,
            plane: self.plane,
            held: None,
            from_parts: None,
            materials,
        })
    }

    /// The lattice filled into the solid, with the material's constants and the cell weights:
    /// the body, its bulk stiffness constant (k, or kappa on random lattices), the plate
    /// thickness (1 in 3D) and whether the body is cell-weighted.
    #[allow(clippy::type_complexity)]
    fn body(&self) -> Result<(Body, Real, Real, bool, Option<Calibrated>), BuildError> {
        let (body, k, h, design) = self.unweighted_body()?;
        let (body, weighted) = self.weigh(body)?;
        Ok((body, k, h, weighted, design))
    }

    /// [`Builder::cell_weights`] applied to `body`, and whether it was.
    fn weigh(&self, body: Body) -> Result<(Body, bool), BuildError> {
        let key = "lattice.cell_weights";
        let why_not = if self.kind.is_random() {
            Some("a random lattice weights its springs and nodes by the volumes they stand for already; remove it")
        } else if self.turned() {
            Some("a lattice laid along a fibre or material axes (lattice.rotate_to, material.axes) has stepped faces, which no cell fraction describes; set cell_weights = false")
        } else if body.lattice.is_periodic() {
            Some("a periodic lattice has no free faces to weight; remove it")
        } else {
            None
        };
        match (self.cell_weights, why_not) {
            (Some(false), _) => Ok((body, false)),
            (Some(true), Some(why)) => Err(BuildError::new(key, why)),
            (None, Some(_)) => Ok((body, false)),
            (Some(true), None) => body
                .with_cell_weights()
                .map(|b| (b, true))
                .map_err(|e| BuildError::new(key, format!("{e}; set cell_weights = false"))),
            // The default: a body too thin to weight (one node plane across) keeps equal
            // weights, and `hooke check` says so.
            (None, None) => {
                let mut body = body;
                let weighted = body.weigh_by_cells().is_ok();
                Ok((body, weighted))
            }
        }
    }

    /// [`Builder::body`] before the cell weights.
    fn unweighted_body(&self) -> Result<(Body, Real, Real, Option<Calibrated>), BuildError> {
        let kind = self.kind;
        let (a, h) = self.spacing_thickness()?;
        // The turn of the lattice: along a fibre (lattice.rotate_to), or along an orthotropic
        // material's axes (material.axes), which need it.
        let axes = match &self.anisotropic {
            Some(Anisotropic::Orthotropic(o)) if !o.along_body_axes() => Some(o),
            _ => None,
        };
        let turn = match (self.rotate_to, axes) {
            (Some(_), Some(_)) => {
                return Err(BuildError::new(
                    "lattice.rotate_to",
                    "material.axes lays the lattice along the orthotropic material's axes already; remove lattice.rotate_to",
                ))
            }
            (Some(_), None) if kind != LatticeKind::Cubic => {
                return Err(BuildError::new(
                    "lattice.rotate_to",
                    "only the cubic lattice is turned (random lattices have no axes); remove it",
                ))
            }
            (Some(dir), None) => Some(
                hooke_core::anisotropy::lattice_rotation(dir)
                    .map_err(|e| BuildError::new("lattice.rotate_to", e.to_string()))?,
            ),
            (None, Some(o)) => Some(o.lattice_rotation()),
            (None, None) => None,
        };
        let lattice = match turn {
            None => fill_lattice(kind, a, h, self.random, &self.geometry)?,
            // (A random or hexagonal lattice with material.axes is refused below, with the
            // anisotropic material.)
            Some(_) if kind != LatticeKind::Cubic => {
                fill_lattice(kind, a, h, self.random, &self.geometry)?
            }
            Some(r) => crate::geometry::fill_turned_cubic(a, &r, &self.geometry)?,
        };
        let (body, k, design, held) = self.material_body(lattice)?;
        self.phases_hold(&held)?;
        Ok((body, k, h, design))
    }

    /// The material on `lattice` (the whole body's, or a process's piece's): the body, its
    /// bulk stiffness constant (k, or kappa on random lattices; NaN for an anisotropic
    /// material, whose families differ) and a random lattice's anisotropic design.
    fn material_body(
        &self,
        lattice: hooke_core::Lattice,
    ) -> Result<(Body, Real, Option<Calibrated>, Vec<bool>), BuildError> {
        let kind = self.kind;
        if self.field.is_some() && (!self.phases.is_empty() || self.anisotropic.is_some()) {
            return Err(BuildError::new(
                "material.stiffness_field",
                "a stiffness field scatters a body of one isotropic material for now; remove the phases or the anisotropic material (or the field)",
            ));
        }
        if let Some(t) = &self.anisotropic {
            if !self.phases.is_empty() {
                return Err(BuildError::new(
                    "phases",
                    "phases take isotropic materials in a body of an isotropic material for now; the body's material is anisotropic",
                ));
            }
            if self.material.is_some() {
                return Err(BuildError::new(
                    "material",
                    "give an isotropic material or an anisotropic one, not both",
                ));
            }
            if !matches!(
                kind,
                LatticeKind::Cubic | LatticeKind::Random3d | LatticeKind::Random2d
            ) {
                return Err(BuildError::new(
                    "material.kind",
                    format!(
                        "anisotropic materials are built on the cubic, random2d and random3d lattices; the {} lattice is not supported yet: use lattice.kind = \"cubic\", \"random2d\" or \"random3d\"",
                        kind.name()
                    ),
                ));
            }
            // On a random lattice the direction functions are calibrated first (about half a
            // minute on cubes of their own seeds); `hooke check` prints what they reached.
            let (body, design) = if kind.is_random() {
                let sampler = self.random.sampler;
                match t.random_design_for(kind.dim(), sampler, self.plane) {
                    Ok(cal) => {
                        let density = t.density();
                        (cal.design.body(lattice, density), Some(cal))
                    }
                    Err(e) => (Err(e), None),
                }
            } else {
                (t.body(lattice), None)
            };
            let body = body.map_err(|e| {
                let msg = e.to_string();
                // The key the message is about: the constant it names, else the material.
                let key = [
                    "youngs_plane",
                    "youngs_fibre",
                    "poisson_plane",
                    "poisson_fibre",
                    "shear_fibre",
                    "youngs_x",
                    "youngs_y",
                    "youngs_z",
                    "poisson_xy",
                    "shear_yz",
                    "shear_xz",
                    "shear_xy",
                    "density",
                ]
                .into_iter()
                .find(|k| msg.contains(k))
                .map_or(
                    match t {
                        Anisotropic::Transverse(_) => "material.fibre".to_string(),
                        Anisotropic::Orthotropic(_) if msg.contains("the plate's normal") => {
                            "material.axes".to_string()
                        }
                        Anisotropic::Orthotropic(_) => "material.kind".to_string(),
                    },
                    |k| format!("material.{k}"),
                );
                BuildError::new(key, msg)
            })?;
            if !matches!(
                self.breaking,
                None | Some(BreakRule::Stretch(_) | BreakRule::FibreStretch { .. })
            ) {
                return Err(BuildError::new(
                    "material.fracture_energy",
                    "the fracture-energy calibrations (and the energy and softening criteria) are measured for isotropic materials; give critical_stretch for a transverse one",
                ));
            }
            // No single k: the families differ (`hooke check` prints them).
            return Ok((body, Real::NAN, design, Vec::new()));
        }
        if !self.phases.is_empty() {
            let (body, held) = self.phase_body(lattice)?;
            return Ok((body, Real::NAN, None, held));
        }
        if !self.interfaces.is_empty() {
            return Err(BuildError::new(
                "interfaces[0].between",
                "an interface joins two materials of a body, and this body is of one: add                  [[phases]] (Builder::phase) or remove the interface",
            ));
        }
        let (mut body, k) = self.isotropic_body(lattice)?;
        if let Some(f) = &self.field {
            self.apply_field(&mut body, f)?;
        }
        Ok((body, k, None, Vec::new()))
    }

    /// Scale each spring by the stiffness field at its two halves, in series (see
    /// [`crate::field`]).
    fn apply_field(
        &self,
        body: &mut Body,
        f: &crate::field::StiffnessField,
    ) -> Result<(), BuildError> {
        use rayon::prelude::*;
        f.check().map_err(|(key, why)| {
            BuildError::new(format!("material.stiffness_field.{key}"), why)
        })?;
        let modes = f.modes(self.kind.dim());
        let pos = &body.lattice.pos;
        let factor: Vec<Real> = (0..body.nodes())
            .into_par_iter()
            .with_min_len(1024)
            .map(|i| modes.factor(pos.get(i)))
            .collect();
        let ends = &body.lattice.bonds.ends;
        let scaled: Vec<Real> = ends
            .par_iter()
            .zip(body.k.par_iter())
            .map(|(&[i, j], &k)| {
                k * hooke_core::phases::series(factor[i as usize], factor[j as usize])
            })
            .collect();
        body.k = scaled.into();
        Ok(())
    }

    /// Refuse a phase whose shape holds no node, or an interface between materials that no
    /// spring joins (`held`: the phases', then the interfaces' flags, over the whole body; a
    /// process building its part ors its flags with the others' first).
    fn phases_hold(&self, held: &[bool]) -> Result<(), BuildError> {
        match held.iter().position(|&h| !h) {
            Some(p) if p < self.phases.len() => Err(BuildError::new(
                self.phase_key(p),
                "the phase's shape holds no node of the body: move it or make it larger",
            )),
            Some(i) => {
                let i = i - self.phases.len();
                let [a, b] = &self.interfaces[i].between;
                Err(BuildError::new(
                    format!("interfaces[{i}].between"),
                    format!(
                        "the materials \"{a}\" and \"{b}\" never touch in this body (no spring \
                         joins a node of one to a node of the other): remove the interface or \
                         check the phases' shapes"
                    ),
                ))
            }
            None => Ok(()),
        }
    }

    /// The key of the builder's phase `p`: `inclusions[i]` for the `i`th set of inclusions,
    /// else `phases[j]` for the `j`th phase given by a shape.
    fn phase_key(&self, p: usize) -> String {
        match self.inclusions.iter().position(|&(q, _)| q == p) {
            Some(i) => format!("inclusions[{i}]"),
            None => {
                let j = p - self.inclusions.iter().filter(|&&(q, _)| q < p).count();
                format!("phases[{j}]")
            }
        }
    }

    /// The name of each phase's material: the body's, then each phase's (a node's phase in
    /// [`Body::phase`] indexes it).
    pub fn phase_names(&self) -> Vec<String> {
        std::iter::once(self.name.clone())
            .chain(self.phases.iter().map(|(_, m)| m.name.clone()))
            .collect()
    }

    /// The interface (index into the interfaces) of each pair of phases, `(P + 1)^2` entries,
    /// row-major; refused where an interface names an unknown material or one twice, or has a
    /// factor that is not positive.
    fn interface_table(&self) -> Result<Vec<Option<usize>>, BuildError> {
        let names = self.phase_names();
        let n = names.len();
        let mut table = vec![None; n * n];
        for (i, f) in self.interfaces.iter().enumerate() {
            let key = format!("interfaces[{i}].between");
            if let Some(name) = f.between.iter().find(|m| !names.contains(m)) {
                let mut known: Vec<&str> = names.iter().map(String::as_str).collect();
                known.sort_unstable();
                known.dedup();
                return Err(BuildError::new(
                    key,
                    format!(
                        "no material named \"{name}\": the body's materials are {}",
                        known.join(", ")
                    ),
                ));
            }
            if f.between[0] == f.between[1] {
                return Err(BuildError::new(
                    key,
                    "an interface joins two different materials: name two",
                ));
            }
            if !(f.stiffness.is_finite() && f.stiffness > 0.0) {
                return Err(BuildError::new(
                    format!("interfaces[{i}].stiffness_factor"),
                    format!(
                        "{}: give a positive factor (1: the two materials in series)",
                        f.stiffness
                    ),
                ));
            }
            for (a, na) in names.iter().enumerate() {
                for (b, nb) in names.iter().enumerate() {
                    let joins = (na == &f.between[0] && nb == &f.between[1])
                        || (na == &f.between[1] && nb == &f.between[0]);
                    if !joins {
                        continue;
                    }
                    if let Some(first) = table[a * n + b] {
                        if first != i {
                            return Err(BuildError::new(
                                key,
                                format!(
                                    "interfaces[{first}] joins \"{na}\" and \"{nb}\" already: \
                                     give each interface once"
                                ),
                            ));
                        }
                    }
                    table[a * n + b] = Some(i);
                }
            }
        }
        Ok(table)
    }

    /// The body of the material and its phases on `lattice` (`hooke_core::phases`): each node
    /// of the last phase whose shape holds it, else of the body's material, and each
    /// interface's springs' stiffness times its factor; and the flags
    /// [`Builder::phases_hold`] checks (each phase holds a node of `lattice`, each interface
    /// joins two).
    fn phase_body(&self, lattice: hooke_core::Lattice) -> Result<(Body, Vec<bool>), BuildError> {
        if let Some(rule) = &self.breaking {
            if !matches!(rule, BreakRule::Stretch(_) | BreakRule::FractureEnergy(_)) {
                return Err(BuildError::new(
                    "material.criterion",
                    "a body of several materials breaks by a critical stretch for now (given, \
                     or from a fracture energy; the energy and softening criteria are one \
                     material's): give critical_stretch or fracture_energy",
                ));
            }
        }
        if self.phases.len() > 254 {
            return Err(BuildError::new(
                "phases",
                format!("{} phases: give at most 254", self.phases.len()),
            ));
        }
        let table = self.interface_table()?;
        let dim = self.kind.dim();
        let tol = 1e-9 * self.spacing;
        let mut node_phase = vec![0u8; lattice.len()];
        let mut held = vec![false; self.phases.len() + self.interfaces.len()];
        for (p, (shape, _)) in self.phases.iter().enumerate() {
            for (i, np) in node_phase.iter_mut().enumerate() {
                if shape.contains(lattice.pos.get(i), tol, dim) {
                    *np = (p + 1) as u8;
                    held[p] = true;
                }
            }
        }
        let (body, _) = self.isotropic_body(lattice.clone())?;
        let mut phases =
            vec![Phase::of(body).map_err(|e| BuildError::new("material", e.to_string()))?];
        for (p, (_, m)) in self.phases.iter().enumerate() {
            let key = format!("{}.material", self.phase_key(p));
            let err = |e: hooke_core::Error| BuildError::new(key.clone(), e.to_string());
            material::check_elastic(&m.elastic).map_err(err)?;
            let body = Body::new(lattice.clone(), &m.elastic, self.plane).map_err(err)?;
            phases.push(Phase::of(body).map_err(err)?);
        }
        let mut body = hooke_core::phases::assemble(lattice, phases, &node_phase)
            .map_err(|e| BuildError::new("phases", e.to_string()))?;
        // A lattice all of one phase (a process's part may be) keeps the form of a body of
        // several materials, each node's q in its normaliser: every process's arithmetic is
        // then the same, whichever materials its part holds.
        if body.q_node.is_none() {
            let q = vec![body.q; body.nodes()];
            body = body
                .with_node_q(q)
                .map_err(|e| BuildError::new("phases", e.to_string()))?;
        }
        // The interfaces: which join two nodes, and their springs' stiffness factors.
        if !self.interfaces.is_empty() {
            let n = self.phases.len() + 1;
            let which: Vec<Option<usize>> = body
                .lattice
                .bonds
                .ends
                .iter()
                .map(|e| {
                    let [i, j] = e.map(|v| node_phase[v as usize] as usize);
                    table[i * n + j]
                })
                .collect();
            for &f in which.iter().flatten() {
                held[self.phases.len() + f] = true;
            }
            if self.interfaces.iter().any(|f| f.stiffness != 1.0) {
                let k = &mut *body.k;
                for (b, f) in which.iter().enumerate() {
                    if let Some(f) = *f {
                        k[b] *= self.interfaces[f].stiffness;
                    }
                }
            }
        }
        body.phase = Some(node_phase);
        Ok((body, held))
    }

    /// Each phase's material, for reports (empty for a body of one material).
    fn material_infos(&self, body: &Body) -> Result<Vec<crate::MaterialInfo>, BuildError> {
        let Some(base) = self.material.filter(|_| !self.phases.is_empty()) else {
            return Ok(Vec::new());
        };
        let names = self.phase_names();
        std::iter::once(base)
            .chain(self.phases.iter().map(|(_, m)| m.elastic))
            .zip(names)
            .enumerate()
            .map(|(index, (m, name))| {
                let c = material::constants_for_lattice(&body.lattice, &m, self.plane)
                    .map_err(|e| BuildError::new("phases", e.to_string()))?;
                Ok(crate::MaterialInfo {
                    index,
                    name,
                    youngs: m.youngs,
                    poisson: m.poisson,
                    density: m.density,
                    q: c.q,
                })
            })
            .collect()
    }

    /// Each spring's strength factor against the criterion's critical stretch `s_base`
    /// (`None`: all 1), from the materials' and interfaces' own strengths and the Weibull
    /// scatters. A spring inside one material breaks at that material's critical stretch (its
    /// own, or the one its fracture energy gives with its constants, else `s_base`), one
    /// between two at its interface's (from the two materials' springs in series, times the
    /// interface's stiffness factor, and their mean q), else at the weaker material's; a
    /// material's scatter multiplies its springs' (an interface's springs do not scatter).
    /// `global(i)`: node `i`'s index in the whole body (a draw follows the nodes its spring
    /// joins, not a part's numbering).
    fn strength_factors(
        &self,
        body: &Body,
        s_base: Real,
        h: Real,
        global: &dyn Fn(usize) -> u64,
    ) -> Result<Option<Vec<Real>>, BuildError> {
        let own = self
            .phases
            .iter()
            .any(|(_, m)| m.toughness.is_some() || m.weibull.is_some())
            || self.weibull.is_some()
            || self.interfaces.iter().any(|f| f.toughness.is_some());
        if !own || self.breaking.is_none() {
            return Ok(None);
        }
        let (kind, a, plane) = (self.kind, self.spacing, self.plane);
        let Some(base) = self.material else {
            return Ok(None);
        };
        let elastic: Vec<Elastic> = std::iter::once(base)
            .chain(self.phases.iter().map(|(_, m)| m.elastic))
            .collect();
        let toughness: Vec<Option<Toughness>> = std::iter::once(None)
            .chain(self.phases.iter().map(|(_, m)| m.toughness))
            .collect();
        let scatter: Vec<Option<Weibull>> = std::iter::once(self.weibull)
            .chain(self.phases.iter().map(|(_, m)| m.weibull))
            .collect();
        // A phase's bulk constants: (k, or kappa on a random lattice; q).
        let constants = |p: usize, key: &str| {
            material::constants_for_lattice(&body.lattice, &elastic[p], plane)
                .map(|c| (c.k, c.q))
                .map_err(|e| BuildError::new(key, e.to_string()))
        };
        let stretch = |t: Toughness, (k, q): (Real, Real), key: &str| {
            match t {
                Toughness::Stretch(s) => CriticalStretch::new(s),
                Toughness::Energy(g) => CriticalStretch::from_fracture_energy(kind, k, a, q, h, g),
            }
            .map(|c| c.s_c)
            .map_err(|e| BuildError::new(key, e.to_string()))
        };
        let n = elastic.len();
        let mut s_c = Vec::with_capacity(n);
        for (p, t) in toughness.iter().enumerate() {
            let key = match p {
                0 => "material".to_string(),
                p => format!("{}.material", self.phase_key(p - 1)),
            };
            s_c.push(match t {
                None => s_base,
                Some(t) => stretch(*t, constants(p, &key)?, &key)?,
            });
        }
        let table = self.interface_table()?;
        let mut pair = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                let at = table[i * n + j].map(|f| (f, &self.interfaces[f]));
                pair[i * n + j] = match at {
                    Some((
                        f,
                        Interface {
                            toughness: Some(t),
                            stiffness,
                            ..
                        },
                    )) => {
                        let key = format!("interfaces[{f}]");
                        let (ki, qi) = constants(i, &key)?;
                        let (kj, qj) = constants(j, &key)?;
                        let k = hooke_core::phases::series(ki, kj) * stiffness;
                        stretch(*t, (k, 0.5 * (qi + qj)), &key)?
                    }
                    _ => s_c[i].min(s_c[j]),
                };
            }
        }
        let phase = |v: u32| body.phase.as_ref().map_or(0, |p| p[v as usize] as usize);
        let factor = body
            .lattice
            .bonds
            .ends
            .iter()
            .map(|&[i, j]| {
                let (pi, pj) = (phase(i), phase(j));
                let s = pair[pi * n + pj] / s_base;
                match scatter[pi].filter(|_| pi == pj) {
                    Some(w) => s * w.factor(global(i as usize), global(j as usize)),
                    None => s,
                }
            })
            .collect();
        Ok(Some(factor))
    }

    /// The lattice's spacing and the plate's thickness (1 in 3D), checked.
    fn spacing_thickness(&self) -> Result<(Real, Real), BuildError> {
        let dim = self.kind.dim();
        let a = self.spacing;
        if !(a.is_finite() && a > 0.0) {
            return Err(BuildError::new(
                "lattice.spacing",
                format!("{a}: give a positive spacing in m"),
            ));
        }
        let h = match (self.thickness, dim) {
            (Some(t), 2) if t.is_finite() && t > 0.0 => t,
            (Some(t), 2) => {
                return Err(BuildError::new(
                    "lattice.thickness",
                    format!("{t}: give a positive thickness in m"),
                ))
            }
            (None, 2) => {
                return Err(BuildError::new(
                    "lattice.thickness",
                    "a 2D lattice is a plate: give its thickness in m",
                ))
            }
            (Some(_), _) => {
                return Err(BuildError::new(
                    "lattice.thickness",
                    "only 2D lattices have a thickness; remove it",
                ))
            }
            (None, _) => 1.0,
        };
        Ok((a, h))
    }

    /// The isotropic material on `lattice`: the body and its bulk stiffness constant (k, or
    /// kappa on random lattices).
    fn isotropic_body(&self, lattice: hooke_core::Lattice) -> Result<(Body, Real), BuildError> {
        let kind = self.kind;
        let elastic = self.material.ok_or_else(|| {
            BuildError::new(
                "material",
                "give the material: Young's modulus, Poisson's ratio and density",
            )
        })?;
        let mat = |e: hooke_core::Error| {
            let msg = e.to_string();
            let key = if msg.contains("Poisson") {
                "material.poisson"
            } else if msg.contains("Young") {
                "material.youngs"
            } else {
                "material.density"
            };
            BuildError::new(key, msg)
        };
        material::check_elastic(&elastic).map_err(mat)?;
        // What the lattice cannot reach is a matter of nu.
        let nu = |e: hooke_core::Error| BuildError::new("material.poisson", e.to_string());
        let body = Body::new(lattice, &elastic, self.plane).map_err(nu)?;
        let k = if kind.is_random() {
            material::constants_for_lattice(&body.lattice, &elastic, self.plane)
                .map_err(nu)?
                .k
        } else {
            // The rule's value where the springs follow one (the list is then never filled).
            body.k.uniform_value().unwrap_or_else(|| body.k[0])
        };
        Ok((body, k))
    }

    /// The breaking rule's criterion, calibrated for this lattice (`q` its dispersion, `k` its
    /// stiffness, `h` a plate's thickness); none without a rule.
    fn criterion(
        &self,
        q: Real,
        k: Real,
        h: Real,
    ) -> Result<Option<Box<dyn Criterion>>, BuildError> {
        let (kind, a) = (self.kind, self.spacing);
        let fr = |key: &'static str| {
            move |e: hooke_fracture::FractureError| BuildError::new(key, e.to_string())
        };
        Ok(match self.breaking {
            None => None,
            Some(BreakRule::FractureEnergy(g)) => Some(Box::new(
                CriticalStretch::from_fracture_energy(kind, k, a, q, h, g)
                    .map_err(fr("material.fracture_energy"))?,
            )),
            Some(BreakRule::Stretch(s)) => Some(Box::new(
                CriticalStretch::new(s).map_err(fr("material.critical_stretch"))?,
            )),
            Some(BreakRule::FibreStretch { across, along }) => {
                let Some(Anisotropic::Transverse(t)) = &self.anisotropic else {
                    return Err(BuildError::new(
                        "material.critical_stretch_fibre",
                        "a critical stretch along the fibre needs a fibre: kind = \"transverse\" (or remove it)",
                    ));
                };
                Some(Box::new(
                    FibreStretch::new(across, along, t.fibre)
                        .map_err(fr("material.critical_stretch_fibre"))?,
                ))
            }
            Some(BreakRule::SpringEnergy(_) | BreakRule::SpringEnergyFromStretch(_))
                if kind.is_random() =>
            {
                return Err(BuildError::new("material.criterion", "the energy criterion is calibrated on the hex and cubic lattices (a random lattice's springs differ in stiffness); use the stretch criterion here"))
            }
            Some(BreakRule::SpringEnergy(g)) => {
                // The stretch calibration validates G_c first (its errors name the key).
                CriticalStretch::from_fracture_energy(kind, k, a, q, h, g)
                    .map_err(fr("material.fracture_energy"))?;
                Some(Box::new(
                    SpringEnergy::from_fracture_energy(kind, k, a, q, h, g)
                        .map_err(fr("material.criterion"))?,
                ))
            }
            Some(BreakRule::SpringEnergyFromStretch(s)) => {
                let c = CriticalStretch::new(s).map_err(fr("material.critical_stretch"))?;
                Some(Box::new(
                    SpringEnergy::matching(c.s_c, k, q, a).map_err(fr("material.criterion"))?,
                ))
            }
            Some(BreakRule::Softening {
                fracture_energy: g,
                strength,
                shape,
            }) => {
                // The stretch calibration validates G_f first (its errors name the key).
                CriticalStretch::from_fracture_energy(kind, k, a, q, h, g)
                    .map_err(fr("material.fracture_energy"))?;
                let e = self.material.map_or(Real::NAN, |m| m.youngs);
                let (f_t, key) = match strength {
                    Strength::Tensile(f) => (f, "material.tensile_strength"),
                    Strength::CharacteristicLength(l) if l.is_finite() && l > 0.0 => {
                        ((e * g / l).sqrt(), "material.characteristic_length")
                    }
                    Strength::CharacteristicLength(l) => {
                        return Err(BuildError::new(
                            "material.characteristic_length",
                            format!("{l} is not a positive length (m)"),
                        ))
                    }
                };
                Some(Box::new(
                    Softening::from_fracture_energy(kind, k, a, q, h, g, e, f_t, shape)
                        .map_err(fr(key))?,
                ))
            }
            Some(BreakRule::SofteningStretch { peak, last, shape }) => Some(Box::new(
                Softening::new(peak, last, shape).map_err(fr("material.final_stretch"))?,
            )),
        })
    }

    /// The breaking rule and the pre-cracks: the fracture state and the springs cut.
    fn fracture(
        &self,
        body: &Body,
        state: &mut State,
        k: Real,
        h: Real,
        cuts_nothing: &dyn Fn(bool) -> bool,
        global: &dyn Fn(usize) -> u64,
    ) -> Result<(Option<Fracture>, usize), BuildError> {
        // A body of several materials: the criterion is its own material's (phase 0), and
        // each spring's strength factor says how its material or interface differs.
        let (k, q) = match (!self.phases.is_empty(), self.material) {
            (true, Some(m)) => {
                let c = material::constants_for_lattice(&body.lattice, &m, self.plane)
                    .map_err(|e| BuildError::new("material", e.to_string()))?;
                (c.k, c.q)
            }
            _ => (k, body.q),
        };
        let criterion = self.criterion(q, k, h)?;
        let mut fracture = criterion.map(|c| Fracture::new(body, c));
        if let Some(f) = fracture.take() {
            let s_base = f.criterion().screen().unwrap_or(1.0);
            fracture = Some(match self.strength_factors(body, s_base, h, global)? {
                None => f,
                Some(factor) => f
                    .with_strength(body, factor)
                    .map_err(|e| BuildError::new("material", e.to_string()))?,
            });
        }
        let mut precracked = 0;
        for (n, c) in self.cracks.iter().enumerate() {
            let f = fracture.get_or_insert_with(|| {
                Fracture::new(
                    body,
                    Box::new(CriticalStretch {
                        s_c: Real::INFINITY,
                    }),
                )
            });
            precracked += f
                .precrack_where(body, state, std::slice::from_ref(c), cuts_nothing)
                .map_err(|e| {
                    BuildError::new(
                        format!("precrack[{n}]"),
                        e.to_string().replace("pre-crack 0: ", ""),
                    )
                })?;
        }
        Ok((fracture, precracked))
    }

    /// Boundary conditions and initial velocities: the loading, each node's region id and the
    /// regions whose reactions are recorded. No-fail regions are marked in `fracture`.
    fn loading(
        &self,
        body: &Body,
        weighted: bool,
        state: &mut State,
        fracture: &mut Option<Fracture>,
        pick: &Selector,
    ) -> Result<(Loading, Vec<u32>, Vec<Boundary>), BuildError> {
        let mut loading = Loading {
            body_acceleration: Vector::from(self.gravity),
            ..Default::default()
        };
        let mut regions = vec![0u32; body.nodes()];
        let mut boundaries = Vec::new();
        for (n, bc) in self.bcs.iter().enumerate() {
            let key = format!("boundary[{n}]");
            let nodes = (pick.select)(&bc.region);
            if (pick.none)(&nodes) {
                return Err(BuildError::new(
                    format!("{key}.region"),
                    "the region selects no node: check it against the geometry (and --scale)",
                ));
            }
            if bc.fixed.is_empty()
                && bc.motions.is_empty()
                && bc.tractions.is_empty()
                && !bc.no_fail
            {
                return Err(BuildError::new(key, "the boundary does nothing: give fixed, velocity, displacement, traction or no_fail"));
            }
            boundaries.push(Boundary {
                name: bc.name.clone().unwrap_or_else(|| key.clone()),
                nodes: (pick.listed)(&nodes),
            });
            for &i in &nodes {
                regions[i as usize] = n as u32 + 1;
            }
            self.conditions(&key, bc, &nodes, (body, weighted), &mut loading)?;
            if bc.no_fail {
                if let Some(f) = fracture.as_mut() {
                    f.set_no_fail(&nodes);
                }
            }
        }
        self.initial_velocities(state, pick)?;
        Ok((loading, regions, boundaries))
    }

    /// A boundary's fixed axes, prescribed motions and tractions on its `nodes`, into
    /// `loading` (`weighted`: the body's nodes stand for their cells' shares of a face).
    fn conditions(
        &self,
        key: &str,
        bc: &Bc,
        nodes: &[u32],
        (body, weighted): (&Body, bool),
        loading: &mut Loading,
    ) -> Result<(), BuildError> {
        let dim = self.kind.dim();
        // One motion per axis: a node held and moved along the same axis would be set by two
        // rules (its displacement by one, its velocity by the other), and the ledger's
        // boundary work would follow neither.
        let axes = bc.fixed.iter().chain(bc.motions.iter().map(|(a, _)| a));
        let mut seen = [false; 3];
        for &axis in axes {
            if axis < 3 && std::mem::replace(&mut seen[axis], true) {
                return Err(BuildError::new(
                    key,
                    format!(
                        "axis {} is prescribed twice (fixed, velocity or displacement): keep one",
                        ["x", "y", "z"][axis]
                    ),
                ));
            }
        }
        for &axis in &bc.fixed {
            check_axis(dim, axis, format!("{key}.fixed"))?;
            loading.prescribed.push(Prescribed {
                nodes: nodes.to_vec(),
                axis,
                motion: Motion::Fixed,
            });
        }
        for (j, (axis, m)) in bc.motions.iter().enumerate() {
            check_axis(dim, *axis, format!("{key}.motion[{j}]"))?;
            if let Motion::Velocity(f) | Motion::Displacement(f) = m {
                f.validate()
                    .map_err(|e| BuildError::new(format!("{key}.motion[{j}]"), e.to_string()))?;
            }
            loading.prescribed.push(Prescribed {
                nodes: nodes.to_vec(),
                axis: *axis,
                motion: m.clone(),
            });
        }
        for (j, (t, normal, scale)) in bc.tractions.iter().enumerate() {
            check_axis(dim, *normal, format!("{key}.traction[{j}].normal"))?;
            if self.turned() {
                // A turned lattice's faces are steps: no node stands for a known share of
                // a face's area, so a traction would be spread wrongly.
                return Err(BuildError::new(
                    format!("{key}.traction[{j}]"),
                    "a traction needs faces on node planes, and a lattice laid along a fibre or material axes (lattice.rotate_to, material.axes) has stepped faces; load it by a prescribed velocity or displacement of a box region instead",
                ));
            }
            loading.loads.extend(traction_loads(
                body,
                nodes,
                *t,
                *normal,
                scale.clone(),
                weighted,
            ));
        }
        Ok(())
    }

    /// The initial velocities of their regions' nodes.
    fn initial_velocities(&self, state: &mut State, pick: &Selector) -> Result<(), BuildError> {
        for (n, (region, v)) in self.initial.iter().enumerate() {
            let nodes = (pick.select)(region);
            if (pick.none)(&nodes) {
                return Err(BuildError::new(
                    format!("initial[{n}].region"),
                    "the region selects no node",
                ));
            }
            for i in nodes {
                state.v.set(i as usize, Vector::from(*v));
            }
        }
        Ok(())
    }

    /// End time and the output intervals (s).
    fn times(&self) -> Result<(Real, Real, Real, Option<Real>), BuildError> {
        let end_time = match self.end_time {
            Some(t) if t.is_finite() && t > 0.0 => t,
            Some(t) => {
                return Err(BuildError::new(
                    "solver.end_time",
                    format!("{t}: give a positive time in s"),
                ))
            }
            None => {
                return Err(BuildError::new(
                    "solver.end_time",
                    "give the simulated time to reach (s)",
                ))
            }
        };
        let positive = |v: Option<Real>, key: &str, default: Real| match v {
            Some(x) if x.is_finite() && x > 0.0 => Ok(x),
            Some(x) => Err(BuildError::new(
                key,
                format!("{x}: give a positive time in s"),
            )),
            None => Ok(default),
        };
        let output_every = positive(self.output_every, "output.every", end_time / 20.0)?;
        let checkpoint_every = positive(
            self.checkpoint_every,
            "output.checkpoint_every",
            end_time / 4.0,
        )?;
        let reactions_every = match self.reactions_every {
            Some(x) => Some(positive(Some(x), "output.reactions_every", x)?),
            None => None,
        };
        if !(self.damping.is_finite() && self.damping >= 0.0) {
            return Err(BuildError::new(
                "solver.damping",
                "give zero or a positive coefficient in 1/s",
            ));
        }
        if let Some(s) = self.quasi_static {
            if !(1..=1_000_000).contains(&s) {
                return Err(BuildError::new(
                    "solver.steps",
                    "give 1 to 1 000 000 load steps",
                ));
            }
        }
        if !self.formats.0 && !self.formats.1 {
            return Err(BuildError::new(
                "output.format",
                "give at least one format: VTK, HDF5 or both",
            ));
        }
        Ok((end_time, output_every, checkpoint_every, reactions_every))
    }
}

/// Refuse an axis the body has not: `axis` of a `dim`-dimensional body, named by `key`.
fn check_axis(dim: usize, axis: usize, key: String) -> Result<(), BuildError> {
    if axis < dim {
        Ok(())
    } else {
        Err(BuildError::new(
            key,
            format!(
                "axis {axis} does not exist in a {dim}D body; use 0 (x), 1 (y){}",
                if dim == 3 { " or 2 (z)" } else { "" }
            ),
        ))
    }
}
