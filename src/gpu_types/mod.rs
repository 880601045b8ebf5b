//! The only home of the structs shared by the host and the WGSL shaders.
//!
//! Rust is the source of truth: every struct here is `#[repr(C)]` + `bytemuck::Pod`, built from
//! 16-byte rows (a `vec3` plus one scalar, a `vec4`, or four scalars) so that the WGSL layout
//! rules (`vec3` aligned to 16) add no hidden padding, with any padding named. The WGSL mirrors
//! live in `shaders/common/types.wgsl`; `tests/gpu/wgsl.rs` parses that file with naga and
//! compares every struct's size and member offsets against [`SHARED_STRUCTS`].
//!
//! Enumerations shared with WGSL ([`GpuEstimator`], ...) are emitted as WGSL `const`s by
//! `backend::gpu::shader`, so their values are written once, here.
//!
//! One file per concern: [`grid`] (grid header, rays, segments), [`tracking`] (tracking
//! parameters and enumerations), [`geometry`] (triangles, lights, homogeneous media, BVH
//! nodes), [`wavefront`] (path state, queues, counters, parameters, emission) and [`layout`]
//! (the layout table the WGSL test checks).
pub mod envmap;
pub mod geometry;
pub mod grid;
pub mod layout;
pub mod tracking;
pub mod wavefront;

pub use crate::volume::CellBounds;
pub use envmap::*;
pub use geometry::*;
pub use grid::*;
pub use layout::*;
pub use tracking::*;
pub use wavefront::*;
