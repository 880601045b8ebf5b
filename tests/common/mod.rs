//! Helpers shared by the integration tests: synthetic grids and statistics.
#![allow(dead_code, unused_imports)]
pub mod blur;
pub mod boxes;
pub mod cli;
pub mod culled;
pub mod external;
pub mod farm;
pub mod gpu;
pub mod grids;
pub mod overlap;
pub mod rays;
pub mod reference;
pub mod render;
pub mod scratch;
pub mod sequence;
pub mod stats;
pub mod stress;
pub use grids::*;
pub use stats::*;

/// Writes a fixture file whole (a temporary file renamed into place): the tests of one binary
/// run on several threads, and binaries may run at once, writing the same fixtures; a reader
/// must never see one half written.
pub fn write_whole(path: &std::path::Path, bytes: &[u8]) {
    use std::io::Write;
    brume::film::write_atomically(path, |f| {
        f.write_all(bytes)
            .map_err(|source| brume::film::FilmError::Io {
                action: "write",
                path: path.to_path_buf(),
                source,
            })
    })
    .unwrap_or_else(|e| panic!("{e}"));
}
