//! Errors from writing and reading film outputs. Every variant names the file involved.
use std::path::PathBuf;
use thiserror::Error;

/// What went wrong writing or reading an image or a log.
#[derive(Debug, Error)]
pub enum FilmError {
    /// The operating system refused a step (create, write, sync, rename, open).
    #[error("cannot {action} {path}: {source}")]
    Io {
        /// What was being done, e.g. "write" or "read".
        action: &'static str,
        /// The file the caller asked for (not the temporary file).
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The `exr` crate could not encode or decode the file.
    #[error("{path} is not a readable OpenEXR file: {source}")]
    Exr {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: exr::error::Error,
    },
    /// The `exr` crate failed while encoding an image.
    #[error("cannot encode OpenEXR {path}: {source}")]
    ExrEncode {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: exr::error::Error,
    },
    /// The file is an EXR but lacks channels the reader needs.
    #[error("{path} lacks channel(s) {missing:?}; it has {found:?}")]
    MissingChannels {
        /// The file.
        path: PathBuf,
        /// Channels that were needed.
        missing: Vec<String>,
        /// Channels the file has.
        found: Vec<String>,
    },
    /// Parts of the file (or two files being compared) have different pixel sizes.
    #[error("{path}: {what} is {}x{} pixels, expected {}x{}", found.0, found.1, expected.0, expected.1)]
    SizeMismatch {
        /// The file.
        path: PathBuf,
        /// Which part differs.
        what: String,
        /// The size that was expected, (width, height).
        expected: (usize, usize),
        /// The size found.
        found: (usize, usize),
    },
    /// Caller-supplied data that cannot be written (a bad attribute name, a pixel buffer of
    /// the wrong length).
    #[error("cannot write {path}: {reason}")]
    InvalidInput {
        /// The file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// A Brume EXR whose content does not match its `brume:checksum` (damaged on disk or in
    /// transfer), or that lacks the checksum where one is required.
    #[error("{path} is damaged: {reason}")]
    Corrupt {
        /// The file.
        path: PathBuf,
        /// What does not match.
        reason: String,
    },
    /// A line of a tile log that is not a tile record.
    #[error("{path}:{line}: not a tile record: {source}")]
    BadLogLine {
        /// The log file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// The JSON error.
        source: serde_json::Error,
    },
}

impl FilmError {
    pub(crate) fn io(action: &'static str, path: &std::path::Path, source: std::io::Error) -> Self {
        FilmError::Io {
            action,
            path: path.to_path_buf(),
            source,
        }
    }
}
