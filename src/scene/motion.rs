//! Transformation motion blur: the poses of the camera and of media nodes at evenly spaced
//! times across the shutter, from the file's animations, for each camera sample to interpolate
//! at its own time.
use glam::{Affine3A, Mat4, Quat, Vec3};

use super::animation::Animations;
use super::camera;
use super::error::{Ctx, SceneError};
use super::nodes::{self, PlacedNode};
use super::velocity::Shutter;
use crate::math::Aabb;

/// Poses taken across the shutter: enough that interpolating between them follows a
/// CUBICSPLINE or a parent's rotation closely, where Cycles takes three by default.
pub const MOTION_STEPS: usize = 16;

/// A node's pose at `MOTION_STEPS + 1` evenly spaced times of a shutter.
#[derive(Clone, Debug, PartialEq)]
pub struct NodeMotion {
    pub shutter: Shutter,
    /// `(scale, rotation, translation)` of the node's world matrix at each step, open to close.
    pub poses: Vec<(Vec3, Quat, Vec3)>,
}

impl NodeMotion {
    /// The motion of the matrices `steps` (open to close), `None` where they are all equal.
    fn of(shutter: Shutter, steps: impl Iterator<Item = Mat4>) -> Option<NodeMotion> {
        let poses: Vec<_> = steps.map(|m| m.to_scale_rotation_translation()).collect();
        let still = poses.windows(2).all(|w| w[0] == w[1]);
        (!still).then_some(NodeMotion { shutter, poses })
    }

    /// The world matrix at time offset `dt` (frames): the poses on either side interpolated
    /// (scale and position linearly, rotation by slerp), clamped to the shutter.
    pub fn world_from_node(&self, dt: f32) -> Mat4 {
        let steps = (self.poses.len() - 1) as f32;
        let u = ((dt - self.shutter.open) / self.shutter.length()).clamp(0.0, 1.0) * steps;
        let i = (u.floor() as usize).min(self.poses.len() - 2);
        let f = u - i as f32;
        let (s0, r0, t0) = self.poses[i];
        let (s1, r1, t1) = self.poses[i + 1];
        Mat4::from_scale_rotation_translation(
            s0.lerp(s1, f),
            r0.slerp(r1, f).normalize(),
            t0.lerp(t1, f),
        )
    }
}

/// A node's motion relative to its pose at the frame, where what it carries (a medium's
/// fields, a mesh's triangles) is placed: a query at time offset `dt` maps its ray to the
/// frame's pose instead of moving the contents.
#[derive(Clone, Debug)]
pub struct FrameMotion {
    pub node: NodeMotion,
    /// The node's world matrix at the frame.
    pub frame_world_from_node: Mat4,
}

/// Evaluations of the interpolated pose per shutter step when bounding a sweep.
const SWEEP_SUBSTEPS: usize = 8;

impl FrameMotion {
    /// Maps world space at time offset `dt` to world space at the frame: the frame's pose
    /// after the inverse of `dt`'s.
    #[inline]
    pub fn rest_from_world(&self, dt: f32) -> Affine3A {
        Affine3A::from_mat4(self.frame_world_from_node * self.node.world_from_node(dt).inverse())
    }

    /// Maps world space at the frame to world space at time offset `dt`.
    #[inline]
    pub fn world_from_rest(&self, dt: f32) -> Affine3A {
        Affine3A::from_mat4(self.node.world_from_node(dt) * self.frame_world_from_node.inverse())
    }

    /// The world box swept by `bounds` (a box at the frame) over the shutter: the boxes at
    /// `SWEEP_SUBSTEPS` evaluations of the interpolated pose per step, padded by the farthest
    /// a corner moves between two evaluations (the most an interpolated pose strays from the
    /// chord of its neighbours).
    pub fn swept_bounds(&self, bounds: Aabb) -> Aabb {
        if bounds.is_empty() {
            return bounds;
        }
        let n = MOTION_STEPS * SWEEP_SUBSTEPS;
        let shutter = self.node.shutter;
        let corners = |dt: f32| {
            let world_from_rest = self.world_from_rest(dt);
            (0..8).map(move |c| {
                let pick = |a: usize, lo: f32, hi: f32| if c >> a & 1 == 0 { lo } else { hi };
                world_from_rest.transform_point3(Vec3::new(
                    pick(0, bounds.min.x, bounds.max.x),
                    pick(1, bounds.min.y, bounds.max.y),
                    pick(2, bounds.min.z, bounds.max.z),
                ))
            })
        };
        let mut swept = Aabb::EMPTY;
        let mut pad = 0.0f32;
        let mut last: Option<Vec<Vec3>> = None;
        for k in 0..=n {
            let now: Vec<Vec3> = corners(shutter.time(k as f32 / n as f32)).collect();
            if let Some(prev) = &last {
                for (a, b) in prev.iter().zip(&now) {
                    pad = pad.max(a.distance(*b));
                }
            }
            for p in &now {
                swept = swept.union_point(*p);
            }
            last = Some(now);
        }
        Aabb::new(swept.min - Vec3::splat(pad), swept.max + Vec3::splat(pad))
    }
}

/// Every node placed at each of the shutter's `MOTION_STEPS + 1` times, `None` where nothing
/// can move (no animation, or the shutter closed). The placements' warnings repeat the load's
/// and are dropped.
pub fn placements(
    path: &std::path::Path,
    doc: &gltf::Document,
    animations: &Animations,
    frame: i32,
    fps: f32,
    shutter: Shutter,
) -> Result<Option<Vec<Vec<PlacedNode>>>, SceneError> {
    if !shutter.is_open() || animations.is_empty() {
        return Ok(None);
    }
    let mut scratch = Ctx::new(path);
    (0..=MOTION_STEPS)
        .map(|k| {
            let dt = shutter.time(k as f32 / MOTION_STEPS as f32);
            let pose = animations.pose((frame as f32 + dt) / fps);
            nodes::place_nodes(&mut scratch, doc, &pose)
        })
        .collect::<Result<Vec<_>, _>>()
        .map(Some)
}

/// The camera's motion across the shutter: `wanted` picks the camera as the scene's load does;
/// `None` where it stands still.
pub fn camera_motion(
    path: &std::path::Path,
    doc: &gltf::Document,
    steps: &[Vec<PlacedNode>],
    wanted: Option<&str>,
    bounds: &Aabb,
    shutter: Shutter,
) -> Result<Option<NodeMotion>, SceneError> {
    let mut scratch = Ctx::new(path);
    let cameras = steps
        .iter()
        .map(|placed| {
            Ok(camera::choose_camera(&mut scratch, doc, placed, wanted, bounds)?.world_from_camera)
        })
        .collect::<Result<Vec<_>, SceneError>>()?;
    Ok(NodeMotion::of(shutter, cameras.into_iter()))
}

/// The motion of the node placed `placement`-th (in `nodes::place_nodes`' order) across the
/// shutter; `None` where it stands still.
pub fn placement_motion(
    steps: &[Vec<PlacedNode>],
    placement: usize,
    shutter: Shutter,
) -> Option<NodeMotion> {
    NodeMotion::of(
        shutter,
        steps.iter().map(|placed| placed[placement].world_from_node),
    )
}
