//! Against other programs: Cycles 5 through bpy, Mitsuba 3, the Blender add-on, and a single-node
//! Slurm. Each says SKIPPED with the reason where its tool is not installed.
//!
//! One module per concern; `cargo test --release --test external MODULE::` runs one of them.
#[path = "../common/mod.rs"]
mod common;

mod blender_roundtrip;
mod cycles_blur;
mod cycles_compare;
mod cycles_fire;
mod farm_slurm;
mod mitsuba_compare;
