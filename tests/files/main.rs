//! Files in and out: EXR accumulation, writing and reading, tile logs, OpenVDB grids against
//! OpenVDB itself, glTF scenes and their bad inputs, textures, bare .vdb files, and mutated inputs
//! that must give clear errors.
//!
//! One module per concern; `cargo test --release --test files MODULE::` runs one of them.
#[path = "../common/mod.rs"]
mod common;

mod bare_vdb;
mod film_accum;
mod film_exr;
mod film_tile_log;
mod fuzz_inputs;
mod scene_examples;
mod scene_gltf;
mod scene_textures;
mod vdb_files;
mod vdb_vectors;
