//! What the GPU integrator renders exactly as the CPU would: the scene's limits ([`supports`])
//! and the settings that ask for CPU-only physics ([`supports_with`]); a render beyond them is
//! refused with a one-line reason, and `--backend auto` renders it on the CPU.
use crate::gpu_types::{GPU_CAMERA_POSES, GPU_MAX_NESTED_MEDIA, GPU_MAX_VDB_MEDIA, STACK_NONE};
use crate::render::{RenderScene, RenderSettings};

/// Whether the GPU integrator renders `rs` exactly as the CPU would, else a one-line reason.
pub fn supports(rs: &RenderScene) -> Result<(), String> {
    if rs.nesting_depth > GPU_MAX_NESTED_MEDIA {
        return Err(format!(
            "KHR_materials_volume meshes nested {} deep; the GPU medium stack holds {GPU_MAX_NESTED_MEDIA}",
            rs.nesting_depth
        ));
    }
    if rs.features.nested && rs.homogeneous.len() >= STACK_NONE as usize {
        return Err(format!(
            "{} homogeneous media with nested meshes; the GPU medium stack indexes fewer than {STACK_NONE}",
            rs.homogeneous.len()
        ));
    }
    if rs.vdb.len() > GPU_MAX_VDB_MEDIA {
        return Err(format!(
            "{} VDB media; the GPU integrator binds at most {GPU_MAX_VDB_MEDIA}",
            rs.vdb.len()
        ));
    }
    if let Some(m) = rs
        .scene
        .camera_motion
        .as_ref()
        .filter(|m| m.poses.len() != GPU_CAMERA_POSES)
    {
        return Err(format!(
            "a camera moving through {} poses; the GPU interpolates {GPU_CAMERA_POSES}",
            m.poses.len()
        ));
    }
    if rs.vdb.iter().any(|m| m.motion.is_some()) {
        return Err(
            "a medium node moving during the shutter (transformation blur of media renders on the \
             CPU backend only)"
                .into(),
        );
    }
    if rs.scene.moving_meshes.is_some() {
        return Err(
            "a mesh moving during the shutter (transformation blur of meshes renders on the CPU \
             backend only)"
                .into(),
        );
    }
    let of_voxels = |m: &crate::render::media::VdbMedium| {
        let blackbody = m.emission.as_ref().and_then(|e| e.blackbody.as_ref());
        blackbody.is_some_and(|b| b.of_voxels)
    };
    if rs.vdb.iter().any(of_voxels) {
        return Err(
            "the blackbody of each voxel (--blackbody voxels) renders on the CPU backend only"
                .into(),
        );
    }
    if rs.lights.moving() {
        return Err(
            "a light moving during the shutter (transformation blur of lights renders on the CPU \
             backend only)"
                .into(),
        );
    }
    if rs.scene.triangle_count() >= crate::scene::NO_INDEX as usize {
        return Err(format!(
            "{} triangles; the GPU integrator indexes fewer than 2^32",
            rs.scene.triangle_count()
        ));
    }
    Ok(())
}

/// [`supports`] for a render with `settings`: the GPU mirrors every sampling setting the CPU
/// takes (equiangular sampling and emitting media sampled as lights included), so the scene
/// alone decides.
pub fn supports_with(rs: &RenderScene, _settings: &RenderSettings) -> Result<(), String> {
    supports(rs)
}
