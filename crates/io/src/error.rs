//! Errors of the output crate: each names the file and what to do.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum IoError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: cannot write output there ({why}); choose another directory with --out")]
    NotWritable { path: PathBuf, why: String },
    #[error("{path}: VTK writer failed: {msg}")]
    Vtk { path: PathBuf, msg: String },
    #[error("{path}: not a hooke checkpoint, or damaged ({why})")]
    Format { path: PathBuf, why: String },
    #[error("{path}: the checkpoint belongs to another case (digest {found:016x}, this case {expected:016x}); resume with the case that wrote it")]
    DigestMismatch {
        path: PathBuf,
        found: u64,
        expected: u64,
    },
}

pub(crate) fn io(path: &std::path::Path) -> impl FnOnce(std::io::Error) -> IoError + '_ {
    move |source| IoError::Io {
        path: path.to_path_buf(),
        source,
    }
}
