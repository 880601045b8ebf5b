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
//! nodes), [`wavefront`] (path state, queues, counters, parameters, emission), [`motion`]
//! (velocity blur, the shutter and the camera's poses), [`phase`] (a medium's phase function)
//! and [`layout`]
//! (the layout table the WGSL test checks).
/// A `#[repr(u32)]` enumeration that the WGSL sees as `const NAME: u32 = value;` lines
/// (`backend::gpu::shader`): each variant's value and WGSL name written once, with `ALL` (every
/// variant in declaration order), `wgsl_name` and `wgsl_constants`.
macro_rules! wgsl_enum {
    (
        $(#[$meta:meta])*
        pub enum $name:ident {
            $( $(#[$vmeta:meta])* $variant:ident = $value:literal => $wgsl:literal, )*
        }
    ) => {
        $(#[$meta])*
        #[repr(u32)]
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub enum $name {
            $( $(#[$vmeta])* $variant = $value, )*
        }

        impl $name {
            pub const ALL: [$name; [$($value),*].len()] = [$($name::$variant),*];

            /// The WGSL constant's name.
            pub fn wgsl_name(self) -> &'static str {
                match self {
                    $( $name::$variant => $wgsl, )*
                }
            }

            /// Every variant as a WGSL `const NAME: u32 = value;` line.
            pub fn wgsl_constants() -> String {
                Self::ALL
                    .iter()
                    .map(|&v| format!("const {}: u32 = {}u;\n", v.wgsl_name(), v as u32))
                    .collect()
            }
        }
    };
}

pub mod envmap;
pub mod geometry;
pub mod grid;
pub mod layout;
pub mod motion;
pub mod phase;
pub mod tracking;
pub mod wavefront;

pub use crate::volume::CellBounds;
pub use envmap::*;
pub use geometry::*;
pub use grid::*;
pub use layout::*;
pub use motion::*;
pub use phase::*;
pub use tracking::*;
pub use wavefront::*;
