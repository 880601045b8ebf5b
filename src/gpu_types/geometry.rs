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

/// One placement of a stored shape, where the GPU keeps instancing (a scene whose two-level
/// BVH answers the CPU's queries): its transforms, and where its shape's CWBVH nodes and
/// local-space [`GpuTriangle`]s start in the node and triangle buffers. A hit names a
/// scene-wide slot: slot `s` of the placement's shape is `first_slot + s`. The buffer holds
/// the placements in the top-level BVH's primitive order, so `first_slot` grows with the index.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuPlacement {
    /// `world_from_local`'s columns: x axis...
    pub world_x: [f32; 3],
    /// First node of the shape's CWBVH in the node buffer.
    pub node_base: u32,
    /// ...y axis...
    pub world_y: [f32; 3],
    /// First of the shape's triangles in the triangle buffer (its BVH's primitive order).
    pub prim_base: u32,
    /// ...z axis...
    pub world_z: [f32; 3],
    /// Scene-wide slot of the shape's first triangle slot in this placement.
    pub first_slot: u32,
    /// ...and translation.
    pub world_w: [f32; 3],
    /// Index into `Scene::triangles` of the placement's first triangle.
    pub first_triangle: u32,
    /// `local_from_world` (`Affine3A`): x axis...
    pub local_x: [f32; 3],
    /// `PLACEMENT_*` bits.
    pub flags: u32,
    /// ...y axis...
    pub local_y: [f32; 3],
    pub _pad0: u32,
    /// ...z axis...
    pub local_z: [f32; 3],
    pub _pad1: u32,
    /// ...and translation.
    pub local_w: [f32; 3],
    pub _pad2: u32,
    /// Normals map by the inverse transpose of `world_from_local`'s upper 3x3: its columns.
    pub normal_x: [f32; 3],
    pub _pad3: u32,
    pub normal_y: [f32; 3],
    pub _pad4: u32,
    pub normal_z: [f32; 3],
    pub _pad5: u32,
}
const _: () = assert!(size_of::<GpuPlacement>() == 176);

/// [`GpuPlacement::flags`] bit: the transform mirrors, so its world corners 1 and 2 swap.
pub const PLACEMENT_MIRRORED: u32 = 1;
/// [`GpuPlacement::flags`] bit: the shape has no triangles (no ray enters it).
pub const PLACEMENT_EMPTY: u32 = 2;

/// One entry of the area lights' selection CDF (`AreaLights::cdf`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuAreaLight {
    /// Cumulative `area * luminance / total` up to and including this light.
    pub cdf: f32,
    /// Its scene-wide slot: in the [`GpuTriangle`] buffer, or through its [`GpuPlacement`].
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
