//! Watching a run: progress reports and interruption.

use std::time::Duration;

use hooke_core::Real;

/// Where a run stands, handed to [`Observer::progress`].
#[derive(Clone, Debug, serde::Serialize)]
pub struct Progress {
    /// Simulated time (s) and the time to reach.
    pub time: Real,
    pub end_time: Real,
    /// Fraction done, 0 to 1 (of simulated time, or of load steps).
    pub fraction: f64,
    pub step: u64,
    /// Steps (or load steps) per wall-clock second since the run (or the resume) started.
    pub steps_per_second: f64,
    /// Estimated wall-clock seconds left.
    pub eta_seconds: Option<f64>,
    pub broken_springs: usize,
    /// Kinetic + strain energy (J) and the relative energy-balance error, evaluated at
    /// simulated time `energy_time` (s).
    pub energy: Real,
    pub balance: Real,
    /// When `energy` and `balance` were evaluated: `time`, unless the evaluation (a force
    /// evaluation by the reference law) would cost a large body's run more than about 5 % at
    /// this rate of reports, and an earlier one is shown again.
    pub energy_time: Real,
    /// Quasi-static runs: (load step, load steps in all).
    pub load_step: Option<(usize, usize)>,
}

/// Told how a run goes; asked whether to stop.
///
/// The drivers call [`Observer::interrupted`] after every step (keep it cheap: an atomic flag)
/// and [`Observer::progress`] about every [`Observer::progress_interval`] of wall-clock time
/// (a report evaluates the energy when that costs the run at most about 5 %, see
/// [`Progress::energy_time`]).
pub trait Observer {
    /// Wall-clock time between progress reports; `None` (the default): no reports.
    fn progress_interval(&self) -> Option<Duration> {
        None
    }
    fn progress(&mut self, _progress: &Progress) {}
    /// Stop the run now: it writes a frame and a checkpoint and returns
    /// [`crate::Error::Interrupted`].
    fn interrupted(&self) -> bool {
        false
    }
}

/// An observer that watches nothing.
#[derive(Clone, Copy, Debug, Default)]
pub struct Silent;

impl Observer for Silent {}

/// Stops a run when a flag is set (e.g. by a Ctrl-C handler), and reports nothing.
#[derive(Clone, Debug, Default)]
pub struct StopFlag(pub std::sync::Arc<std::sync::atomic::AtomicBool>);

impl Observer for StopFlag {
    fn interrupted(&self) -> bool {
        self.0.load(std::sync::atomic::Ordering::SeqCst)
    }
}
