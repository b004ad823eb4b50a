//! `hooke._hooke`: the extension module under the `hooke` Python package.
//!
//! A thin layer over `hooke-sim` (the run drivers) and `hooke-case` (case files): nothing here
//! steps a body or writes a file by itself. Stepping releases the interpreter in slices of about
//! a tenth of a second and checks for Ctrl-C between slices, so a long `run` stays interruptible
//! and leaves the simulation usable (the KeyboardInterrupt arrives after a whole step).

mod spec;

use std::path::PathBuf;
use std::time::Instant;

use numpy::{PyArray1, PyArray2, PyArrayMethods};
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
            if sim.quasi_static.is_some() {
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
                || run.simulation().state.time >= until - 0.5 * run.integrator().dt
            {
                // Back in Python: the state shows every break due, and the output folder every
                // frame written so far.
                run.settle();
                return py.detach(|| run.flush_outputs()).map_err(run_error);
            }
            let n = ((SLICE_SECONDS / per) as u64).clamp(1, budget);
            let t0 = Instant::now();
            let before = run.simulation().state.step;
            let result = py.detach(|| -> hooke_sim::Result<()> {
                for _ in 0..n {
                    if run.done()
                        || run.simulation().state.time >= until - 0.5 * run.integrator().dt
                    {
                        break;
                    }
                    run.step(&mut Quiet)?;
                }
                Ok(())
            });
            let taken = run.simulation().state.step - before;
            result.map_err(run_error)?;
            budget -= taken.min(budget);
            if taken > 0 {
                self.step_seconds = t0.elapsed().as_secs_f64() / taken as f64;
            }
            py.check_signals()?;
        }
    }
}

fn coords<'py>(py: Python<'py>, c: &Coords) -> Bound<'py, PyArray2<Real>> {
    let n = c.len();
    let mut flat = Vec::with_capacity(3 * n);
    for i in 0..n {
        flat.extend_from_slice(&[c.x[i], c.y[i], c.z[i]]);
    }
    let a = PyArray1::from_vec(py, flat)
        .reshape([n, 3])
        .expect("3n values reshape to n x 3");
    a.readwrite().make_nonwriteable();
    a
}

fn readonly<'py>(py: Python<'py>, v: Vec<Real>) -> Bound<'py, PyArray1<Real>> {
    let a = PyArray1::from_vec(py, v);
    a.readwrite().make_nonwriteable();
    a
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
        let dt = slf.borrow_mut().running()?.integrator().dt;
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

    /// Run to the end time, make the outputs final (last frame, checkpoint, run.json) and
    /// return the summary as JSON text (`hooke run --json`'s keys).
    fn finish(&mut self, py: Python<'_>) -> PyResult<String> {
        if let Some(s) = &self.summary {
            return Ok(s.clone());
        }
        let (summary, ended) = match self.pending.take() {
            // Quasi-static: the load steps, to the end, through the library's driver.
            Some((sim, opts)) if sim.quasi_static.is_some() => py
                .detach(|| hooke_sim::run_keeping(sim, opts, &mut Quiet))
                .map_err(run_error)?,
            pending => {
                self.pending = pending;
                self.drive(py, u64::MAX, Real::INFINITY)?;
                let run = self.run.take().expect("started by drive");
                py.detach(|| run.finish_keeping(&mut Quiet))
                    .map_err(run_error)?
            }
        };
        let mut v = serde_json::to_value(&summary).map_err(|e| RunError::new_err(e.to_string()))?;
        v["output_dir"] = serde_json::json!(self.out.display().to_string());
        let s = v.to_string();
        self.summary = Some(s.clone());
        self.ended = Some(ended);
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
        self.run.as_ref().map(|r| r.integrator().dt)
    }

    #[getter]
    fn nodes(&self) -> usize {
        self.sim().body.nodes()
    }

    #[getter]
    fn springs(&self) -> usize {
        self.sim().body.springs()
    }

    /// The output folder.
    #[getter]
    fn out(&self) -> String {
        self.out.display().to_string()
    }

    /// Reference positions (m), n x 3, read-only.
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<Real>> {
        coords(py, &self.sim().body.lattice.pos)
    }

    /// Displacements (m), n x 3, read-only.
    #[getter]
    fn displacement<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<Real>> {
        coords(py, &self.sim().state.u)
    }

    /// Velocities (m/s) at the last half step (leapfrog), n x 3, read-only.
    #[getter]
    fn velocity<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<Real>> {
        coords(py, &self.sim().state.v)
    }

    /// Damage per node: the fraction of its springs that are broken (0 without fracture).
    #[getter]
    fn damage<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<Real>> {
        let sim = self.sim();
        let d = match &sim.fracture {
            Some(f) => f.damage(&sim.body, &sim.state),
            None => vec![0.0; sim.body.nodes()],
        };
        readonly(py, d)
    }

    /// Each spring's end nodes, m x 2 (int64), read-only.
    #[getter]
    fn spring_ends<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<i64>> {
        let ends = &self.sim().body.lattice.bonds.ends;
        let flat: Vec<i64> = ends
            .iter()
            .flat_map(|e| [e[0] as i64, e[1] as i64])
            .collect();
        let a = PyArray1::from_vec(py, flat)
            .reshape([ends.len(), 2])
            .expect("2m values reshape to m x 2");
        a.readwrite().make_nonwriteable();
        a
    }

    /// Whether each spring is intact (bool, m), read-only.
    #[getter]
    fn spring_intact<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        let a = PyArray1::from_slice(py, self.sim().state.alive());
        a.readwrite().make_nonwriteable();
        a
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

/// A simulation built from a `hooke.Builder` spec (JSON text).
#[pyfunction]
fn build(spec: &str, out: PathBuf, name: String) -> PyResult<PySimulation> {
    let v: serde_json::Value =
        serde_json::from_str(spec).map_err(|e| CaseError::new_err(format!("builder spec: {e}")))?;
    let sim = spec::build(&v).map_err(CaseError::new_err)?;
    let mut opts = RunOptions::new(out, name);
    opts.command = vec!["python".into(), "hooke.Builder".into()];
    opts.case_text = spec.to_string();
    Ok(PySimulation::new(sim, opts))
}

/// `hooke COMMAND FLAGS --json` as JSON text, for the commands that return one object
/// (`moduli`, `toughness`): the command's own parser and numbers.
#[pyfunction]
fn command_json(py: Python<'_>, command: &str, flags: Vec<String>) -> PyResult<String> {
    let run = match command {
        "moduli" => hooke_cli::moduli_json,
        "toughness" => hooke_cli::toughness_json,
        _ => return Err(CaseError::new_err(format!("{command}: not a JSON command"))),
    };
    let v = py
        .detach(|| run(&flags))
        .map_err(|e| CaseError::new_err(format!("{e:#}")))?;
    Ok(v.to_string())
}

#[pymodule]
fn _hooke(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PySimulation>()?;
    m.add_function(wrap_pyfunction!(load_case, m)?)?;
    m.add_function(wrap_pyfunction!(build, m)?)?;
    m.add_function(wrap_pyfunction!(command_json, m)?)?;
    m.add("CaseError", m.py().get_type::<CaseError>())?;
    m.add("RunError", m.py().get_type::<RunError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
