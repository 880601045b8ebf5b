//! Motion blur on the GPU against the CPU: the uniform-velocity and vortex fixtures of
//! `tests/physics/motion_blur.rs`, the `plume_blur` example and a moving camera agree with the
//! CPU render (another seed) pixel by pixel, on 4 x 4 blocks and in the image means, with no
//! majorant violation on either device; the moving camera's GPU image differs from the still
//! frame's, and the mixture variant (every medium a `vdb_media` entry) advects as the one-medium
//! variant does.
use crate::common;
use common::blur;
use common::gpu::gpu_or_skip;
use common::render::*;

use brume::backend::cpu::RenderOutput;
use brume::backend::gpu::GpuContext;
use brume::render::{Estimator, MajorantMode, RenderScene, RenderSettings};
use brume::scene::Scene;

use super::render::{agree, gpu_render};

fn settings(w: u32, h: u32, spp: u32, seed: u32) -> RenderSettings {
    RenderSettings {
        width: w,
        height: h,
        spp,
        seed,
        ..RenderSettings::default()
    }
}

/// Majorant violations counted over a render's tiles.
fn violations(out: &RenderOutput) -> u64 {
    brume::film::totals(&out.records)
        .counters
        .majorant_violations
}

/// Renders `s` on the GPU and with another seed on the CPU; asserts that they agree per pixel
/// and in the image means ([`agree`]) and on 4 x 4 blocks, all at level `alpha`, and that
/// neither walk saw a density above its majorant. Returns the GPU image.
fn blurred_agree(
    ctx: &GpuContext,
    scene: &Scene,
    s: &RenderSettings,
    label: &str,
    alpha: f64,
) -> RenderOutput {
    let rs = RenderScene::new(scene, s.force_spectral).unwrap();
    assert!(rs.shutter.is_some(), "{label}: the scene moves");
    let g = gpu_render(ctx, scene, s, label);
    let c = render(
        scene,
        &RenderSettings {
            seed: s.seed + 1000,
            ..s.clone()
        },
    );
    agree(label, &g, &c, alpha);
    let (w, h) = (s.width as usize, s.height as usize);
    let blocks = compare_renders(&g, &c, w, h, 4, alpha);
    println!(
        "{label}: 4x4 blocks: {} of {} values fail (worst z {:.2}, threshold {:.2})",
        blocks.failing, blocks.pixels, blocks.worst_z, blocks.z_threshold
    );
    assert_eq!(blocks.failing, 0, "{label}: {blocks:?}");
    let (vg, vc) = (violations(&g), violations(&c));
    println!("{label}: majorant violations GPU {vg}, CPU {vc}");
    assert_eq!(vg, 0, "{label}: GPU majorant violations");
    assert_eq!(vc, 0, "{label}: CPU majorant violations");
    g
}

/// The blurred GPU image is not the still frame's: at least `min` values of 4 x 4 block means
/// differ from those of the CPU's still render (at eight times the samples) by the z-test.
fn differs_from_still(
    g: &RenderOutput,
    still: &Scene,
    s: &RenderSettings,
    label: &str,
    min: usize,
) {
    let c = render(
        still,
        &RenderSettings {
            spp: 8 * s.spp,
            ..s.clone()
        },
    );
    let (w, h) = (s.width as usize, s.height as usize);
    let apart = compare_renders(g, &c, w, h, 4, 1e-3);
    println!(
        "{label}: against the still frame: {} of {} block values fail (worst z {:.2})",
        apart.failing, apart.pixels, apart.worst_z
    );
    assert!(apart.failing >= min, "{label}: {apart:?}");
}

/// The uniform velocity: every estimator on the adaptive walk, and weighted decomposition on
/// the per-leaf walk, over the blur's dilated bounds.
#[test]
fn uniform_velocity_blur_agrees_with_the_cpu() {
    let Some(ctx) = gpu_or_skip("uniform_velocity_blur_agrees_with_the_cpu") else {
        return;
    };
    let (blurred, _) = blur::uniform_velocity_scenes("gpu_uniform");
    let configs = Estimator::ALL
        .map(|e| (e, MajorantMode::Adaptive))
        .into_iter()
        .chain([(Estimator::WeightedDecomposition, MajorantMode::Leaf)])
        .collect::<Vec<_>>();
    let alpha = 1e-3 / configs.len() as f64;
    for (i, (estimator, majorant)) in configs.into_iter().enumerate() {
        let s = RenderSettings {
            estimator,
            majorant,
            ..settings(16, 16, 64, 11 + i as u32)
        };
        let label = format!("uniform blur {estimator} {majorant:?}");
        blurred_agree(&ctx, &blurred, &s, &label, alpha);
    }
}

/// The vortex (a staggered velocity grid, velocities per frame): every majorant mode keeps
/// true majorants on the GPU and agrees with the CPU.
#[test]
fn vortex_blur_agrees_with_the_cpu_in_every_mode() {
    let Some(ctx) = gpu_or_skip("vortex_blur_agrees_with_the_cpu_in_every_mode") else {
        return;
    };
    let (blurred, _) = blur::vortex_scenes("gpu_vortex");
    let alpha = 1e-3 / MajorantMode::ALL.len() as f64;
    for (i, majorant) in MajorantMode::ALL.into_iter().enumerate() {
        let s = RenderSettings {
            estimator: Estimator::Delta,
            majorant,
            ..settings(16, 16, 48, 21 + i as u32)
        };
        let label = format!("vortex blur delta {majorant:?}");
        blurred_agree(&ctx, &blurred, &s, &label, alpha);
    }
}

/// The mixture variant (`--generic` compiles every feature in, so even one medium is a
/// `vdb_media` entry): its advected lookups agree with the CPU's.
#[test]
fn the_mixture_variant_blurs_as_the_cpu_does() {
    let Some(ctx) = gpu_or_skip("the_mixture_variant_blurs_as_the_cpu_does") else {
        return;
    };
    let (blurred, _) = blur::uniform_velocity_scenes("gpu_uniform_generic");
    let s = RenderSettings {
        generic: true,
        ..settings(16, 16, 64, 41)
    };
    blurred_agree(&ctx, &blurred, &s, "uniform blur, mixture variant", 1e-3);
}

/// `scenes/plume_blur.gltf`, the example: an emitting plume advected by its fluid cache's
/// velocity.
#[test]
fn plume_blur_example_agrees_with_the_cpu() {
    let Some(ctx) = gpu_or_skip("plume_blur_example_agrees_with_the_cpu") else {
        return;
    };
    let scene = load_scene("plume_blur.gltf");
    let s = settings(16, 12, 32, 51);
    blurred_agree(&ctx, &scene, &s, "plume_blur.gltf", 1e-3);
}

/// A camera sliding sideways under the shutter: each sample's pose interpolated at its time.
#[test]
fn camera_motion_blur_agrees_with_the_cpu() {
    let Some(ctx) = gpu_or_skip("camera_motion_blur_agrees_with_the_cpu") else {
        return;
    };
    let (moving, still) = blur::moving_camera_scenes("gpu_camera");
    assert!(moving.camera_motion.is_some(), "the camera moves");
    let s = settings(16, 16, 64, 61);
    let g = blurred_agree(&ctx, &moving, &s, "camera blur", 1e-3);
    differs_from_still(&g, &still, &s, "camera blur", 2);
}

/// What the GPU does not mirror yet, a moving light, medium node or mesh, is refused with a
/// one-line reason (the CPU backend renders it).
#[test]
fn moving_lights_media_and_meshes_are_refused_with_a_reason() {
    let refused = |name: &str, scene: &brume::scene::Scene| {
        let rs = RenderScene::new(scene, false).unwrap();
        let why = brume::backend::gpu::supports(&rs).expect_err("not mirrored on the GPU");
        println!("moving {name}: refused: {why}");
        assert!(
            why.contains(name) && why.contains("CPU") && !why.contains('\n'),
            "{why}"
        );
    };
    refused(
        "mesh",
        &blur::moving_meshes_scene(&blur::dir("gpu_refused_mesh"), None),
    );
    for (name, node, key) in [("light", 1, [1.5, 2.0, 1.0]), ("medium", 2, [0.0; 3])] {
        let d = blur::dir(&format!("gpu_refused_{name}"));
        blur::write_medium(
            &d.join("m.vdb"),
            common::stress::blob_voxels(blur::N),
            blur::origin(),
            [0.0; 3],
            Vec::new(),
            brume_ffi::GridClass::Unknown,
        );
        let render_obj = serde_json::json!({"shutter": {"open": -0.5, "close": 0.5}});
        let mut doc = blur::scene("m.vdb", [0.0; 3], serde_json::json!({}), render_obj);
        let to = [key[0] + 1.0, key[1], key[2]];
        blur::animate_translation(&mut doc, &d, "keys.bin", node, key, to, 2.0 / 24.0);
        refused(name, &blur::load(&d, "moving.gltf", &doc));
    }
}
