//! Surfaces and lights as the wavefront integrator reads them: triangles in BVH order, the
//! area lights' CDF, homogeneous media, and obvhs' CWBVH node layout.
use bytemuck::{Pod, Zeroable};
use std::mem::{offset_of, size_of};

use super::{GpuPhase, StructLayout};

/// One triangle as the GPU's ray queries and shading read it, in the BVH's primitive order
/// (`CwBvh::primitive_indices`): entry `k` is scene triangle `triangle`. Positions and normals
/// are the scene's world-space vertices; the material's surface kind and interior medium are
/// copied in so that shadow rays need no material lookup.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTriangle {
    /// First corner, world space, metres.
    pub p0: [f32; 3],
    /// Index into `Scene::triangles`.
    pub triangle: u32,
    /// Second corner.
    pub p1: [f32; 3],
    /// Index into `Scene::materials`.
    pub material: u32,
    /// Third corner.
    pub p2: [f32; 3],
    /// `AreaLights` selection density of this triangle, `area * luminance / total` divided by
    /// its area, i.e. `luminance / total` (0 when it is not an area light).
    pub light_pdf: f32,
    /// Shading normal at the first corner (all zero when the file gives none).
    pub n0: [f32; 3],
    /// `SURFACE_*` kind of the material (`prepare::SurfaceKind`).
    pub kind: u32,
    /// Shading normal at the second corner.
    pub n1: [f32; 3],
    /// `Material::interior_medium` (`NO_INDEX`: none).
    pub interior: u32,
    /// Shading normal at the third corner.
    pub n2: [f32; 3],
    /// Padding to a 16-byte row.
    pub _pad0: u32,
}
const _: () = assert!(size_of::<GpuTriangle>() == 96);

/// One entry of the area lights' selection CDF (`AreaLights::cdf`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuAreaLight {
    /// Cumulative `area * luminance / total` up to and including this light.
    pub cdf: f32,
    /// Its slot in the [`GpuTriangle`] buffer.
    pub prim: u32,
}
const _: () = assert!(size_of::<GpuAreaLight>() == 8);

/// A homogeneous medium (`render::media::HomogeneousMedium`), coefficients in m^-1.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuHomogeneousMedium {
    /// Absorption coefficient per RGB channel, m^-1.
    pub sigma_a: [f32; 3],
    /// Henyey-Greenstein `g`: the phase function of the variants without `FEATURE_PHASES`
    /// (0 where it is another one; those variants are not built for such a medium).
    pub g: f32,
    /// Scattering coefficient per RGB channel, m^-1.
    pub sigma_s: [f32; 3],
    /// Padding to a 16-byte row.
    pub _pad0: f32,
    /// Its phase function, which the `FEATURE_PHASES` variants read.
    pub phase: GpuPhase,
}
const _: () = assert!(size_of::<GpuHomogeneousMedium>() == 64);

/// The texture coordinates (TEXCOORD_0) of a [`GpuTriangle`]'s corners, same slot.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTriangleUv {
    pub uv0: [f32; 2],
    pub uv1: [f32; 2],
    pub uv2: [f32; 2],
}
const _: () = assert!(size_of::<GpuTriangleUv>() == 24);

/// A texture use (`scene::TextureRef`) with its image's place in the texel pool.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTexture {
    /// `KHR_texture_transform` row `(a, b, c)`: `u' = a u + b v + c`.
    pub row0: [f32; 3],
    /// First texel of the image in the pool.
    pub offset: u32,
    /// Row `(d, e, f)`: `v' = d u + e v + f`.
    pub row1: [f32; 3],
    pub width: u32,
    pub height: u32,
    /// `scene::texture::WRAP_*` along u and v.
    pub wrap_s: u32,
    pub wrap_t: u32,
    /// 1: nearest texel, 0: bilinear.
    pub nearest: u32,
}
const _: () = assert!(size_of::<GpuTexture>() == 48);

/// `SurfaceKind` values of [`GpuTriangle::kind`].
pub const SURFACE_OPAQUE: u32 = 0;
pub const SURFACE_DIELECTRIC: u32 = 1;
pub const SURFACE_NULL: u32 = 2;

/// obvhs' `CwBvhNode` (80 bytes, uploaded as is) as the WGSL struct `CwBvhNode` sees it:
/// the three exponent bytes and `imask` read as one `e_imask` word, each 8-byte array as a
/// `vec2<u32>`.
pub const CWBVH_NODE_LAYOUT: StructLayout = {
    use obvhs::cwbvh::node::CwBvhNode as N;
    StructLayout {
        name: "CwBvhNode",
        size: size_of::<N>(),
        members: &[
            ("p", offset_of!(N, p)),
            ("e_imask", offset_of!(N, e)),
            ("child_base_idx", offset_of!(N, child_base_idx)),
            ("primitive_base_idx", offset_of!(N, primitive_base_idx)),
            ("child_meta", offset_of!(N, child_meta)),
            ("child_min_x", offset_of!(N, child_min_x)),
            ("child_max_x", offset_of!(N, child_max_x)),
            ("child_min_y", offset_of!(N, child_min_y)),
            ("child_max_y", offset_of!(N, child_max_y)),
            ("child_min_z", offset_of!(N, child_min_z)),
            ("child_max_z", offset_of!(N, child_max_z)),
        ],
    }
};
const _: () = assert!(offset_of!(obvhs::cwbvh::node::CwBvhNode, imask) == 15);
