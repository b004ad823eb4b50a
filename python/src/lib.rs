//! `hooke._hooke`: the extension module under the `hooke` Python package.
//!
//! A thin layer over `hooke-sim` (the run drivers) and `hooke-case` (case files): nothing here
//! steps a body or writes a file by itself. Stepping releases the interpreter in slices of about
//! a tenth of a second and checks for Ctrl-C between slices, so a long `run` stays interruptible
//! and leaves the simulation usable (the KeyboardInterrupt arrives after a whole step).
//!
//! Modules: this file (the `Simulation` and `Builder` classes, `load_case`, the `hooke-lab`
//! calls), `views` (the zero-copy numpy views, the one place with `unsafe` here) and `spec` (a
//! `hooke.Builder` call's arguments applied to `hooke_sim::Builder` as the call is made).

// `unsafe` only in `views`, each block with its SAFETY comment.
#![deny(unsafe_code)]

mod spec;
#[allow(unsafe_code)]
mod views;

// Large arrays at staggered offsets into their pages, as in the `hooke` binary
// (hooke_sys::alloc): the extension's own allocations only; Python's are its own.
#[global_allocator]
static ALLOC: hooke_sys::alloc::Staggered = hooke_sys::alloc::Staggered;

use std::path::PathBuf;
use std::time::Instant;

use numpy::{PyArray1, PyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use hooke_core::{Coords, Real};
use hooke_sim::{EnergyRow, Observer, Run, RunOptions};

pyo3::create_exception!(
    _hooke,
    CaseError,
    PyValueError,
    "A mistake in a case or an argument; the message names the file, line, column and key, and the fix."
);
pyo3::create_exception!(
    _hooke,
    RunError,
    pyo3::exceptions::PyRuntimeError,
    "A run that failed (an unstable step names the step, node and reason; an output that could not be written names the file)."
);

fn run_error(e: hooke_sim::Error) -> PyErr {
    if e.is_input() {
        CaseError::new_err(e.to_string())
    } else {
        RunError::new_err(e.to_string())
    }
}

/// Wall-clock time the interpreter is released for at a time while stepping.
const SLICE_SECONDS: f64 = 0.1;

/// Never stops a run; the slices are what make Ctrl-C work.
struct Quiet;
impl Observer for Quiet {}

/// A simulation: built from a case, run in steps or to a time, its state readable as numpy
/// arrays. It starts (opens its output folder and writes the first frame) on the first step.
#[pyclass(module = "hooke._hooke", name = "Simulation", unsendable)]
struct PySimulation {
    /// Before the first step.
    pending: Option<(hooke_sim::Simulation, RunOptions)>,
    /// From the first step until `finish`.
    run: Option<Run>,
    /// After `finish`: the summary (JSON), and the simulation as it ended.
    summary: Option<String>,
    ended: Option<hooke_sim::Simulation>,
    out: PathBuf,
    /// Seconds per step, measured, to size the slices.
    step_seconds: f64,
    /// The views handed out (numpy arrays without copies) look at these buffers, which
    /// therefore must neither move nor be freed while this object lives: the displacements'
    /// allocation (the integrator alternates two; `sync` moves them back), and the addresses
    /// of the other viewed buffers, checked after every call that ran Rust code.
    u_home: Option<usize>,
    viewed: Vec<(&'static str, usize)>,
    /// Full-step velocities and node damage, derived: computed when control returns to
    /// Python, and only once they have been asked for.
    velocity: Option<Coords>,
    damage: Option<Vec<Real>>,
}

impl PySimulation {
    /// A simulation that starts (and writes to `opts.out`) on its first step.
    fn new(sim: hooke_sim::Simulation, opts: RunOptions) -> Self {
        PySimulation {
            out: opts.out.clone(),
            pending: Some((sim, opts)),
            run: None,
            summary: None,
            ended: None,
            step_seconds: 0.0,
            u_home: None,
            viewed: Vec::new(),
            velocity: None,
            damage: None,
        }
    }

    /// The address of each viewed buffer now.
    fn address(&self, what: &str) -> usize {
        let sim = self.sim();
        match what {
            "positions" => sim.body.lattice.pos.as_flat().as_ptr() as usize,
            "spring_ends" => sim.body.lattice.bonds.ends.as_ptr() as usize,
            "spring_intact" => sim.state.alive().as_ptr() as usize,
            _ => unreachable!("{what} is not a viewed buffer"),
        }
    }

    /// Back in Python after Rust code ran: the views show the state now. The displacements
    /// return to the allocation the views look at; the derived arrays that were asked for are
    /// recomputed in place.
    fn sync(&mut self) -> PyResult<()> {
        if let Some(home) = self.u_home {
            let home_ptr = home as *const Real;
            let ok = match self.run.as_mut() {
                Some(run) => run.keep_displacement_in(home_ptr),
                None => self.sim().state.u.as_flat().as_ptr() == home_ptr,
            };
            if !ok {
                return Err(RunError::new_err(
                    "internal error: the displacements left the buffer that numpy views look at",
                ));
            }
        }
        for &(what, at) in &self.viewed {
            if self.address(what) != at {
                return Err(RunError::new_err(format!(
                    "internal error: the buffer of {what} moved under its numpy views"
                )));
            }
        }
        if let Some(mut v) = self.velocity.take() {
            match (self.run.as_mut(), &self.ended) {
                (Some(run), _) => run.full_velocity_into(&mut v),
                // Ended: the last velocities computed before the end stay.
                (None, Some(_)) => {}
                (None, None) => v.copy_from(&self.sim().state.v),
            }
            self.velocity = Some(v);
        }
        if let Some(mut d) = self.damage.take() {
            let sim = self.sim();
            match &sim.fracture {
                Some(f) => d.copy_from_slice(&f.damage(&sim.body, &sim.state)),
                None => d.fill(0.0),
            }
            self.damage = Some(d);
        }
        Ok(())
    }

    /// Note a buffer handed out as a view, to check after each call that it did not move.
    fn remember(&mut self, what: &'static str) {
        if !self.viewed.iter().any(|&(w, _)| w == what) {
            let at = self.address(what);
            self.viewed.push((what, at));
        }
    }

    fn sim(&self) -> &hooke_sim::Simulation {
        match (&self.pending, &self.run, &self.ended) {
            (Some((s, _)), _, _) => s,
            (_, Some(r), _) => r.simulation(),
            (_, _, Some(s)) => s,
            _ => unreachable!("a simulation is pending, running or ended"),
        }
    }

    fn running(&mut self) -> PyResult<&mut Run> {
        if self.summary.is_some() {
            return Err(RunError::new_err(
                "the run is finished (finish() was called): load the case again to run it anew",
            ));
        }
        if let Some((sim, _)) = &self.pending {
            if sim.solver.is_quasi_static() {
                return Err(RunError::new_err(
                    "a quasi-static simulation solves its load steps to the end in one go: call finish()",
                ));
            }
        }
        if let Some((sim, opts)) = self.pending.take() {
            self.run = Some(Run::start(sim, opts).map_err(run_error)?);
        }
        Ok(self.run.as_mut().expect("started above"))
    }

    /// Step until `done(run)` says stop, in slices with the interpreter released.
    fn drive(&mut self, py: Python<'_>, mut budget: u64, until: Real) -> PyResult<()> {
        loop {
            // Until a step has been timed, slices of one step.
            let per = if self.step_seconds > 0.0 {
                self.step_seconds
            } else {
                SLICE_SECONDS
            };
            let run = self.running()?;
            if run.done()
                || budget == 0
                || run.simulation().state.time >= until - 0.5 * run.integrator().dt()
            {
                // Back in Python: the state shows every break due, and the output folder every
                // frame written so far.
                run.settle();
                py.detach(|| run.flush_outputs()).map_err(run_error)?;
                return self.sync();
            }
            let n = ((SLICE_SECONDS / per) as u64).clamp(1, budget);
            let t0 = Instant::now();
            let before = run.simulation().state.step;
            let result = py.detach(|| -> hooke_sim::Result<()> {
                for _ in 0..n {
                    if run.done()
                        || run.simulation().state.time >= until - 0.5 * run.integrator().dt()
                    {
                        break;
                    }
                    run.step(&mut Quiet)?;
                }
                Ok(())
            });
            let taken = run.simulation().state.step - before;
            if let Err(e) = result {
                // The views show the state the failure left.
                self.sync()?;
                return Err(run_error(e));
            }
            budget -= taken.min(budget);
            if taken > 0 {
                self.step_seconds = t0.elapsed().as_secs_f64() / taken as f64;
            }
            py.check_signals()?;
        }
    }
}

#[pymethods]
impl PySimulation {
    /// Take `n` explicit steps (fewer if the end time comes first).
    #[pyo3(signature = (n = 1))]
    fn step(&mut self, py: Python<'_>, n: u64) -> PyResult<()> {
        self.drive(py, n, Real::INFINITY)
    }

    /// Step until `until` (s; default: the case's end time), calling `callback(sim)` every
    /// `every` seconds of simulated time if given.
    #[pyo3(signature = (until = None, every = None, callback = None))]
    fn run(
        slf: Bound<'_, Self>,
        until: Option<Real>,
        every: Option<Real>,
        callback: Option<Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let py = slf.py();
        let end = {
            let me = slf.borrow();
            let end_time = me.sim().end_time;
            until.unwrap_or(end_time).min(end_time)
        };
        if let Some(e) = every {
            if !(e.is_finite() && e > 0.0) {
                return Err(CaseError::new_err(format!(
                    "every = {e}: give a positive time (s)"
                )));
            }
        }
        // Start now, so that the time step is known.
        let dt = slf.borrow_mut().running()?.integrator().dt();
        loop {
            let now = slf.borrow().sim().state.time;
            // The next multiple of `every` past the current step (a step lands within half a
            // step of its target).
            let target = match every {
                Some(e) => ((now + 0.5 * dt) / e).floor() * e + e,
                None => end,
            }
            .min(end);
            slf.borrow_mut().drive(py, u64::MAX, target)?;
            if let Some(cb) = &callback {
                cb.call1((slf.clone(),))?;
            }
            let me = slf.borrow();
            let done = me.run.as_ref().is_some_and(|r| r.done());
            if done || me.sim().state.time >= end - 0.5 * dt {
                return Ok(());
            }
        }
    }

    /// What the simulation would do, as `hooke check --json`'s object (JSON text): the
    /// library's report (a few steps timed on a copy of the state; the simulation itself is not
    /// stepped). Only before the first step.
    fn check(&mut self, py: Python<'_>) -> PyResult<String> {
        let Some((sim, _)) = self.pending.as_mut() else {
            return Err(RunError::new_err(
                "check(): the simulation has started; check it before the first step",
            ));
        };
        let scratch = std::env::temp_dir().join(format!(
            "hooke-check-{}-{:p}",
            std::process::id(),
            sim as *const _
        ));
        let report = py.detach(|| sim.check(&scratch)).map_err(run_error)?;
        serde_json::to_string(&report).map_err(|e| RunError::new_err(e.to_string()))
    }

    /// Run to the end time, make the outputs final (last frame, checkpoint, run.json) and
    /// return the summary as JSON text (`hooke run --json`'s keys).
    fn finish(&mut self, py: Python<'_>) -> PyResult<String> {
        if let Some(s) = &self.summary {
            return Ok(s.clone());
        }
        let (summary, ended) = match self.pending.take() {
            // Quasi-static: the load steps, to the end, through the library's driver.
            Some((sim, opts)) if sim.solver.is_quasi_static() => {
                let (summary, ended) = py
                    .detach(|| hooke_sim::run_keeping(sim, opts, &mut Quiet))
                    .map_err(run_error)?;
                let mut v = self
                    .velocity
                    .take()
                    .unwrap_or_else(|| Coords::zeros(ended.body.nodes()));
                v.copy_from(&ended.state.v);
                self.velocity = Some(v);
                (summary, ended)
            }
            pending => {
                self.pending = pending;
                self.drive(py, u64::MAX, Real::INFINITY)?;
                let mut run = self.run.take().expect("started by drive");
                // The velocities at the end, while the integrator that computes them exists.
                let mut v = self
                    .velocity
                    .take()
                    .unwrap_or_else(|| Coords::zeros(run.simulation().body.nodes()));
                run.full_velocity_into(&mut v);
                self.velocity = Some(v);
                py.detach(|| run.finish_keeping(&mut Quiet))
                    .map_err(run_error)?
            }
        };
        let mut v = serde_json::to_value(&summary).map_err(|e| RunError::new_err(e.to_string()))?;
        v["output_dir"] = serde_json::json!(self.out.display().to_string());
        let s = v.to_string();
        self.summary = Some(s.clone());
        self.ended = Some(ended);
        self.sync()?;
        Ok(s)
    }

    /// Simulated time (s).
    #[getter]
    fn time(&self) -> Real {
        self.sim().state.time
    }

    /// Steps taken.
    #[getter]
    fn steps(&self) -> u64 {
        self.sim().state.step
    }

    /// The case's end time (s).
    #[getter]
    fn end_time(&self) -> Real {
        self.sim().end_time
    }

    /// The time step (s), once started.
    #[getter]
    fn dt(&self) -> Option<Real> {
        self.run.as_ref().map(|r| r.integrator().dt())
    }

    #[getter]
    fn nodes(&self) -> usize {
        self.sim().body.nodes()
    }

    #[getter]
    fn springs(&self) -> usize {
        self.sim().body.springs()
    }

    /// Whether the body's springs and nodes are weighted by their cells (`lattice.cell_weights`).
    #[getter]
    fn cell_weighted(&self) -> bool {
        self.sim().cell_weighted
    }

    /// The output folder.
    #[getter]
    fn out(&self) -> String {
        self.out.display().to_string()
    }

    /// Reference positions (m), n x 3, a read-only view without a copy.
    #[getter]
    fn positions<'py>(slf: Bound<'py, Self>) -> Bound<'py, PyArray2<Real>> {
        slf.borrow_mut().remember("positions");
        views::coords(&slf, views::Coords::Positions)
    }

    /// Displacements (m), n x 3, a read-only view without a copy that follows the state: it
    /// shows the displacements after every `step` or `run`.
    #[getter]
    fn displacement<'py>(slf: Bound<'py, Self>) -> Bound<'py, PyArray2<Real>> {
        {
            let mut me = slf.borrow_mut();
            if me.u_home.is_none() {
                me.u_home = Some(me.sim().state.u.as_flat().as_ptr() as usize);
            }
        }
        views::coords(&slf, views::Coords::Displacement)
    }

    /// Velocities (m/s) at the current time (the full step, not leapfrog's half step), n x 3,
    /// a read-only array that follows the state (recomputed in place when `step` or `run`
    /// returns, once it has been asked for).
    #[getter]
    fn velocity<'py>(slf: Bound<'py, Self>) -> PyResult<Bound<'py, PyArray2<Real>>> {
        {
            let mut me = slf.borrow_mut();
            if me.velocity.is_none() {
                me.velocity = Some(Coords::zeros(me.sim().body.nodes()));
                me.sync()?;
            }
        }
        Ok(views::coords(&slf, views::Coords::Velocity))
    }

    /// Damage per node: the fraction of its springs that are broken (0 without fracture),
    /// a read-only array that follows the state like `velocity`.
    #[getter]
    fn damage<'py>(slf: Bound<'py, Self>) -> PyResult<Bound<'py, PyArray1<Real>>> {
        {
            let mut me = slf.borrow_mut();
            if me.damage.is_none() {
                me.damage = Some(vec![0.0; me.sim().body.nodes()]);
                me.sync()?;
            }
        }
        Ok(views::damage(&slf))
    }

    /// Each spring's end nodes, m x 2 (uint32), a read-only view without a copy.
    #[getter]
    fn spring_ends<'py>(slf: Bound<'py, Self>) -> Bound<'py, PyArray2<u32>> {
        slf.borrow_mut().remember("spring_ends");
        views::spring_ends(&slf)
    }

    /// Whether each spring is intact (bool, m), a read-only view without a copy that follows
    /// the state.
    #[getter]
    fn spring_intact<'py>(slf: Bound<'py, Self>) -> Bound<'py, PyArray1<bool>> {
        slf.borrow_mut().remember("spring_intact");
        views::spring_intact(&slf)
    }

    /// The energy ledger now (J) as JSON text (`NAME_energy.csv`'s columns).
    fn energy_json(&mut self) -> PyResult<String> {
        let row = match self.run.as_mut() {
            Some(r) => {
                let b = r.energy();
                EnergyRow::from_balance(r.simulation().state.time, &b)
            }
            None => {
                return Err(RunError::new_err(
                    "the energy ledger starts with the run: step() or run() first",
                ))
            }
        };
        serde_json::to_string(&row).map_err(|e| RunError::new_err(e.to_string()))
    }

    /// Each boundary region's reaction now as JSON text.
    fn reactions_json(&mut self) -> PyResult<String> {
        let r = self
            .run
            .as_mut()
            .ok_or_else(|| {
                RunError::new_err("reactions start with the run: step() or run() first")
            })?
            .reactions();
        serde_json::to_string(&r).map_err(|e| RunError::new_err(e.to_string()))
    }

    /// Springs broken so far and the energy they released (J).
    fn broken(&self) -> (usize, Real) {
        self.sim().broken()
    }

    fn __repr__(&self) -> String {
        let s = self.sim();
        format!(
            "<hooke.Simulation {} lattice, {} nodes, {} springs, t = {:e} s of {:e} s>",
            s.body.lattice.kind.name(),
            s.body.nodes(),
            s.body.springs(),
            s.state.time,
            s.end_time
        )
    }
}

/// Load a case from a file path or from TOML text (`path` then only names it in messages).
#[pyfunction]
#[pyo3(signature = (path, text, out, name, set = Vec::new(), scale = 1.0, command = Vec::new()))]
fn load_case(
    path: PathBuf,
    text: String,
    out: PathBuf,
    name: String,
    set: Vec<String>,
    scale: Real,
    command: Vec<String>,
) -> PyResult<PySimulation> {
    let overrides =
        hooke_case::parse_overrides(&set).map_err(|e| CaseError::new_err(e.to_string()))?;
    let (sim, base) = hooke_case::prepare(&path, &text, scale, &overrides)
        .map_err(|e| CaseError::new_err(e.to_string()))?;
    let opts = RunOptions {
        out,
        name,
        command,
        ..base
    };
    Ok(PySimulation::new(sim, opts))
}

/// `hooke.Builder`'s engine: a simulation under construction, each call applied to the
/// library's builder as it is made ([`spec::Pending`]), so that a mistake raises `CaseError` at
/// the call that made it. The calls are also kept, as data, for the run's provenance (run.json
/// records how the simulation was built, as it records a case file's text).
#[pyclass(module = "hooke._hooke", name = "Builder", unsendable)]
struct PyBuilder {
    pending: spec::Pending,
    lattice: String,
    spacing: Real,
    calls: Vec<serde_json::Value>,
}

#[pymethods]
impl PyBuilder {
    #[new]
    fn new(lattice: &str, spacing: Real) -> PyResult<Self> {
        Ok(PyBuilder {
            pending: spec::Pending::new(lattice, spacing).map_err(CaseError::new_err)?,
            lattice: lattice.to_string(),
            spacing,
            calls: Vec::new(),
        })
    }

    /// Apply the builder method `name` with its argument (numbers, strings, bools, None, and
    /// lists, tuples and dicts of them; numpy scalars and arrays too).
    fn call(&mut self, name: &str, arg: &Bound<'_, PyAny>) -> PyResult<()> {
        let v = to_value(arg)?;
        self.pending.apply(name, &v).map_err(CaseError::new_err)?;
        self.calls.push(serde_json::json!([name, v]));
        Ok(())
    }

    /// The simulation, writing to `out` (files named `name`) once it steps. The builder stays
    /// usable: building again gives another simulation of the same body.
    fn build(&self, out: PathBuf, name: String) -> PyResult<PySimulation> {
        let sim = self.pending.build().map_err(CaseError::new_err)?;
        let mut opts = RunOptions::new(out, name);
        opts.command = vec!["python".into(), "hooke.Builder".into()];
        opts.case_text = serde_json::json!({
            "lattice": self.lattice, "spacing": self.spacing, "calls": self.calls,
        })
        .to_string();
        Ok(PySimulation::new(sim, opts))
    }
}

/// A Python value as plain data: None, bools, numbers, strings, and sequences and dicts of
/// them (numpy scalars through `float` or `int`, arrays through `tolist`).
fn to_value(o: &Bound<'_, PyAny>) -> PyResult<serde_json::Value> {
    use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
    use serde_json::Value;
    if o.is_none() {
        return Ok(Value::Null);
    }
    if let Ok(b) = o.cast::<PyBool>() {
        return Ok(Value::Bool(b.is_true()));
    }
    if o.is_instance_of::<PyInt>() {
        if let Ok(i) = o.extract::<i64>() {
            return Ok(Value::from(i));
        }
        return Ok(Value::from(o.extract::<u64>()?));
    }
    if o.is_instance_of::<PyFloat>() {
        return Ok(Value::from(o.extract::<f64>()?));
    }
    if o.is_instance_of::<PyString>() {
        return Ok(Value::String(o.extract::<String>()?));
    }
    if let Ok(d) = o.cast::<PyDict>() {
        let mut m = serde_json::Map::new();
        for (k, v) in d.iter() {
            let k: String = k
                .extract()
                .map_err(|_| CaseError::new_err(format!("{k}: a key must be a string")))?;
            m.insert(k, to_value(&v)?);
        }
        return Ok(Value::Object(m));
    }
    if o.is_instance_of::<PyList>() || o.is_instance_of::<PyTuple>() {
        let items = o
            .try_iter()?
            .map(|x| to_value(&x?))
            .collect::<PyResult<_>>()?;
        return Ok(Value::Array(items));
    }
    if o.hasattr("tolist")? {
        // numpy: arrays become lists and scalars Python numbers.
        return to_value(&o.call_method0("tolist")?);
    }
    if o.hasattr("__index__")? {
        return Ok(Value::from(o.call_method0("__index__")?.extract::<i64>()?));
    }
    if o.hasattr("__float__")? {
        return Ok(Value::from(o.call_method0("__float__")?.extract::<f64>()?));
    }
    Err(CaseError::new_err(format!(
        "{}: give numbers, strings, bools, lists or dicts",
        o.repr()?
    )))
}

/// `hooke moduli ... --json`'s object as JSON text, from the experiment's options as JSON (the
/// command's flags by name: `{"lattice": "cubic", "nu": 0.3, "size": [21, 6, 6]}`): the same
/// library call as the command's, so the same keys and numbers.
#[pyfunction]
fn moduli_json(py: Python<'_>, options: &str) -> PyResult<String> {
    let opts: hooke_lab::moduli::ModuliOptions = serde_json::from_str(options)
        .map_err(|e| CaseError::new_err(format!("hooke.moduli: {e}")))?;
    let v = py
        .detach(|| hooke_lab::moduli::value(&opts))
        .map_err(|e| CaseError::new_err(format!("{e:#}")))?;
    Ok(v.to_string())
}

/// `hooke toughness ... --json`'s object (one `nu`) as JSON text, from the options as JSON, like
/// [`moduli_json`].
#[pyfunction]
fn toughness_json(py: Python<'_>, options: &str) -> PyResult<String> {
    let opts: hooke_lab::toughness::ToughnessOptions = serde_json::from_str(options)
        .map_err(|e| CaseError::new_err(format!("hooke.toughness: {e}")))?;
    let v = py
        .detach(|| hooke_lab::toughness::value(&opts))
        .map_err(|e| CaseError::new_err(format!("{e:#}")))?;
    Ok(v.to_string())
}

#[pymodule]
fn _hooke(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // As the `hooke` binary: calibrations of anisotropic random-lattice materials are kept
    // between processes ($HOOKE_CACHE, or the user's cache directory).
    hooke_core::random::anisotropic::set_cache_dir(hooke_sys::cache_dir());
    // As the binary: HOOKE_NO_SIMD and HOOKE_SIMD=avx2 choose the kernels' paths (same bits).
    hooke_core::kernel::set_simd(hooke_core::kernel::Simd::from_env_values(
        std::env::var_os("HOOKE_NO_SIMD").is_some(),
        std::env::var("HOOKE_SIMD").ok().as_deref(),
    ));
    m.add_class::<PySimulation>()?;
    m.add_function(wrap_pyfunction!(load_case, m)?)?;
    m.add_class::<PyBuilder>()?;
    m.add_function(wrap_pyfunction!(moduli_json, m)?)?;
    m.add_function(wrap_pyfunction!(toughness_json, m)?)?;
    m.add("CaseError", m.py().get_type::<CaseError>())?;
    m.add("RunError", m.py().get_type::<RunError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
