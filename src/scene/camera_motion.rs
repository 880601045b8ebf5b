//! Transformation motion blur of the camera: its pose at evenly spaced times across the
//! shutter, from the file's animations, for each camera sample to interpolate at its own time.
use glam::{Mat4, Quat, Vec3};

use super::animation::Animations;
use super::error::{Ctx, SceneError};
use super::velocity::Shutter;
use super::{camera, nodes};
use crate::math::Aabb;

/// Poses taken across the shutter: enough that interpolating between them follows a
/// CUBICSPLINE or a parent's rotation closely, where Cycles takes three by default.
pub const CAMERA_MOTION_STEPS: usize = 16;

/// The camera's rigid pose at `steps + 1` evenly spaced times of a shutter.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraMotion {
    pub shutter: Shutter,
    /// `(rotation, translation)` of `world_from_camera` at each step, open to close.
    pub poses: Vec<(Quat, Vec3)>,
}

impl CameraMotion {
    /// `world_from_camera` at time offset `dt` (frames): the poses on either side interpolated
    /// (rotation by slerp, position linearly), clamped to the shutter.
    pub fn world_from_camera(&self, dt: f32) -> Mat4 {
        let steps = (self.poses.len() - 1) as f32;
        let u = ((dt - self.shutter.open) / self.shutter.length()).clamp(0.0, 1.0) * steps;
        let i = (u.floor() as usize).min(self.poses.len() - 2);
        let f = u - i as f32;
        let (r0, t0) = self.poses[i];
        let (r1, t1) = self.poses[i + 1];
        Mat4::from_rotation_translation(r0.slerp(r1, f).normalize(), t0.lerp(t1, f))
    }
}

/// The camera's motion across `shutter` at frame `frame` and `fps`, or `None` where it stands
/// still (no animation moves it, or the shutter is closed). `wanted` picks the camera as the
/// scene's load does; the poses' warnings repeat the load's and are dropped.
#[allow(clippy::too_many_arguments)]
pub fn camera_motion(
    path: &std::path::Path,
    doc: &gltf::Document,
    animations: &Animations,
    wanted: Option<&str>,
    bounds: &Aabb,
    frame: i32,
    fps: f32,
    shutter: Shutter,
) -> Result<Option<CameraMotion>, SceneError> {
    if !shutter.is_open() || animations.is_empty() {
        return Ok(None);
    }
    let mut scratch = Ctx::new(path);
    let mut poses = Vec::with_capacity(CAMERA_MOTION_STEPS + 1);
    for k in 0..=CAMERA_MOTION_STEPS {
        let dt = shutter.time(k as f32 / CAMERA_MOTION_STEPS as f32);
        let pose = animations.pose((frame as f32 + dt) / fps);
        let placed = nodes::place_nodes(&mut scratch, doc, &pose)?;
        let cam = camera::choose_camera(&mut scratch, doc, &placed, wanted, bounds)?;
        let (_, r, t) = cam.world_from_camera.to_scale_rotation_translation();
        poses.push((r, t));
    }
    let still = poses.windows(2).all(|w| w[0] == w[1]);
    Ok((!still).then_some(CameraMotion { shutter, poses }))
}
