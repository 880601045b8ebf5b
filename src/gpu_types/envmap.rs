//! The environment map as the wavefront kernels read it (`shaders/common/envmap.wgsl`, the
//! mirror of `render::envmap`): this header as a uniform, and one flat `f32` storage
//! buffer holding the pixels (3 floats each, row-major from the top) followed by the
//! distribution's arrays (`sampling::piecewise` layout): `func`, `cond_cdf`, `marg_cdf`.
//! One storage binding keeps the stages that sample lights within the per-stage limit.
use bytemuck::{Pod, Zeroable};
use std::mem::size_of;

/// `EnvironmentMap` for the GPU.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuEnvMap {
    /// Rows of `lookup_from_world` (a rotation): `d = (dot(row0, w), dot(row1, w),
    /// dot(row2, w))`; `w` components unused.
    pub row0: [f32; 4],
    pub row1: [f32; 4],
    pub row2: [f32; 4],
    /// `color * strength`.
    pub scale: [f32; 3],
    /// `PiecewiseConstant2D::integral`.
    pub integral: f32,
    /// Pixels across and down.
    pub width: u32,
    pub height: u32,
    /// Offsets (in floats) of `func`, `cond_cdf` and `marg_cdf` in the data buffer; the
    /// pixels start at 0.
    pub func_offset: u32,
    pub cond_offset: u32,
    pub marg_offset: u32,
    /// 1: uniform sphere sampling (`EnvSampling::Uniform`), 0: importance sampling.
    pub uniform: u32,
    pub _pad0: u32,
    pub _pad1: u32,
}
const _: () = assert!(size_of::<GpuEnvMap>() == 96);

impl GpuEnvMap {
    /// The header and the data buffer of `map`.
    pub fn from_map(map: &crate::render::envmap::EnvironmentMap) -> (GpuEnvMap, Vec<f32>) {
        let m = map.lookup_from_world;
        let row = |r: usize| [m.col(0)[r], m.col(1)[r], m.col(2)[r], 0.0];
        let d = &map.distribution;
        let mut data: Vec<f32> = map.image.rgb.iter().flatten().copied().collect();
        let func_offset = data.len() as u32;
        data.extend_from_slice(&d.func);
        let cond_offset = data.len() as u32;
        data.extend_from_slice(&d.cond_cdf);
        let marg_offset = data.len() as u32;
        data.extend_from_slice(&d.marg_cdf);
        let info = GpuEnvMap {
            row0: row(0),
            row1: row(1),
            row2: row(2),
            scale: map.scale.to_array(),
            integral: d.integral,
            width: map.image.width,
            height: map.image.height,
            func_offset,
            cond_offset,
            marg_offset,
            uniform: (map.sampling == crate::render::envmap::EnvSampling::Uniform) as u32,
            _pad0: 0,
            _pad1: 0,
        };
        (info, data)
    }
}
