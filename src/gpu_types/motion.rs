//! Motion blur as the wavefront reads it: a blurred medium's velocity grid and advection
//! ([`GpuVelocityBlur`], `render::media::VelocityBlur`) and the shutter with the camera's poses
//! across it ([`GpuCameraMotion`], `scene::motion::NodeMotion`).
use bytemuck::{Pod, Zeroable};
use std::mem::size_of;

use super::GpuGridInfo;

/// Poses of [`GpuCameraMotion`]: `scene::motion::MOTION_STEPS + 1`.
pub const GPU_CAMERA_POSES: usize = crate::scene::motion::MOTION_STEPS + 1;

/// One medium's velocity motion blur (`VelocityBlur`): the velocity grid's three components
/// in the shared grid buffers ([`GpuGridInfo::cell_offset`]) and the maps of `Advection`, so
/// a lookup at density index point `p` by a sample at time offset `dt` reads
/// `Advection::source(p, dt * factor)`. `factor` 0: the medium is not blurred.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuVelocityBlur {
    /// The x, y and z components (`VectorGrid::components`), each with its own
    /// `cell_offset` and its bricks and constants placed in the shared buffers.
    pub x: GpuGridInfo,
    pub y: GpuGridInfo,
    pub z: GpuGridInfo,
    /// Rows of `Advection::velocity_from_density` (density index space to velocity index
    /// space).
    pub velocity_from_density: [[f32; 4]; 3],
    /// Rows of `Advection::index_from_value` (a velocity value to a density-index
    /// displacement; linear, the fourth column 0).
    pub index_from_value: [[f32; 4]; 3],
    /// Rows of `VelocityBlur::world_from_index` (where emission is looked up).
    pub world_from_index: [[f32; 4]; 3],
    /// `VelocityBlur::factor`: displacement per frame per unit of velocity; 0 without blur.
    pub factor: f32,
    /// 1 for a staggered (MAC) velocity grid (`VectorGrid::staggered`).
    pub staggered: u32,
    pub _pad0: u32,
    pub _pad1: u32,
}
const _: () = assert!(size_of::<GpuVelocityBlur>() == 3 * 96 + 3 * 48 + 16);

/// The shutter each camera sample draws its time over (`RenderScene::shutter`) and the
/// camera's poses across it (`NodeMotion`), rotation and position at
/// [`GPU_CAMERA_POSES`] evenly spaced times from open to close.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuCameraMotion {
    /// `Shutter::open`, frames from the frame's time.
    pub open: f32,
    /// `Shutter::close`.
    pub close: f32,
    /// 1 when samples draw a time (`RenderScene::shutter` is `Some`).
    pub timed: u32,
    /// 1 when the camera moves (`Scene::camera_motion`); else `GpuWavefrontParams::camera`.
    pub moves: u32,
    /// `world_from_camera`'s rotation at each pose, a quaternion `(x, y, z, w)`.
    pub rotation: [[f32; 4]; GPU_CAMERA_POSES],
    /// `world_from_camera`'s translation at each pose (`w` unused).
    pub translation: [[f32; 4]; GPU_CAMERA_POSES],
}
const _: () = assert!(size_of::<GpuCameraMotion>() == 16 + 2 * 16 * GPU_CAMERA_POSES);

impl Default for GpuCameraMotion {
    fn default() -> Self {
        Zeroable::zeroed()
    }
}
