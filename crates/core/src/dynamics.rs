//! Explicit dynamics: velocity Verlet in leapfrog form with lumped node masses, boundary
//! conditions, loads, mass-proportional damping and an energy ledger.
//!
//! Between steps `state.v` holds the half-step velocity `v(t - dt/2)`; [`Integrator::full_velocity`]
//! gives `v(t)` for output. One step (`t -> t + dt`):
//!
//! 1. sweep 1: pools `p_n` at `u(t)`;
//! 2. sweep 2: forces at `u(t)`, kick `v(t+dt/2) = ((1 - c dt/2) v(t-dt/2) + dt a(t)) / (1 + c dt/2)`
//!    and drift `u(t+dt) = u(t) + dt v(t+dt/2)` (both fused, [`crate::kernel`]);
//! 3. the sparse parts: external loads on their nodes, prescribed motion overriding its DOFs,
//!    and the work both do.
//!
//! **Energy ledger.** Leapfrog conserves a discrete energy; works are booked in the matching
//! midpoint form, `W += F(t) . (v(t-dt/2) + v(t+dt/2)) dt/2`. The balance
//!
//! ```text
//! K + U  =  K0 + U0 + W_external + W_boundary + W_body - D_damping - E_released
//! ```
//!
//! then holds to O(dt^2), without secular drift. `W_boundary` is the work of the reactions at
//! prescribed DOFs, `R = m (v+ - v-)/dt - f - F_ext`. `E_released` is the energy that broken
//! springs took with them (fracture).

use rayon::prelude::*;

use crate::body::Body;
use crate::error::{Error, Result};
use crate::kernel::{Kernel, StepParams};
use crate::law::{self, Energy};
use crate::loading::{Loading, Motion};
use crate::math::{Coords, Real, Vector};
use crate::stability::{self, StableStep, DEFAULT_SAFETY};
use crate::state::State;
use crate::team::Team;

mod breaks;
mod partition;

pub use breaks::{commit_alone, node_dispersive_energy, BreakReport, Breaker, Candidates};
#[cfg(test)]
pub(crate) use partition::special_nodes;
use partition::{Partition, Plan, Pools};

/// How the time step is chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TimeStep {
    /// `safety * 2 / sqrt(lambda_max)` from the Lanczos estimate.
    Auto { safety: Real },
    /// A given step (s); refused above the stable limit unless `force`.
    Fixed { dt: Real, force: bool },
}

impl IntegratorOptions {
    /// Put `kernel` on the vector path these options ask for (portable, AVX2, or the best the
    /// processor has).
    fn choose_lanes(&self, kernel: &mut Kernel) {
        if self.portable {
            kernel.set_simd(false);
        } else if self.avx2 {
            kernel.use_avx2();
        }
    }
}

impl Default for TimeStep {
    fn default() -> Self {
        TimeStep::Auto {
            safety: DEFAULT_SAFETY,
        }
    }
}

/// Options of the integrator. Defaults: automatic dt with safety 0.8, no damping.
#[derive(Clone, Debug, Default)]
pub struct IntegratorOptions {
    pub time_step: TimeStep,
    /// Mass-proportional damping coefficient c (1/s): force `-c m v` on every node.
    pub damping: Real,
    /// Use the portable kernel even where a vector kernel exists (for comparisons).
    pub portable: bool,
    /// Use the CSR kernel even for box lattices (reference path).
    pub force_csr: bool,
    /// Take the AVX2 path where the processor has AVX-512 too (to test and measure that path;
    /// ignored with `portable` or without AVX2).
    pub avx2: bool,
    /// Choose the step from a bound that holds for every pattern of broken springs,
    /// `lambda_max <= (1 + 2 max(q, 0)) lambda_max(plain law, current body)` (see
    /// [`crate::stability`]), instead of from the current body alone. Runs with fracture need it:
    /// with q > 0, nodes on new free surfaces stiffen and the intact body's step can become
    /// unstable.
    pub damage_proof: bool,
}

/// Work and dissipation accumulated since the start (J).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Ledger {
    pub external_work: Real,
    pub boundary_work: Real,
    pub body_work: Real,
    pub dissipated: Real,
    pub released: Real,
}

/// The energy balance at one instant (J).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EnergyBalance {
    pub kinetic: Real,
    pub strain: Energy,
    pub ledger: Ledger,
    /// `K0 + U0` at the start.
    pub initial: Real,
    /// `K + U - (K0 + U0 + W_ext + W_bc + W_body - D - E_released)`.
    pub error: Real,
    /// `|error|` over the largest energy figure in the balance.
    pub relative_error: Real,
}

/// The integrator's part of a checkpoint (see [`Integrator::checkpoint`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IntegratorCheckpoint {
    pub dt: Real,
    pub ledger: Ledger,
    pub initial: Real,
    pub initial_power: Real,
    pub stable: StableStep,
}

#[derive(Clone, Debug)]
struct PrescribedDof {
    node: usize,
    axis: usize,
    motion: usize,
    /// The external loads on its node: `Integrator::dof_loads[loads]` (indices into `loaded`,
    /// in its order), found once at set-up rather than by a search over the loaded nodes per
    /// DOF and step.
    loads: std::ops::Range<usize>,
}

/// Forces from outside the lattice that depend on where its nodes are: contact with rigid
/// bodies, contact between fragments (`hooke-contact`).
///
/// They are evaluated at the positions of the step's start, like the internal forces, and
/// applied as an extra kick, like external loads, so the leapfrog stays symplectic for
/// conservative interactions and their work enters the ledger as external work. Whatever the
/// interaction moves itself (rigid bodies) it advances here by one step, with the reactions of
/// the same forces, so the total momentum is conserved to round-off.
pub trait Interaction {
    /// Push `(node, force)` for the nodes it acts on (each node once) into `out`, which the
    /// caller has cleared: forces at time `state.time` from the displacements `state.u`; the
    /// half-step velocities `state.v` are `v(t - dt/2)`. Must not allocate in steady state and
    /// must give the same result for any thread count.
    fn forces(&mut self, body: &Body, state: &State, dt: Real, out: &mut Vec<(u32, [Real; 3])>);

    /// The nodes whose displacements and velocities the next [`Interaction::forces`] reads, for
    /// a run shared between processes, which then makes only those current (see
    /// [`crate::team`]). Called before every `forces`, by every process alike (it may hold a
    /// collective operation of `team`, the processes' owned node ranges given). The default
    /// reads every node.
    fn reads(
        &mut self,
        _body: &Body,
        _state: &State,
        _nodes: &[std::ops::Range<usize>],
    ) -> Reads<'_> {
        Reads::All
    }
}

/// What an [`Interaction`]'s next forces read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reads<'a> {
    /// Any node.
    All,
    /// These nodes only (ascending, each once).
    Nodes(&'a [u32]),
}

/// The explicit integrator for one body.
#[derive(Debug)]
pub struct Integrator {
    /// The time step (s), fixed for the run ([`Integrator::dt`]).
    dt: Real,
    damping: Real,
    kernel: Kernel,
    stable: StableStep,
    loading: Loading,
    motions: Vec<Motion>,
    dofs: Vec<PrescribedDof>,
    /// Nodes carrying external loads, with the load index.
    loaded: Vec<(usize, usize)>,
    /// Entries of `loaded` on each prescribed DOF's node (see `PrescribedDof::loads`).
    dof_loads: Vec<usize>,
    /// Whether each entry of `loaded` is the first for its node (set up once: a search per
    /// entry in the step was quadratic in the loaded nodes).
    first_load: Vec<bool>,
    inv_mass: Vec<Real>,
    u_next: Coords,
    /// The frames' per-spring arrays, kept from frame to frame ([`law::FrameScratch`]).
    frame_scratch: law::FrameScratch,
    ledger: Ledger,
    initial: Real,
    /// Power of the non-conservative forces at the start (see [`Integrator::energy`]).
    initial_power: Real,
    /// Scratch for the sparse bookkeeping (no allocation per step).
    v_before: Vec<[Real; 3]>,
    f_before: Vec<[Real; 3]>,
    /// The prescribed DOFs' displacements before a step that drifts in place.
    u_before: Vec<Real>,
    v_kernel: Vec<[Real; 3]>,
    partials: Vec<crate::kernel::SweepSums>,
    /// Scratch for interaction forces and the velocities of their nodes before the sweep.
    contact: Vec<(u32, [Real; 3])>,
    v_contact: Vec<[Real; 3]>,
    /// On a piece: this rank's contact pushes' work terms, three per push and axis.
    contact_terms: Vec<Real>,
    /// `State::breaks` when the kernel's spring masks last matched the state.
    synced: u64,
    /// Springs broken through [`Integrator::break_spring`] since the step began.
    killed: Vec<u32>,
    /// What committing a breaker's decisions keeps between rounds.
    breaks: breaks::BreakScratch,
    /// How the work is split between processes (alone, or this one's share of a team's).
    partition: Partition,
    /// A plate on which nothing acts along z (see [`Integrator::is_plane`]): its z components
    /// stay the exact zeros they start as, so sweep 2 and the exchange between ranks leave them
    /// alone.
    plane: bool,
}

/// What an instability's error suggests.
const UNSTABLE_HINT: &str =
    "reduce the time step (or its safety factor), or check loads and boundary conditions";

/// Book one contact push's work on one axis: `[external, body force, damping]`.
pub(super) fn book_contact(l: &mut Ledger, [external, body, dissipated]: [Real; 3]) {
    l.external_work += external;
    l.body_work += body;
    l.dissipated += dissipated;
}

/// Where a step's new displacements are: the integrator's second buffer, or `state.u` for a
/// kernel that drifts in place ([`Kernel::drifts_in_place`]).
#[inline]
fn new_displacements<'a>(
    u_next: &'a mut Coords,
    u: &'a mut Coords,
    in_place: bool,
) -> &'a mut Coords {
    if in_place {
        u
    } else {
        u_next
    }
}

/// The stable step of the integrator's options: the estimate with `kernel`, or with its plain
/// copy times `1 + 2 max(q, 0)` (`q_bound`: over every node of the body, `Body::q_bound`, also
/// where this process holds only its piece) for the damage-proof step (that bounds the dispersive law's
/// lambda for the intact body as for any pattern of broken springs, stability.rs, so estimating
/// the dispersive one too would only cost a second Lanczos run). `scratch` is the estimate's
/// drift scratch and unit masses ([`stability::estimate_using`]).
fn estimate(
    body: &Body,
    state: &mut State,
    kernel: &Kernel,
    opts: &IntegratorOptions,
    scratch: (&mut Coords, &mut Vec<Real>),
    (split, q_bound): (Option<&mut stability::Split>, Real),
) -> StableStep {
    let (u_next, ones) = scratch;
    if opts.damage_proof {
        let plain =
            stability::estimate_using(body, state, &kernel.plain(), 40, 1e-3, u_next, ones, split);
        let lambda = (1.0 + 2.0 * q_bound) * plain.lambda_max;
        StableStep {
            lambda_max: lambda,
            dt_critical: 2.0 / lambda.sqrt(),
            ..plain
        }
    } else {
        stability::estimate_using(body, state, kernel, 40, 1e-3, u_next, ones, split)
    }
}

/// The step the options ask for, given the stable step: the safety factor times the critical
/// step, or the fixed step, refused above the critical one unless forced.
fn step_size(opts: &IntegratorOptions, stable: &StableStep) -> Result<Real> {
    match opts.time_step {
        TimeStep::Auto { safety } => {
            if !(safety > 0.0 && safety <= 1.0) {
                return Err(Error::OutOfRange {
                    what: "time-step safety factor",
                    value: safety,
                    why: "give 0 < safety <= 1 (default 0.8)".into(),
                });
            }
            Ok(safety * stable.dt_critical)
        }
        TimeStep::Fixed { dt, force } => {
            if !(dt.is_finite() && dt > 0.0) {
                return Err(Error::OutOfRange {
                    what: "time step dt (s)",
                    value: dt,
                    why: "it must be positive".into(),
                });
            }
            if dt > stable.dt_critical && !force {
                return Err(Error::TimeStepTooLarge {
                    dt,
                    limit: stable.dt_critical,
                    critical: stable.dt_critical,
                    safety: 1.0,
                });
            }
            Ok(dt)
        }
    }
}

impl Integrator {
    /// The time step (s).
    pub fn dt(&self) -> Real {
        self.dt
    }

    /// The mass-proportional damping coefficient c (1/s): a force `-c m v` on every node.
    pub fn damping(&self) -> Real {
        self.damping
    }

    /// The kernel that sweeps the body (its name, its memory; see [`Kernel`]).
    pub fn kernel(&self) -> &Kernel {
        &self.kernel
    }

    /// The stable step and the estimate behind it.
    pub fn stable(&self) -> &StableStep {
        &self.stable
    }

    /// Take the AVX2 vector path even where AVX-512 is there too (to test and measure it);
    /// false where the kernel has no such path or the processor lacks AVX2.
    pub fn use_avx2(&mut self) -> bool {
        self.kernel.use_avx2()
    }

    /// The integrator's heap memory by part, its kernel's included (see
    /// [`crate::memory::Footprint`]).
    pub fn footprint(&self) -> crate::memory::Footprint {
        use crate::memory::bytes;
        let mut parts = vec![
            ("inverse masses", bytes(&self.inv_mass)),
            ("next displacements", self.u_next.heap_bytes()),
            ("frame scratch", self.frame_scratch.bytes()),
            (
                "step bookkeeping",
                bytes(&self.motions)
                    + bytes(&self.dofs)
                    + bytes(&self.loaded)
                    + bytes(&self.dof_loads)
                    + bytes(&self.first_load)
                    + bytes(&self.v_before)
                    + bytes(&self.f_before)
                    + bytes(&self.v_kernel)
                    + bytes(&self.partials)
                    + bytes(&self.contact)
                    + bytes(&self.v_contact)
                    + bytes(&self.contact_terms)
                    + bytes(&self.killed),
            ),
        ];
        parts.extend(self.kernel.footprint());
        parts
    }

    /// Prepare a run: validate the loading, estimate the stable step, apply the prescribed
    /// motion at `state.time`, and turn the full-step velocity in `state.v` into the half-step
    /// velocity the leapfrog needs.
    pub fn new(
        body: &Body,
        state: &mut State,
        loading: Loading,
        opts: &IntegratorOptions,
    ) -> Result<Self> {
        Self::new_shared(body, state, loading, opts, None)
    }

    /// [`Integrator::new`] for a member of `team` (every member calls it with the same body
    /// and state): the stable-step estimate's force sweeps and vector passes are shared as a
    /// step's are ([`stability::Split`]; the same step, bit for bit, as one process finds),
    /// and the integrator is then distributed ([`Integrator::distribute`]). `None` or a team
    /// of one: [`Integrator::new`].
    pub fn new_shared(
        body: &Body,
        state: &mut State,
        loading: Loading,
        opts: &IntegratorOptions,
        team: Option<std::sync::Arc<dyn Team>>,
    ) -> Result<Self> {
        body.validate()?;
        loading.validate(body.nodes())?;
        if !(opts.damping.is_finite() && opts.damping >= 0.0) {
            return Err(Error::OutOfRange {
                what: "damping coefficient c (1/s)",
                value: opts.damping,
                why: "it must be zero or positive".into(),
            });
        }
        // The run's split, found once: the estimate trades its sweeps' halo as the steps will.
        let plan = Plan::new(body, &loading, team);
        let mut kernel = if opts.force_csr {
            Kernel::Csr { plain: false }
        } else {
            Kernel::for_body_in(body, state, plan.swept())
        };
        opts.choose_lanes(&mut kernel);
        // The damage-proof step needs only the plain law's estimate: (1 + 2 max(q, 0)) times
        // its lambda bounds the dispersive law's lambda for the intact body as for any pattern
        // of broken springs (stability.rs), so estimating that one too would only cost a second
        // Lanczos run (as many force sweeps as 20 steps) at set-up.
        // The estimate's drift scratch is the integrator's own, cleared after it (a plate's
        // drift leaves z alone, so z must start at zero).
        let mut u_next = stability::drift_scratch(body, &kernel);
        // The estimate's unit masses become the inverse masses afterwards (one array fewer to
        // first-touch).
        let mut inv_mass = Vec::new();
        let mut split = plan.split();
        let stable = estimate(
            body,
            state,
            &kernel,
            opts,
            (&mut u_next, &mut inv_mass),
            (split.as_mut(), body.q_bound()),
        );
        drop(split);
        // The steps of a kernel that drifts in place write the new displacements over the old
        // (the estimate's drifts did too): it has no scratch.
        u_next.fill_zero();
        inv_mass
            .par_iter_mut()
            .with_min_len(1 << 14)
            .zip(&body.mass)
            .for_each(|(x, &m)| *x = 1.0 / m);
        let dt = step_size(opts, &stable)?;
        let mut it = Self::assemble(body, loading, opts, kernel, dt, stable, (u_next, inv_mass));
        it.synced = state.breaks();
        it.plane &= Self::flat(state);
        // The CSR kernel's scratch is sized here, so that no step allocates (the pools it also
        // computes are recomputed below).
        if matches!(it.kernel, Kernel::Csr { .. } | Kernel::Rows(_)) {
            it.kernel.pools(body, state);
        }
        // Prescribed positions and velocities at the start.
        it.prescribe_start(state);
        // At the rest configuration every extension is zero, so the pools, the forces and the
        // strain energy are zero exactly: skip the reference law's passes over a large body.
        let strain = if state.u.as_flat().iter().all(|&x| x == 0.0) {
            state.f.fill_zero();
            state.pool.fill(0.0);
            0.0
        } else {
            law::update_forces(body, state);
            law::energy(body, &state.u, state.springs(body), &state.norm).total()
        };
        it.initial = kinetic(body, &state.v) + strain;
        let v0 = state.v.clone();
        it.initial_power = it.power(body, state, &v0);
        it.back_half_step(body, state);
        plan.distribute(&mut it, body);
        Ok(it)
    }

    /// Set the prescribed DOFs' displacements and velocities at `state.time` (the start).
    fn prescribe_start(&self, state: &mut State) {
        let t = state.time;
        for d in &self.dofs {
            let (u, v) = self.prescribed_at(d, state.u.comp(d.axis)[d.node], t);
            state.u.comp_mut(d.axis)[d.node] = u;
            state.v.comp_mut(d.axis)[d.node] = v;
        }
    }

    /// Turn the full-step velocity at `state.time` into the half-step one the leapfrog needs:
    /// `v(t - dt/2) = v(t) - dt/2 a(t)` for free DOFs (prescribed ones take their own).
    fn back_half_step(&self, body: &Body, state: &mut State) {
        let (t, dt) = (state.time, self.dt);
        let mut a = self.acceleration(body, state);
        for d in &self.dofs {
            a.comp_mut(d.axis)[d.node] = 0.0;
        }
        for d in &self.dofs {
            let (_, v) = self.prescribed_at(d, state.u.comp(d.axis)[d.node], t - 0.5 * dt);
            state.v.comp_mut(d.axis)[d.node] = v;
        }
        state.v.axpy(-0.5 * dt, &a);
    }

    /// The parts shared by [`Integrator::new`] and [`Integrator::resume`].
    fn assemble(
        body: &Body,
        loading: Loading,
        opts: &IntegratorOptions,
        kernel: Kernel,
        dt: Real,
        stable: StableStep,
        (u_next, inv_mass): (Coords, Vec<Real>),
    ) -> Self {
        let mut motions = Vec::new();
        let mut dofs = Vec::new();
        for p in &loading.prescribed {
            motions.push(p.motion.clone());
            for &i in &p.nodes {
                dofs.push(PrescribedDof {
                    node: i as usize,
                    axis: p.axis,
                    motion: motions.len() - 1,
                    loads: 0..0,
                });
            }
        }
        let loaded: Vec<(usize, usize)> = loading
            .loads
            .iter()
            .enumerate()
            .flat_map(|(li, l)| l.nodes.iter().map(move |&i| (i as usize, li)))
            .collect();
        let mut on_node: std::collections::HashMap<usize, Vec<usize>> = Default::default();
        for (k, &(i, _)) in loaded.iter().enumerate() {
            on_node.entry(i).or_default().push(k);
        }
        let mut dof_loads = Vec::new();
        for d in &mut dofs {
            let start = dof_loads.len();
            dof_loads.extend(on_node.get(&d.node).into_iter().flatten());
            d.loads = start..dof_loads.len();
        }
        let sparse = dofs.len() + loaded.len();
        let plane = body.lattice.dim() == 2
            && loading.body_acceleration.z == 0.0
            && loading.loads.iter().all(|l| l.force.z == 0.0)
            && loading
                .prescribed
                .iter()
                .all(|p| p.axis != 2 || matches!(p.motion, Motion::Fixed));
        let mut seen = std::collections::HashSet::new();
        let first_load = loaded.iter().map(|&(i, _)| seen.insert(i)).collect();
        Integrator {
            dt,
            damping: opts.damping,
            kernel,
            stable,
            loading,
            motions,
            dofs,
            loaded,
            dof_loads,
            first_load,
            inv_mass,
            u_next,
            frame_scratch: Default::default(),
            ledger: Ledger::default(),
            initial: 0.0,
            initial_power: 0.0,
            v_before: Vec::with_capacity(sparse),
            f_before: Vec::with_capacity(sparse),
            u_before: Vec::with_capacity(sparse),
            v_kernel: Vec::with_capacity(sparse),
            partials: vec![Default::default(); crate::kernel::partials_len(body.nodes())],
            partition: Partition::Alone,
            plane,
            contact: Vec::new(),
            v_contact: Vec::new(),
            contact_terms: Vec::new(),
            synced: 0,
            killed: Vec::new(),
            breaks: Default::default(),
        }
    }

    /// What a checkpoint must keep of the integrator to continue a run bit for bit (the rest
    /// is the [`State`], whose `v` holds the half-step velocities, and the loading).
    /// On a piece, every rank's is the same (its state is the piece's).
    pub fn checkpoint(&self) -> IntegratorCheckpoint {
        IntegratorCheckpoint {
            dt: self.dt,
            ledger: self.ledger,
            initial: self.initial,
            initial_power: self.initial_power,
            stable: self.stable,
        }
    }

    /// Continue a run from a checkpoint: `state` as it was saved (half-step velocities, broken
    /// springs, time and step), the same body, loading and options. Nothing is re-estimated or
    /// converted, so the continued run is bit-identical to an uninterrupted one.
    pub fn resume(
        body: &Body,
        state: &State,
        loading: Loading,
        opts: &IntegratorOptions,
        ck: &IntegratorCheckpoint,
    ) -> Result<Self> {
        body.validate()?;
        loading.validate(body.nodes())?;
        if !(ck.dt.is_finite() && ck.dt > 0.0) {
            return Err(Error::InvalidInput {
                what: "checkpoint",
                why: format!("time step {} is not positive", ck.dt),
            });
        }
        let mut kernel = if opts.force_csr {
            Kernel::Csr { plain: false }
        } else {
            Kernel::for_body(body, state)
        };
        opts.choose_lanes(&mut kernel);
        let u_next = if kernel.drifts_in_place() {
            Coords::default()
        } else {
            Coords::zeros(body.nodes())
        };
        let inv_mass = body.mass.iter().map(|&m| 1.0 / m).collect();
        let mut it = Self::assemble(
            body,
            loading,
            opts,
            kernel,
            ck.dt,
            ck.stable,
            (u_next, inv_mass),
        );
        it.synced = state.breaks();
        it.plane &= Self::flat(state);
        it.ledger = ck.ledger;
        it.initial = ck.initial;
        it.initial_power = ck.initial_power;
        Ok(it)
    }

    /// Continue from a checkpoint an integrator built for the same body, loading and options
    /// (a rank's, already cut to its piece, which reads its own piece's checkpoint: the
    /// steps, time step and ledger become the checkpoint's, and the kernel follows `state`'s
    /// springs). The continued run is bit-identical to an uninterrupted one.
    pub fn restore(&mut self, body: &Body, state: &State, ck: &IntegratorCheckpoint) {
        self.dt = ck.dt;
        self.stable = ck.stable;
        self.ledger = ck.ledger;
        self.initial = ck.initial;
        self.initial_power = ck.initial_power;
        self.plane &= Self::flat(state);
        // Rebuilt for the checkpoint's springs, whatever the counter says.
        self.synced = state.breaks().wrapping_add(1);
        self.sync(body, state);
    }

    /// Position and velocity of a prescribed DOF at time `t`, given its current displacement
    /// (for `Fixed`: stays where it is).
    fn prescribed_at(&self, d: &PrescribedDof, current: Real, t: Real) -> (Real, Real) {
        match &self.motions[d.motion] {
            Motion::Fixed => (current, 0.0),
            Motion::Velocity(f) => (current, f.value(t)),
            Motion::Displacement(f) => {
                let h = 0.5 * self.dt;
                (f.value(t), (f.value(t + h) - f.value(t - h)) / (2.0 * h))
            }
        }
    }

    /// Total acceleration `(f + F_ext)/m + g - c v` from `state.f` (current) and the given
    /// velocity. Output path only.
    fn acceleration(&self, body: &Body, state: &State) -> Coords {
        let mut a = Coords::zeros(body.nodes());
        let g = self.loading.body_acceleration;
        // Component by component (the operations of `f m^-1 + g - c v` on vectors, in their
        // order): loops the compiler vectorises, where a node at a time was a frame's
        // slowest pass after the forces.
        for c in 0..3 {
            let (f, v) = (state.f.comp(c), state.v.comp(c));
            for (((a, &f), &v), &im) in a.comp_mut(c).iter_mut().zip(f).zip(v).zip(&self.inv_mass) {
                *a = f * im + g[c] - self.damping * v;
            }
        }
        for &(i, li) in &self.loaded {
            let l = &self.loading.loads[li];
            let f = l.force * l.scale.value(state.time) * self.inv_mass[i];
            a.set(i, a.get(i) + f);
        }
        a
    }

    /// The external load on axis `c` of prescribed DOF `d`'s node at time `t` (N).
    fn load_on(&self, d: &PrescribedDof, c: usize, t: Real) -> Real {
        self.dof_loads[d.loads.clone()]
            .iter()
            .map(|&k| {
                let l = &self.loading.loads[self.loaded[k].1];
                l.force[c] * l.scale.value(t)
            })
            .sum()
    }

    /// Energy accumulated in the ledger so far.
    pub fn ledger(&self) -> Ledger {
        self.ledger
    }

    /// Break spring `b`: the state (its intact flags and both nodes' normalisers) and the
    /// kernel's spring masks change together. Returns false if it was already broken.
    ///
    /// On a piece ([`Integrator::cut`]) `b` is the piece's spring, and the normaliser of an
    /// end that is a ghost comes from the ghost's partial row: nothing reads a ghost's.
    pub fn break_spring(&mut self, body: &Body, state: &mut State, b: usize) -> bool {
        let in_sync = state.breaks() == self.synced;
        if !state.kill_bond(body, b) {
            return false;
        }
        self.kernel.bond_killed(body, b);
        self.killed.push(b as u32);
        if in_sync {
            self.synced = state.breaks();
        }
        true
    }

    /// Soften spring `b` to damage weight `w` (a softening material; [`State::soften`]): the
    /// state's weight, stiffness and both normalisers change, and the kernel follows (the
    /// stencil, which has one stiffness, hands the body to the general kernel at the first
    /// damage). `w = 0` breaks it ([`Integrator::break_spring`]). Returns false if nothing
    /// changed (the weight was not lower).
    pub fn soften_spring(&mut self, body: &Body, state: &mut State, b: usize, w: Real) -> bool {
        if w <= 0.0 {
            return self.break_spring(body, state, b);
        }
        let in_sync = state.breaks() == self.synced;
        if !state.soften(body, b, w) {
            return false;
        }
        if !self.kernel.is_stencil() {
            self.kernel.bond_softened(body, state, b);
            self.killed.push(b as u32);
            if in_sync {
                self.synced = state.breaks();
            }
        }
        // On the stencil `synced` stays behind: the next `sync` switches kernels.
        true
    }

    /// Bring the kernel's spring masks in line with the state if springs were changed without
    /// [`Integrator::break_spring`] (a caller's `State::kill_bond` or `set_alive`): cheap when
    /// nothing changed, one pass over the springs when something did.
    fn sync(&mut self, body: &Body, state: &State) {
        if state.breaks() == self.synced {
            return;
        }
        if self.kernel.holds_springs() {
            let simd = self.kernel.simd();
            // Softened springs: the stencil cannot hold their stiffnesses, and `for_body` gives
            // the CSR kernel.
            let swept = self.partition.swept();
            self.kernel = Kernel::for_body_in(body, state, swept.clone());
            self.kernel.set_simd(simd);
            if let Some(nodes) = swept {
                self.kernel.keep_rows(nodes);
            }
        }
        self.synced = state.breaks();
    }

    /// Whether the body is a plate on which nothing acts along z: no body acceleration, load or
    /// prescribed motion along z, and no displacement or velocity along z when the run began
    /// (contact between plates is planar too). Its z components then stay exact zeros, and
    /// the sweeps do not touch them.
    pub fn is_plane(&self) -> bool {
        self.plane
    }

    fn flat(state: &State) -> bool {
        state.u.z().iter().chain(state.v.z()).all(|&z| z == 0.0)
    }

    /// One step.
    pub fn step(&mut self, body: &Body, state: &mut State) {
        self.step_with(body, state, None);
    }

    /// One step with an interaction (contact) acting on the nodes.
    pub fn step_with(
        &mut self,
        body: &Body,
        state: &mut State,
        interaction: Option<&mut dyn Interaction>,
    ) {
        self.step_full(body, state, interaction, None);
    }

    /// The sparse bookkeeping before the sweep overwrites v: the half-step velocity of every
    /// loaded or prescribed node, the prescribed DOFs' displacements (when the kernel drifts in
    /// place), and the internal force at u(t) on every prescribed node (in a team computed by the
    /// owners and gathered).
    fn record_before(&mut self, body: &Body, state: &State, in_place: bool) {
        self.v_before.clear();
        self.f_before.clear();
        for &(i, _) in &self.loaded {
            self.v_before
                .push([state.v.x()[i], state.v.y()[i], state.v.z()[i]]);
        }
        for d in &self.dofs {
            let i = d.node;
            self.v_before
                .push([state.v.x()[i], state.v.y()[i], state.v.z()[i]]);
        }
        self.u_before.clear();
        if in_place {
            self.u_before
                .extend(self.dofs.iter().map(|d| state.u.comp(d.axis)[d.node]));
        }
        // A pristine box's forces from its grid, leaving its rows and stiffnesses unbuilt (looked
        // up only for a step that has prescribed nodes).
        let grid = if self.dofs.is_empty() {
            None
        } else {
            crate::law::GridLaw::of(body, state)
        };
        let force = |i| match &grid {
            Some(g) => g.node_force(&state.u, &state.pool, i),
            None => {
                crate::law::node_force(body, body.q, &state.u, state.springs(body), &state.pool, i)
            }
        };
        self.prescribed_forces_everywhere(&force);
    }

    /// External loads: the sweep kicked without them; add their share of the kick (linear in
    /// the force, so this equals kicking with it). The velocities the sweep computed are kept
    /// first, so that the work can be booked once every load on a node has acted.
    fn kick_loads(
        &mut self,
        body: &Body,
        state: &mut State,
        (t, dt, grow): (Real, Real, Real),
        in_place: bool,
    ) {
        self.v_kernel.clear();
        for &(i, _) in &self.loaded {
            self.v_kernel
                .push([state.v.x()[i], state.v.y()[i], state.v.z()[i]]);
        }
        for &(i, li) in &self.loaded {
            let l = &self.loading.loads[li];
            let dv = l.force * (l.scale.value(t) * dt * self.inv_mass[i] * grow);
            for c in 0..3 {
                state.v.comp_mut(c)[i] += dv[c];
                new_displacements(&mut self.u_next, &mut state.u, in_place).comp_mut(c)[i] +=
                    dt * dv[c];
            }
        }
        let g = self.loading.body_acceleration;
        for (k, &(i, li)) in self.loaded.iter().enumerate() {
            let f: Vector = self.loading.loads[li].force * self.loading.loads[li].scale.value(t);
            let first = self.first_load[k];
            for c in 0..3 {
                let (v0, v1) = (self.v_before[k][c], state.v.comp(c)[i]);
                self.ledger.external_work += f[c] * 0.5 * (v0 + v1) * dt;
                if first {
                    // The sweep booked body-force work and damping with its own velocity.
                    let (mid_kernel, mid) = (0.5 * (v0 + self.v_kernel[k][c]), 0.5 * (v0 + v1));
                    let m = body.mass[i];
                    self.ledger.body_work += m * g[c] * (mid - mid_kernel) * dt;
                    self.ledger.dissipated +=
                        self.damping * m * (mid * mid - mid_kernel * mid_kernel) * dt;
                }
            }
        }
    }

    /// Interaction forces: an extra kick like the loads; work booked with the node's velocities
    /// before and after the whole step. Damping and body-force work were booked by the sweep
    /// with its own velocity; the contact kick changes that velocity, so their share is
    /// rebooked as for the loads. On a piece each rank pushes its own nodes: their work terms
    /// are gathered and every rank books them in node order, as one process does.
    fn kick_contact(
        &mut self,
        body: &Body,
        state: &mut State,
        params: &StepParams,
        (dt, grow): (Real, Real),
        in_place: bool,
    ) {
        let g = self.loading.body_acceleration;
        // rank books them in node order, as one process does.
        let pieced = self.partition.is_pieced();
        let mut terms = std::mem::take(&mut self.contact_terms);
        terms.clear();
        for (k, &(i, f)) in self.contact.iter().enumerate() {
            let i = i as usize;
            let m = body.mass[i];
            let v_sweep = [state.v.x()[i], state.v.y()[i], state.v.z()[i]];
            for c in 0..3 {
                let dv = f[c] * dt * self.inv_mass[i] * grow;
                state.v.comp_mut(c)[i] += dv;
                new_displacements(&mut self.u_next, &mut state.u, in_place).comp_mut(c)[i] +=
                    dt * dv;
                let (v0, v1) = (self.v_contact[k][c], state.v.comp(c)[i]);
                let (mid_kernel, mid) = (0.5 * (v0 + v_sweep[c]), 0.5 * (v0 + v1));
                let term = [
                    f[c] * 0.5 * (v0 + v1) * dt,
                    m * g[c] * (mid - mid_kernel) * dt,
                    self.damping * m * (mid * mid - mid_kernel * mid_kernel) * dt,
                ];
                if pieced {
                    terms.extend(term);
                } else {
                    book_contact(&mut self.ledger, term);
                }
            }
        }
        if pieced {
            self.book_contact_pieces(body, state, params, &terms, in_place);
        }
        self.contact_terms = terms;
    }

    /// Prescribed motion overrides its DOFs; the reaction's work is booked.
    fn prescribe(&mut self, body: &Body, state: &mut State, (t, dt): (Real, Real), in_place: bool) {
        let nl = self.loaded.len();
        for (k, d) in self.dofs.iter().enumerate() {
            let (i, c) = (d.node, d.axis);
            let u_now = if in_place {
                self.u_before[k]
            } else {
                state.u.comp(c)[i]
            };
            let (u1, v_half) = match &self.motions[d.motion] {
                Motion::Fixed => (u_now, 0.0),
                Motion::Velocity(f) => {
                    let v = f.value(t + 0.5 * dt);
                    (u_now + dt * v, v)
                }
                Motion::Displacement(f) => {
                    let u1 = f.value(t + dt);
                    (u1, (u1 - u_now) / dt)
                }
            };
            let v_kernel = state.v.comp(c)[i];
            new_displacements(&mut self.u_next, &mut state.u, in_place).comp_mut(c)[i] = u1;
            state.v.comp_mut(c)[i] = v_half;
            let v_old = self.v_before[nl + k][c];
            let m = body.mass[i];
            // The sweep booked body-force work and damping for this DOF with the velocity it
            // computed; the DOF moves with the prescribed velocity instead, so rebook them.
            let (mid_kernel, mid) = (0.5 * (v_old + v_kernel), 0.5 * (v_old + v_half));
            let g_c = self.loading.body_acceleration[c];
            self.ledger.body_work += m * g_c * (mid - mid_kernel) * dt;
            self.ledger.dissipated += self.damping * m * (mid * mid - mid_kernel * mid_kernel) * dt;
            let fext = self.load_on(d, c, t);
            // Its loads' work was booked with the kicked velocity too; the DOF moved with the
            // prescribed one.
            self.ledger.external_work += fext * (mid - mid_kernel) * dt;
            let g = self.loading.body_acceleration[c];
            let reaction = m * (v_half - v_old) / dt - self.f_before[k][c] - fext - m * g
                + self.damping * m * 0.5 * (v_half + v_old);
            self.ledger.boundary_work += reaction * 0.5 * (v_old + v_half) * dt;
        }
    }

    fn step_full(
        &mut self,
        body: &Body,
        state: &mut State,
        mut interaction: Option<&mut dyn Interaction>,
        breaker: Option<&mut dyn Breaker>,
    ) -> BreakReport {
        self.sync(body, state);
        self.killed.clear();
        // Sweep 1 done (and consistent with every break) before the contact forces.
        let (swept, broke) = match breaker {
            Some(b) => self.break_at_start(body, state, b),
            None => (false, BreakReport::default()),
        };
        let dt = self.dt;
        let t = state.time;
        self.contact.clear();
        self.v_contact.clear();
        if let Some(it) = interaction.as_mut() {
            self.contact_reads_current(body, state, &mut **it);
            it.forces(body, state, dt, &mut self.contact);
            for &(i, _) in &self.contact {
                let i = i as usize;
                self.v_contact
                    .push([state.v.x()[i], state.v.y()[i], state.v.z()[i]]);
            }
        }
        if !swept {
            self.pools_everywhere(body, state, Real::INFINITY);
        }
        let in_place = self.kernel.drifts_in_place();
        self.record_before(body, state, in_place);
        let params = StepParams {
            dt,
            damping: self.damping,
            accel: self.loading.body_acceleration.into(),
            plane: self.plane,
        };
        let sums = self.sweep_everywhere(body, state, &params);
        self.swept_velocities_current(state);
        self.ledger.dissipated += sums.dissipated;
        self.ledger.body_work += sums.body_work;
        let grow = 1.0 / (1.0 + 0.5 * self.damping * dt);
        self.kick_loads(body, state, (t, dt, grow), in_place);
        self.kick_contact(body, state, &params, (dt, grow), in_place);
        self.prescribe(body, state, (t, dt), in_place);
        if !in_place {
            std::mem::swap(&mut state.u, &mut self.u_next);
        }
        state.step += 1;
        state.time = t + dt;
        broke
    }

    /// Run `steps` steps, checking for blow-up every 64 steps and at the end. On instability
    /// the state is left as it was at the failing check, and the error names the step, node and
    /// reason.
    pub fn run(&mut self, body: &Body, state: &mut State, steps: u64) -> Result<()> {
        for s in 0..steps {
            self.step(body, state);
            if (s + 1) % 64 == 0 || s + 1 == steps {
                self.gather_state(state);
                self.check(body, state)?;
            }
        }
        Ok(())
    }

    /// Look for non-finite values or springs stretched beyond any physical meaning.
    pub fn check(&self, body: &Body, state: &State) -> Result<()> {
        self.whole("the one-process blow-up check");
        Self::check_nodes(body, state, 0..body.nodes())
    }

    fn check_nodes(body: &Body, state: &State, nodes: std::ops::Range<usize>) -> Result<()> {
        Self::check_nodes_of(body, state, nodes, body.nodes())
    }

    /// Why a node is unstable: a non-finite value (`finite` false), or a displacement of
    /// `moved` metres.
    fn unstable_reason(finite: bool, moved: Real) -> String {
        if finite {
            format!("moved {moved:.3e} m, a thousand times the body's size")
        } else {
            "has a non-finite displacement or velocity".to_string()
        }
    }

    /// [`Integrator::check_nodes`] with the size limit of a body of `total` nodes (a piece's
    /// whole body).
    fn check_nodes_of(
        body: &Body,
        state: &State,
        nodes: std::ops::Range<usize>,
        total: usize,
    ) -> Result<()> {
        let size = body.lattice.spacing * (total as Real).cbrt().max(1.0) * 1e3;
        for i in nodes {
            let u = state.u.get(i);
            let v = state.v.get(i);
            let finite = u.iter().chain(&v).all(|x| x.is_finite());
            let reason =
                (!finite || u.norm() > size).then(|| Self::unstable_reason(finite, u.norm()));
            if let Some(reason) = reason {
                return Err(Error::Unstable {
                    step: state.step,
                    time: state.time,
                    node: i,
                    reason,
                    hint: UNSTABLE_HINT,
                });
            }
        }
        Ok(())
    }

    /// Moves the displacements into the integrator's other buffer, values unchanged (one copy
    /// of `3 n` values). A step writes the new displacements into a second buffer and swaps the
    /// two, so `state.u`'s allocation alternates from step to step; a reader that holds a view
    /// of it without copying (numpy) calls this, when the parity is wrong, to keep the
    /// displacements where its view looks. Nothing to do where the kernel drifts in place
    /// ([`crate::kernel::Kernel::drifts_in_place`]): `state.u` never moves.
    pub fn swap_displacement_buffers(&mut self, state: &mut State) {
        if self.u_next.len() != state.u.len() {
            return; // One buffer: the kernel drifts in place (`Kernel::drifts_in_place`).
        }
        std::mem::swap(&mut state.u, &mut self.u_next);
        state.u.copy_from(&self.u_next);
    }

    /// Full-step velocity `v(t)` (for output and energy): `v(t-dt/2) + dt/2 a(t)` on free DOFs,
    /// the prescribed velocity on prescribed ones. Refreshes `state.f` and `state.pool`.
    ///
    /// On a piece ([`Integrator::cut`]) the velocities of its own nodes and of the loaded and
    /// prescribed ones; collective there.
    pub fn full_velocity(&self, body: &Body, state: &mut State) -> Coords {
        if self
            .piece_fields(body, state, &mut law::FrameScratch::default())
            .is_none()
        {
            law::update_forces(body, state);
        }
        self.velocity_from_forces(body, state)
    }

    /// What an output frame needs, from one evaluation ([`law::frame_fields`]): the full-step
    /// velocity, the energy balance and the derived fields, with `state.pool` and `state.f`
    /// refreshed. The same values as [`Integrator::full_velocity`] and
    /// [`Integrator::energy`], bit for bit, at a fraction of their cost.
    ///
    /// Shared by a team, each rank computes the fields of its own nodes
    /// ([`law::FramePart`]); the pools and forces are then gathered whole on every rank (the
    /// velocity, the reactions and a checkpoint read them), and the energy densities and
    /// stresses too with `whole` (for a writer of whole frames), else they hold this rank's
    /// nodes only. The displacements must be whole (`gather_state`).
    pub fn frame_view(
        &mut self,
        body: &Body,
        state: &mut State,
        whole: bool,
    ) -> (Coords, EnergyBalance, law::FrameFields) {
        if let Some(frame) = self.frame_on_piece(body, state, whole) {
            return frame;
        }
        let part = self.partition.frame_part();
        // A box's frame from its grid, leaving its rows and stiffnesses unbuilt (one process).
        let grid = part.map_or_else(|| law::frame_fields_grid(body, state), |_| None);
        let mut fields = grid.unwrap_or_else(|| {
            law::frame_fields_part(
                body,
                &state.u,
                state.springs(body),
                &state.norm,
                &mut self.frame_scratch,
                part,
            )
        });
        self.frame_gathered(&mut fields, whole);
        // Kept while glibc's heap would keep its blocks anyway once a set-up is done (below the
        // mapping threshold): a larger body gives them back after each frame, as before, so
        // frames never raise a large run's resident memory.
        if self.frame_scratch.bytes() > hooke_sys::alloc::KEPT_BLOCK {
            self.frame_scratch = Default::default();
        }
        state.pool.copy_from_slice(&fields.pool);
        state.f.clone_from(&fields.force);
        let v = self.velocity_from_forces(body, state);
        let b = self.balance(body, state, &v, fields.strain);
        (v, b, fields)
    }

    /// The full-step velocity from the current `state.f` (see [`Integrator::full_velocity`]).
    fn velocity_from_forces(&self, body: &Body, state: &State) -> Coords {
        let a = self.acceleration(body, state);
        let mut v = state.v.clone();
        v.axpy(0.5 * self.dt, &a);
        // Damping acts on the half-step velocity implicitly: undo its explicit share above and
        // apply the same implicit factor the kick uses.
        if self.damping > 0.0 {
            let h = 0.5 * self.damping * self.dt;
            for c in 0..3 {
                for (vn, (vh, an)) in v
                    .comp_mut(c)
                    .iter_mut()
                    .zip(state.v.comp(c).iter().zip(a.comp(c)))
                {
                    let a_nodamp = an + self.damping * vh;
                    *vn = (vh + 0.5 * self.dt * a_nodamp) / (1.0 + h);
                }
            }
        }
        for d in &self.dofs {
            let (_, v_now) = self.prescribed_at(d, state.u.comp(d.axis)[d.node], state.time);
            v.comp_mut(d.axis)[d.node] = v_now;
        }
        v
    }

    /// Power of the external loads, body force, damping and support reactions at this instant
    /// (W), from the full-step velocity `v` and current `state.f`.
    fn power(&self, body: &Body, state: &State, v: &Coords) -> Real {
        let [_, nodes] = self.node_sums(body, v);
        self.power_with(body, state, v, nodes)
    }

    /// `(1/2 sum m |v|^2, sum m (g.v - c |v|^2))`: the kinetic energy and the body force's and
    /// damping's power, each summed per chunk of [`crate::kernel::CHUNK`] nodes and the
    /// chunks added in order, so that a team's ranks, each summing its own chunks (on a
    /// piece: the only ones it holds), find one process's bits. Collective on pieces.
    fn node_sums(&self, body: &Body, v: &Coords) -> [Real; 2] {
        let (g, c) = (self.loading.body_acceleration, self.damping);
        if let Some(sums) = self.node_sums_on_piece(body, v) {
            return sums;
        }
        chunk_node_sums(body, v, g, c, 0..body.nodes())
            .into_iter()
            .fold([0.0; 2], |s, x| [s[0] + x[0], s[1] + x[1]])
    }

    /// [`Integrator::power`] with the body force's and damping's share `nodes` already summed.
    fn power_with(&self, body: &Body, state: &State, v: &Coords, nodes: Real) -> Real {
        let t = state.time;
        let g = self.loading.body_acceleration;
        let mut p = nodes;
        for &(i, li) in &self.loaded {
            let l = &self.loading.loads[li];
            p += (l.force * l.scale.value(t)).dot(&v.get(i));
        }
        for d in &self.dofs {
            let (i, c) = (d.node, d.axis);
            let h = self.dt;
            let accel = match &self.motions[d.motion] {
                Motion::Fixed => continue,
                Motion::Velocity(f) => (f.value(t + 0.5 * h) - f.value(t - 0.5 * h)) / h,
                Motion::Displacement(f) => {
                    (f.value(t + h) - 2.0 * f.value(t) + f.value(t - h)) / (h * h)
                }
            };
            let m = body.mass[i];
            let fext = self.load_on(d, c, t);
            let vc = v.comp(c)[i];
            let reaction = m * accel - state.f.comp(c)[i] - fext - m * g[c] + self.damping * m * vc;
            p += reaction * vc;
        }
        p
    }

    /// The force each node receives from outside the lattice at `state.time` (N), for output:
    /// the support reaction on every prescribed DOF, `m a - f_int - f_ext - m g + c m v` (the
    /// force that makes the DOF follow its motion, as booked in the ledger), plus the external
    /// loads. `state.f` must hold the internal forces at `state.u` and `v` the full-step
    /// velocity, as after [`Integrator::full_velocity`]. Summed over a boundary region it is the
    /// force that region exerts on the body (a load-displacement curve's load).
    ///
    /// On a piece, at the loaded and prescribed nodes (after [`Integrator::frame_view`] or
    /// [`Integrator::full_velocity`], which take their forces from their owners).
    pub fn boundary_forces(&self, body: &Body, state: &State, v: &Coords) -> Coords {
        self.boundary_forces_from(body, state, |i, c| state.f.comp(c)[i], |i, c| v.comp(c)[i])
    }

    /// [`Integrator::boundary_forces`] at the full step, as after
    /// [`Integrator::full_velocity`], the same bits, from the forces of the prescribed nodes
    /// alone ([`law::forces_at`]): a reaction record between frames costs a few rows, not two
    /// passes over the body. Leaves the state as it is.
    ///
    /// On a piece each owner computes its prescribed nodes' forces, from its own nodes'
    /// pools and its ghosts' traded (a halo trade and an all-gather: collective).
    pub fn boundary_forces_now(&self, body: &Body, state: &State) -> Coords {
        // Each node once, though a grip prescribes its two or three axes.
        let mut nodes: Vec<usize> = self.dofs.iter().map(|d| d.node).collect();
        nodes.sort_unstable();
        nodes.dedup();
        let forces = self
            .forces_on_piece(body, state, &nodes)
            .unwrap_or_else(|| law::forces_at(body, state, &nodes));
        let force =
            |i: usize, c: usize| forces[nodes.binary_search(&i).expect("a prescribed node")][c];
        // A prescribed DOF's full-step velocity is its prescribed one, the last DOF's where
        // regions that overlap prescribe one twice (as `Integrator::velocity_from_forces`
        // writes them, in order).
        let (u, t) = (&state.u, state.time);
        let mut prescribed = std::collections::HashMap::new();
        for d in &self.dofs {
            let v = self.prescribed_at(d, u.comp(d.axis)[d.node], t).1;
            prescribed.insert((d.node, d.axis), v);
        }
        self.boundary_forces_from(body, state, force, |i, c| prescribed[&(i, c)])
    }

    /// [`Integrator::boundary_forces`] with the internal force and the velocity of a prescribed
    /// DOF (node `i`, axis `c`) from `force(i, c)` and `velocity(i, c)`.
    fn boundary_forces_from(
        &self,
        body: &Body,
        state: &State,
        force: impl Fn(usize, usize) -> Real,
        velocity: impl Fn(usize, usize) -> Real,
    ) -> Coords {
        let t = state.time;
        let g = self.loading.body_acceleration;
        let mut out = Coords::zeros(body.nodes());
        for &(i, li) in &self.loaded {
            let l = &self.loading.loads[li];
            let f = l.force * l.scale.value(t);
            out.set(i, out.get(i) + f);
        }
        let h = self.dt;
        for d in &self.dofs {
            let (i, c) = (d.node, d.axis);
            let accel = match &self.motions[d.motion] {
                Motion::Fixed => 0.0,
                Motion::Velocity(f) => (f.value(t + 0.5 * h) - f.value(t - 0.5 * h)) / h,
                Motion::Displacement(f) => {
                    (f.value(t + h) - 2.0 * f.value(t) + f.value(t - h)) / (h * h)
                }
            };
            let m = body.mass[i];
            let vc = velocity(i, c);
            // Loads on this DOF are already in `out`: the support adds what is missing.
            let reaction =
                m * accel - force(i, c) - self.load_on(d, c, t) - m * g[c] + self.damping * m * vc;
            out.comp_mut(c)[i] += reaction;
        }
        out
    }

    /// The energy balance now.
    ///
    /// The ledger books each step's work over `[t - dt/2, t + dt/2]` (the midpoint form that
    /// matches leapfrog), so its sum runs from `t0 - dt/2` to `t - dt/2`; the half steps at both
    /// ends are added as `(P(t) - P(t0)) dt/2`, P the power of the non-conservative forces.
    /// Without it the balance would carry an O(dt) error that grows with the load.
    ///
    /// On a piece, collective: every rank finds one process's balance.
    pub fn energy(&self, body: &Body, state: &mut State) -> EnergyBalance {
        if let Some(f) = self.piece_fields(body, state, &mut law::FrameScratch::default()) {
            let v = self.velocity_from_forces(body, state);
            return self.balance(body, state, &v, f.strain);
        }
        // A pristine box from its grid: the same pools, forces and energy, without building its
        // rows and stiffnesses at the end of a run that never needed them.
        if let Some(f) = law::frame_fields_grid(body, state) {
            state.pool.copy_from_slice(&f.pool);
            state.f.clone_from(&f.force);
            let v = self.velocity_from_forces(body, state);
            return self.balance(body, state, &v, f.strain);
        }
        let v = self.full_velocity(body, state);
        let strain = law::energy(body, &state.u, state.springs(body), &state.norm);
        self.balance(body, state, &v, strain)
    }

    /// The balance for full-step velocity `v` and strain energy `strain` of the current state.
    fn balance(
        &self,
        body: &Body,
        state: &State,
        v: &Coords,
        strain: law::Energy,
    ) -> EnergyBalance {
        let [kinetic, nodes] = self.node_sums(body, v);
        let l = self.ledger;
        let ends = 0.5 * self.dt * (self.power_with(body, state, v, nodes) - self.initial_power);
        let expected = self.initial + l.external_work + l.boundary_work + l.body_work
            - l.dissipated
            - l.released
            + ends;
        let error = kinetic + strain.total() - expected;
        let scale = [
            kinetic,
            strain.total(),
            self.initial,
            l.external_work.abs(),
            l.boundary_work.abs(),
            l.body_work.abs(),
            l.dissipated,
            l.released.abs(),
        ]
        .into_iter()
        .fold(0.0, Real::max);
        EnergyBalance {
            kinetic,
            strain,
            ledger: l,
            initial: self.initial,
            error,
            relative_error: if scale > 0.0 {
                error.abs() / scale
            } else {
                0.0
            },
        }
    }
}

/// Kinetic energy `1/2 sum m |v|^2` (J), summed per chunk of [`crate::kernel::CHUNK`] nodes,
/// the chunks in order (the bits a team's ranks find, each summing its own chunks).
pub fn kinetic(body: &Body, v: &Coords) -> Real {
    chunk_node_sums(body, v, Vector::zeros(), 0.0, 0..body.nodes())
        .into_iter()
        .fold(0.0, |s, x| s + x[0])
}

/// Per chunk of [`crate::kernel::CHUNK`] nodes of `nodes` (which starts on a chunk), in
/// order: `1/2 sum m |v|^2` and `sum m (g.v - c |v|^2)`, each node's terms added in node
/// order. Parallel over the chunks, the same bits for any thread count.
fn chunk_node_sums(
    body: &Body,
    v: &Coords,
    g: Vector,
    damping: Real,
    nodes: std::ops::Range<usize>,
) -> Vec<[Real; 2]> {
    let chunk = crate::kernel::CHUNK;
    let chunks = nodes.len().div_ceil(chunk);
    (0..chunks)
        .into_par_iter()
        .map(|k| {
            let from = nodes.start + k * chunk;
            let mut s = [0.0; 2];
            for i in from..(from + chunk).min(nodes.end) {
                let (vi, m) = (v.get(i), body.mass[i]);
                let v2 = vi.norm_squared();
                s[0] += 0.5 * m * v2;
                s[1] += m * (g.dot(&vi) - damping * v2);
            }
            s
        })
        .collect()
}

/// Total linear momentum `sum m v` (kg m/s).
pub fn momentum(body: &Body, v: &Coords) -> Vector {
    (0..body.nodes()).map(|i| body.mass[i] * v.get(i)).sum()
}

/// Total angular momentum about the origin, `sum m x x v` (kg m^2/s).
pub fn angular_momentum(body: &Body, state: &State, v: &Coords) -> Vector {
    (0..body.nodes())
        .map(|i| body.mass[i] * state.position(body, i).cross(&v.get(i)))
        .sum()
}
