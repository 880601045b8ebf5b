//! The per-render parameters every wavefront stage reads (`GpuWavefrontParams`): camera and
//! its motion, lights, limits, sampling choices and the medium stack around the camera, from
//! the CPU's `RenderScene` as the CPU integrator uses them.
use glam::Vec3;

use super::upload::{affine_rows, medium_params};
use crate::gpu_types::{
    GpuCameraMotion, GpuWavefrontParams, GPU_CAMERA_POSES, STACK_NONE, VOLUME_SAMPLING_DISTANCE,
    VOLUME_SAMPLING_EQUIANGULAR, VOLUME_SAMPLING_MIS, WF_FLAG_GUIDED_LIGHTS,
};
use crate::integrator::glow::{Glows, Lamps};
use crate::render::light_groups::{MAX_LIGHT_GROUPS, NO_GROUP};
use crate::render::settings::Absorption;
use crate::render::{
    media::TrackingConfig, FeatureFlags, RenderScene, RenderSettings, VolumeSampling,
};

/// The shutter samples draw their time over and the camera's poses across it, as
/// `integrator::path::radiance` and `generate` use them.
fn camera_motion(rs: &RenderScene) -> GpuCameraMotion {
    let mut m = GpuCameraMotion::default();
    let Some(shutter) = rs.shutter else {
        return m;
    };
    m.timed = 1;
    m.open = shutter.open;
    m.close = shutter.close;
    if let Some(motion) = &rs.scene.camera_motion {
        // `supports` refuses another number of poses.
        if motion.poses.len() == GPU_CAMERA_POSES {
            m.moves = 1;
            for (k, (_, r, t)) in motion.poses.iter().enumerate() {
                m.rotation[k] = r.to_array();
                m.translation[k] = [t.x, t.y, t.z, 0.0];
            }
        }
    }
    m
}

/// `GpuPathState::outer` of a stack whose entries (outermost first) are `media`: the two
/// below the top as 16-bit halves, `STACK_NONE` where there is none. (`supports` refuses
/// deeper stacks and medium indices that do not fit 16 bits.)
pub(super) fn gpu_outer(media: &[u32]) -> u32 {
    let n = media.len();
    let at = |k: usize| -> u32 {
        if n > k {
            media[n - 1 - k] & STACK_NONE
        } else {
            STACK_NONE
        }
    };
    at(1) | (at(2) << 16)
}

/// The render's `GpuWavefrontParams` before any batch: camera, lights, limits and the VDB
/// medium's tracking parameters (the batch fields are set per batch).
pub(super) fn wavefront_params(
    rs: &RenderScene,
    settings: &RenderSettings,
    cfg: &TrackingConfig,
    features: FeatureFlags,
    slots: u32,
) -> GpuWavefrontParams {
    let (w, h) = (settings.width, settings.height);
    let mut params = GpuWavefrontParams {
        camera: affine_rows(glam::Affine3A::from_mat4(rs.pinhole.world_from_camera)),
        tan_half: rs.pinhole.tan_half,
        aspect: w as f32 / h as f32,
        znear: rs.pinhole.znear,
        seed: settings.seed,
        forward: rs.pinhole.forward.to_array(),
        width: w,
        height: h,
        path_count: slots,
        light_count: rs.lights.punctual.len() as u32,
        env: rs
            .lights
            .environment
            .as_ref()
            .map_or(Vec3::ZERO, |e| e.radiance)
            .to_array(),
        env_pdf: rs.lights.pdf_environment(Vec3::Z),
        max_depth: settings.max_depth,
        rr_depth: settings.rr_depth,
        rr_throughput: settings.rr_throughput,
        absorption_weight: (settings.absorption == Absorption::Weight) as u32,
        max_collisions: settings.max_collisions_per_path.min(u32::MAX as u64) as u32,
        has_env: rs.lights.environment.is_some() as u32,
        camera_medium: rs.camera_medium.unwrap_or(crate::scene::NO_INDEX),
        camera_outer: gpu_outer(rs.camera_media.entries()),
        area_count: rs
            .lights
            .area
            .as_ref()
            .map_or(0, |a| a.triangles.len() as u32),
        continuation_albedo: settings
            .light_selection
            .continuation_albedo(rs.lights.continuation_albedo),
        ..Default::default()
    };
    if rs.lights.guided() && settings.light_selection.guided() {
        params.flags |= WF_FLAG_GUIDED_LIGHTS;
    }
    if settings.film_transparent {
        params.flags |= crate::gpu_types::WF_FLAG_FILM_TRANSPARENT;
    }
    if features.heterogeneous {
        medium_params(rs, cfg, features, &mut params);
    }
    params.motion = camera_motion(rs);
    light_group_params(rs, &mut params);
    // As the CPU: the equiangular strategy only where the scene has point or spot lights.
    params.positional_count = rs.lights.positional.len() as u32;
    params.volume_sampling = match rs.volume_sampling(settings) {
        VolumeSampling::Distance => VOLUME_SAMPLING_DISTANCE,
        VolumeSampling::Equiangular => VOLUME_SAMPLING_EQUIANGULAR,
        VolumeSampling::Mis => VOLUME_SAMPLING_MIS,
    };
    let glows = Glows::of_scene(rs, rs.volume_sampling(settings), cfg.time, w, h);
    params.glow_count = glows.count as u32;
    for (k, c) in glows.centres.iter().enumerate() {
        params.glows[k / 2][2 * (k % 2)..][..2].copy_from_slice(&c.to_array());
    }
    let lamps = Lamps::of_scene(rs, rs.volume_sampling(settings), cfg.time);
    params.lamp_count = lamps.count as u32;
    for (k, p) in lamps.positions.iter().enumerate() {
        params.lamps[k] = p.extend(0.0).to_array();
    }
    params.lit_count = lamps.lit.count as u32;
    for (k, b) in lamps.lit.boxes[..lamps.lit.count].iter().enumerate() {
        params.lit_boxes[2 * k] = b.min.extend(0.0).to_array();
        params.lit_boxes[2 * k + 1] = b.max.extend(0.0).to_array();
    }
    params
}

/// The light groups' fields of `params` (`RenderScene::groups`): the environment's, the
/// emissive surfaces' and each punctual light's group (`NO_GROUP` where none are kept).
fn light_group_params(rs: &RenderScene, params: &mut GpuWavefrontParams) {
    let Some(g) = &rs.groups else {
        params.environment_group = u32::from(NO_GROUP);
        params.surfaces_group = u32::from(NO_GROUP);
        return;
    };
    params.environment_group = u32::from(g.environment);
    params.surfaces_group = u32::from(g.surfaces);
    for (k, &group) in g.punctual.iter().enumerate().take(MAX_LIGHT_GROUPS) {
        params.punctual_groups[k / 4] |= u32::from(group) << (8 * (k % 4));
    }
}
