//! Brume: an offline volumetric renderer for OpenVDB media in glTF scenes.
// Comparisons such as `!(x > 0.0)` are written negated on purpose throughout: NaN fails the
// comparison and so takes the safe branch, with no separate `is_nan` test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
pub mod accel;
pub mod backend;
pub mod farm;
pub mod film;
pub mod gpu_types;
pub mod integrator;
pub mod lab;
pub mod math;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod study;
pub mod volume;
