//! What can stop a simulation, sorted by whose it is to fix.

use std::path::PathBuf;

use hooke_core::Real;

/// An error of a run.
///
/// [`Error::is_input`] tells input errors (the caller's to fix: a bad case, a refused resume, a
/// full disk) from failures of the run itself (instability, a solver that did not converge).
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// What was asked for cannot run; the message says what to change.
    #[error("{0}")]
    Input(String),
    /// The observer asked to stop. What is named here was written before returning.
    #[error("{}", interrupted_message(.step, .time, .checkpoint.as_ref(), .load_steps.as_ref()))]
    Interrupted {
        step: u64,
        time: Real,
        /// The checkpoint to continue from (explicit runs).
        checkpoint: Option<PathBuf>,
        /// Quasi-static runs: (load step reached, load steps in all).
        load_steps: Option<(usize, usize)>,
    },
    #[error(transparent)]
    Core(#[from] hooke_core::Error),
    #[error(transparent)]
    Io(#[from] hooke_io::IoError),
    /// A file of the run could not be written.
    #[error("{what}: {source}")]
    File {
        what: String,
        source: std::io::Error,
    },
    /// The run failed (e.g. a quasi-static load step that no solver could equilibrate).
    #[error("{0}")]
    Failed(String),
}

fn interrupted_message(
    step: &u64,
    time: &Real,
    checkpoint: Option<&PathBuf>,
    load_steps: Option<&(usize, usize)>,
) -> String {
    match (load_steps, checkpoint) {
        (Some((k, n)), _) => format!(
            "interrupted after load step {k} of {n}; the last frame is written (quasi-static runs restart from the case)"
        ),
        (None, Some(_)) => format!(
            "interrupted at step {step} (t = {time:e} s); the last frame and a checkpoint are written"
        ),
        (None, None) => format!("interrupted at step {step} (t = {time:e} s)"),
    }
}

impl Error {
    /// Whether the caller's input is at fault (a command line's exit code 2), rather than the run.
    pub fn is_input(&self) -> bool {
        match self {
            Error::Input(_) => true,
            Error::Core(e) => e.is_input_error(),
            _ => false,
        }
    }

    pub(crate) fn file(what: impl Into<String>) -> impl FnOnce(std::io::Error) -> Error {
        let what = what.into();
        move |source| Error::File { what, source }
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
