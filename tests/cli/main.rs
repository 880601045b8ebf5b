//! The command line end to end: renders, checkpoints and resumes, outputs under faults, the tev
//! display, farm parts and merges, the study and the benches, and the documentation against
//! the program.
//!
//! One module per concern; `cargo test --release --test cli MODULE::` runs one of them.
#[path = "../common/mod.rs"]
mod common;

mod bench_majorants;
mod bench_peers;
mod blur;
mod cli_faults;
mod display;
mod docs;
mod farm_cli;
mod farm_parts;
mod film;
mod frames;
mod render_cli;
mod study_compare;
mod study_run;
