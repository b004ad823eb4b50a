//! `run.json`: what a run was, so that a result can be traced to the code, the input and the
//! machine that made it.
//!
//! Written when the run starts (status `running`) and rewritten when it ends, with the status
//! `completed`, `interrupted ...` or `failed: ...` and the end time. Keys: `hooke_version`,
//! `git_commit`, `command`, `case`, `constants` (`lattice`, `nodes`, `springs`, `k` or `kappa`,
//! `q`, `nu`, `criterion`, `dt`, `dt_critical`, `quasi_static_steps`), `threads`, `start_time`,
//! `end_time`, `status`, `resumed_from`, `physics` (the `key = value` lines the checkpoint digest
//! covers) and, in a resumed run, `previous` (the records of the runs it continues).

use std::time::{SystemTime, UNIX_EPOCH};

use hooke_core::dynamics::Integrator;
use serde_json::{json, Value};

use crate::error::{Error, Result};
use crate::run::RunOptions;
use crate::Simulation;

/// The provenance record of one run, kept to be completed at its end.
pub struct Provenance {
    doc: Value,
}

/// The git commit this library was built from (`-dirty` with uncommitted changes).
pub const GIT_COMMIT: &str = env!("HOOKE_GIT_COMMIT");

/// UTC time as RFC 3339 (`2026-11-30T10:15:00Z`).
pub fn utc_now() -> String {
    let secs = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_secs()) as i64;
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    // Days since 1970-01-01 to a civil date, in 400-year eras of 146 097 days.
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

impl Provenance {
    /// Write `run.json` for a run that starts now.
    pub fn start(sim: &Simulation, opts: &RunOptions, it: Option<&Integrator>) -> Result<Self> {
        let kind = sim.body.lattice.kind;
        let nu = hooke_core::material::nu_from_q(kind, sim.q);
        let mut constants = json!({
            "lattice": kind.name(),
            "dimension": sim.body.lattice.dim(),
            "spacing": sim.body.lattice.spacing,
            "nodes": sim.nodes(),
            "springs": sim.springs(),
            "q": sim.q,
            "nu": nu,
            "springs_precracked": sim.precracked,
            "criterion": sim.fracture.as_ref().map(|f| format!("{:?}", f.criterion())),
            "quasi_static_steps": sim.solver.quasi_static_steps(),
        });
        let key = if kind.is_random() { "kappa" } else { "k" };
        constants[key] = json!(sim.k);
        if !sim.materials.is_empty() {
            // The frames' `material` field is each node's index into this list.
            constants["materials"] = json!(sim.materials);
        }
        if let Some(it) = it {
            constants["dt"] = json!(it.dt());
            constants["dt_critical"] = json!(it.stable().dt_critical);
            constants["kernel"] = json!(it.kernel().name());
        }
        let doc = json!({
            "hooke_version": env!("CARGO_PKG_VERSION"),
            "git_commit": GIT_COMMIT,
            "command": opts.command,
            "case": opts.case_text,
            "physics": opts.physics,
            "constants": constants,
            "schedule": {
                "end_time": sim.end_time,
                "output_every": sim.output_every,
                "checkpoint_every": sim.checkpoint_every,
                "reactions_every": sim.reactions_every,
            },
            "threads": rayon::current_num_threads(),
            "resumed_from": opts.resume.as_ref().map(|p| p.display().to_string()),
            "start_time": utc_now(),
            "end_time": Value::Null,
            "status": "running",
        });
        let mut doc = doc;
        // A resumed run keeps the records of the runs it continues.
        if opts.resume.is_some() {
            let earlier = std::fs::read_to_string(opts.out.join("run.json"))
                .ok()
                .and_then(|t| serde_json::from_str::<Value>(&t).ok());
            if let Some(mut earlier) = earlier {
                let mut previous = earlier
                    .get_mut("previous")
                    .map(Value::take)
                    .and_then(|v| v.as_array().cloned())
                    .unwrap_or_default();
                if let Some(o) = earlier.as_object_mut() {
                    o.remove("previous");
                }
                previous.push(earlier);
                doc["previous"] = Value::Array(previous);
            }
        }
        let p = Provenance { doc };
        p.write(&opts.out)?;
        Ok(p)
    }

    /// Record the end of the run (best effort: a run that failed to write keeps its first error).
    pub fn end(&mut self, status: &str, out: &std::path::Path) {
        self.doc["end_time"] = json!(utc_now());
        self.doc["status"] = json!(status);
        let _ = self.write(out);
    }

    fn write(&self, out: &std::path::Path) -> Result<()> {
        let path = out.join("run.json");
        let text = serde_json::to_string_pretty(&self.doc).expect("a JSON value serialises");
        hooke_io::vtk::write_atomic(&path, |w| {
            w.write_all(text.as_bytes())
                .map_err(|e| hooke_io::IoError::Io {
                    path: path.clone(),
                    source: e,
                })
        })
        .map_err(Error::from)
    }
}

/// The first key whose value differs between two physics texts (`key = value` lines, as
/// `hooke_case::physics_text` makes them), described with both values.
pub fn physics_difference(then: &str, now: &str) -> Option<String> {
    let parse = |s: &str| -> Vec<(String, String)> {
        s.lines()
            .filter_map(|l| l.split_once(" = "))
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect()
    };
    let (a, b) = (parse(then), parse(now));
    for (k, v) in &a {
        match b.iter().find(|(k2, _)| k2 == k) {
            Some((_, v2)) if v2 == v => {}
            Some((_, v2)) => return Some(format!("{k} ({v} then, {v2} now)")),
            None => return Some(format!("{k} ({v} then, absent now)")),
        }
    }
    b.iter()
        .find(|(k, _)| !a.iter().any(|(k2, _)| k2 == k))
        .map(|(k, v)| format!("{k} (absent then, {v} now)"))
}
