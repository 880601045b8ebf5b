//! Velocity motion blur: a uniform velocity's blur against the shutter average of renders with
//! the grid translated, a moving absorbing slab's time-averaged transmittance against its
//! closed form, and a vortex's blur with no majorant violation in any majorant mode.
use crate::common::blur::{self, SCALE, V, VOXEL};
use crate::common::render::{block_moments, compare, compare_renders, moments, render, Agreement};

use brume::integrator::features::AllFeatures;
use brume::integrator::media::transmittance_vdb;
use brume::math::Ray;
use brume::render::media::{MediaStats, TrackingConfig};
use brume::render::{Estimator, MajorantMode, RenderScene, RenderSettings};
use brume::sampling::Rng;
use brume_ffi::GridClass;
use glam::Vec3;
use serde_json::json;

fn settings(estimator: Estimator, majorant: MajorantMode, spp: u32, seed: u32) -> RenderSettings {
    RenderSettings {
        width: 16,
        height: 16,
        spp,
        estimator,
        majorant,
        seed,
        ..RenderSettings::default()
    }
}

/// The render of `moving` (512 spp with estimator `e` and majorant `mode`, seed `seed`) against
/// the mean of `statics` (32 spp each, the next seeds): the per-pixel and 4 x 4-block
/// comparisons at level `alpha`, the moving render's majorant violations, and the render.
fn against_shutter_mean(
    moving: &brume::scene::Scene,
    statics: &[brume::scene::Scene],
    e: Estimator,
    mode: MajorantMode,
    seed: u32,
    alpha: f64,
) -> (Agreement, Agreement, u64, brume::backend::cpu::RenderOutput) {
    let out = render(moving, &settings(e, mode, 512, seed));
    let violations = out
        .records
        .iter()
        .map(|r| r.counters.majorant_violations)
        .sum();
    // The static renders' mean, and the variance of that mean.
    let n = statics.len() as f64;
    let mut mean = (vec![0.0; 16 * 16 * 3], vec![0.0; 16 * 16 * 3]);
    for (k, s) in statics.iter().enumerate() {
        let m = moments(&render(s, &settings(e, mode, 32, seed + 1 + k as u32)));
        for (a, b) in mean.0.iter_mut().zip(&m.0) {
            *a += b / n;
        }
        for (a, b) in mean.1.iter_mut().zip(&m.1) {
            *a += b / (n * n);
        }
    }
    let m = moments(&out);
    let pixels = compare((&m.0, &m.1), (&mean.0, &mean.1), alpha);
    let (a, b) = (
        block_moments(&m, 16, 16, 4),
        block_moments(&mean, 16, 16, 4),
    );
    let blocks = compare((&a.0, &a.1), (&b.0, &b.1), alpha);
    (pixels, blocks, violations, out)
}

/// One line of a comparison with the shutter mean: image means, failing pixels and blocks.
fn describe(pixels: &Agreement, blocks: &Agreement) -> String {
    format!(
        "mean {:.5} vs {:.5} (z {:.2}); pixels failing {} of {} (worst z {:.2}); blocks failing \
         {} (worst z {:.2})",
        pixels.mean_a,
        pixels.mean_b,
        pixels.mean_z,
        pixels.failing,
        pixels.pixels,
        pixels.worst_z,
        blocks.failing,
        blocks.worst_z
    )
}

/// For every estimator: the blurred render agrees, pixel by pixel and on 4 x 4 blocks, with the
/// mean of static renders at 16 instants spread over the shutter (the midpoints of 16 equal
/// parts), the grid translated to where the velocity has moved it.
#[test]
fn uniform_velocity_blur_is_the_shutter_average_of_translated_renders() {
    let (blurred, _) = blur::uniform_velocity_scenes("uniform");
    let d = blur::dir("uniform");
    const K: usize = 16;
    let statics: Vec<_> = (0..K)
        .map(|k| {
            let dt = -0.5 + (k as f64 + 0.5) / K as f64;
            let s = V.map(|v| dt * SCALE * v as f64 / 24.0);
            blur::load(
                &d,
                &format!("static_{k}.gltf"),
                &blur::scene("m.vdb", s, json!({}), json!({})),
            )
        })
        .collect();
    let rs = RenderScene::new(&blurred, false).unwrap();
    assert!(rs.shutter.is_some() && rs.vdb[0].blur.is_some());
    let configs = Estimator::ALL
        .map(|e| (e, MajorantMode::Adaptive))
        .into_iter()
        .chain([
            (Estimator::Delta, MajorantMode::Global),
            (Estimator::Delta, MajorantMode::Leaf),
            (Estimator::Decomposition, MajorantMode::Culled),
        ]);
    let mut report = Vec::new();
    for (i, (e, mode)) in configs.enumerate() {
        let (pixels, blocks, violations, _) =
            against_shutter_mean(&blurred, &statics, e, mode, 100 * i as u32, 1e-3 / 14.0);
        println!(
            "{e} {mode:?}: {}; violations {violations}",
            describe(&pixels, &blocks)
        );
        report.push((e, mode, pixels, blocks, violations));
    }
    for (e, mode, pixels, blocks, violations) in report {
        assert_eq!(violations, 0, "{e} {mode:?}");
        assert_eq!(pixels.failing, 0, "{e} {mode:?}: {pixels:?}");
        assert_eq!(blocks.failing, 0, "{e} {mode:?}: {blocks:?}");
        assert!(
            pixels.mean_z < pixels.z_threshold,
            "{e} {mode:?}: {pixels:?}"
        );
    }
    // The test has power: the blur differs from the frame's instant.
    let still = render(
        &statics[K / 2],
        &settings(Estimator::Delta, MajorantMode::Adaptive, 2048, 9),
    );
    let blurred_out = render(
        &blurred,
        &settings(Estimator::Delta, MajorantMode::Adaptive, 2048, 10),
    );
    let apart = compare_renders(&blurred_out, &still, 16, 16, 1, 1e-3);
    println!(
        "blurred against one instant: {} of {} pixels failing (worst z {:.1})",
        apart.failing, apart.pixels, apart.worst_z
    );
    assert!(apart.failing >= 8 && apart.worst_z > 6.0, "{apart:?}");
}

/// A vortex at 10 voxels of motion: no tentative collision sees a density above its majorant in
/// any majorant mode (the analog estimators count every violation), and blurred flights make at
/// most twice the still render's density lookups per real collision.
#[test]
fn vortex_blur_keeps_true_majorants_in_every_mode() {
    let (blurred, still) = blur::vortex_scenes("vortex");
    let per_real = |out: &brume::backend::cpu::RenderOutput| {
        let lookups: u64 = out.records.iter().map(|r| r.counters.density_lookups).sum();
        let real: u64 = out.records.iter().map(|r| r.counters.real_collisions).sum();
        lookups as f64 / real as f64
    };
    for estimator in [Estimator::Delta, Estimator::Decomposition] {
        for mode in MajorantMode::ALL {
            let s = settings(estimator, mode, 64, 3);
            let out = render(&blurred, &s);
            let violations: u64 = out
                .records
                .iter()
                .map(|r| r.counters.majorant_violations)
                .sum();
            let (b, a) = (per_real(&out), per_real(&render(&still, &s)));
            println!(
                "vortex {estimator} {mode:?}: violations {violations}; density lookups per real \
                 collision {b:.3} blurred, {a:.3} still ({:.2}x)",
                b / a
            );
            assert_eq!(violations, 0, "{estimator} {mode:?}");
            assert!(b <= 2.0 * a, "{estimator} {mode:?}: {b} against {a}");
        }
    }
}

/// The time average over `s` uniform in `[-h, h]` of `exp(-a * ramp(x - s))`, where `ramp` is
/// the trilinear profile of voxels 0..8 at density 1: 0 below -1, rising to 1 over [-1, 0],
/// 1 up to 7, falling to 0 over [7, 8].
fn slab_average(x: f64, h: f64, a: f64) -> f64 {
    // The profile's linear pieces `r(u) = r0 + slope u` over `[lo, hi]`; the integral of
    // `exp(-a r(u))` over each, clipped to `[x - h, x + h]`, in closed form.
    let pieces = [
        (f64::NEG_INFINITY, -1.0, 0.0, 0.0),
        (-1.0, 0.0, 1.0, 1.0),
        (0.0, 7.0, 1.0, 0.0),
        (7.0, 8.0, 8.0, -1.0),
        (8.0, f64::INFINITY, 0.0, 0.0),
    ];
    let mut total = 0.0;
    for (lo, hi, r0, slope) in pieces {
        let (lo, hi) = (lo.max(x - h), hi.min(x + h));
        if hi <= lo {
            continue;
        }
        let r = |u: f64| r0 + slope * u;
        total += if slope == 0.0 {
            (-a * r0).exp() * (hi - lo)
        } else {
            ((-a * r(lo)).exp() - (-a * r(hi)).exp()) / (a * slope)
        };
    }
    total / (2.0 * h)
}

/// A purely absorbing slab (voxels 0..8 along x at density 1, 16 deep along z) moving along
/// x at 10 voxels per frame under a one-frame shutter: the transmittance of rays along z at
/// several x, averaged over sample times, against the closed form of [`slab_average`], for
/// every transmittance estimator and majorant mode.
#[test]
fn moving_absorbing_slab_transmittance_matches_its_closed_form() {
    let d = blur::dir("slab");
    let mut voxels = Vec::new();
    for x in 0..8 {
        for y in -12..12 {
            for z in 0..16 {
                voxels.push(([x, y, z], 1.0));
            }
        }
    }
    // Index = world / VOXEL: the slab's voxel x is at world x * VOXEL.
    let speed = 10.0 * VOXEL as f32; // world units per frame
    blur::write_medium(
        &d.join("slab.vdb"),
        voxels,
        [0.0; 3],
        [speed, 0.0, 0.0],
        Vec::new(),
        GridClass::Staggered,
    );
    // Absorption only: colour 0, absorptionColor 0; sigma_a = densityScale per unit density.
    let sigma = 0.05 / VOXEL; // optical depth 0.05 per voxel of depth: 0.8 across the slab
    let extra = json!({"velocityGrid": "vel", "velocityUnit": "frame", "color": [0.0, 0.0, 0.0],
                       "absorptionColor": [0.0, 0.0, 0.0], "densityScale": sigma});
    let render_obj = json!({"shutter": {"open": -0.5, "close": 0.5}});
    let scene = blur::load(
        &d,
        "slab.gltf",
        &blur::scene("slab.vdb", [0.0; 3], extra, render_obj),
    );
    let rs = RenderScene::new(&scene, false).unwrap();
    let m = &rs.vdb[0];
    let shutter = rs.shutter.unwrap();
    let a = sigma * 16.0 * VOXEL; // optical depth through the slab at full density
    let xs = [-6.0, -4.5, -1.5, -0.25, 2.0, 3.5, 6.2, 7.7, 10.0, 12.5];
    let mut worst = 0f64;
    let mut n_tests = 0;
    for estimator in Estimator::ALL {
        for mode in MajorantMode::ALL {
            let cfg = TrackingConfig::from_settings(&settings(estimator, mode, 1, 0));
            let mut stats = MediaStats::default();
            for (i, &x) in xs.iter().enumerate() {
                let expected = slab_average(x, 5.0, a);
                let ray = Ray::new(
                    Vec3::new((x * VOXEL) as f32, 0.01, -0.5),
                    Vec3::new(0.0, 0.0, 1.0),
                );
                let n = 20_000;
                let (mut sum, mut sum2) = (0.0f64, 0.0f64);
                for s in 0..n {
                    let mut rng = Rng::new(i as u32, s, 7 + mode as u32);
                    let dt = shutter.time(rng.uniform_f32());
                    let tr = transmittance_vdb::<AllFeatures>(
                        m,
                        &ray,
                        0.0,
                        3.0,
                        &cfg.at_time(dt),
                        &mut rng,
                        &mut stats,
                    )
                    .x as f64;
                    sum += tr;
                    sum2 += tr * tr;
                }
                let mean = sum / n as f64;
                let var = (sum2 / n as f64 - mean * mean).max(0.0) / n as f64;
                let z = (mean - expected).abs() / (var + 1e-12).sqrt();
                worst = worst.max(z);
                n_tests += 1;
                assert!(
                    z < 4.5,
                    "{estimator} {mode:?} x {x}: {mean:.5} +- {:.5}, closed form {expected:.5}",
                    var.sqrt()
                );
            }
            assert_eq!(
                stats.tracking.majorant_violations, 0,
                "{estimator} {mode:?}"
            );
        }
    }
    println!("slab: {n_tests} time-averaged transmittances, worst z {worst:.2}");
}

/// The blurred render of `moving` against the mean of 16 renders of `still(dt)`, the scene at
/// instants `dt` spread over a one-frame shutter: pixel by pixel and on 4 x 4 blocks, and a
/// check that the blur differs from the frame's instant. Prints and returns nothing; asserts.
fn assert_shutter_average(
    label: &str,
    moving: &brume::scene::Scene,
    still: &dyn Fn(f64) -> brume::scene::Scene,
) {
    const K: usize = 16;
    let statics: Vec<_> = (0..K)
        .map(|k| still(-0.5 + (k as f64 + 0.5) / K as f64))
        .collect();
    let e = Estimator::Delta;
    let mode = MajorantMode::Adaptive;
    let (pixels, blocks, violations, out) =
        against_shutter_mean(moving, &statics, e, mode, 31, 1e-3);
    let centre = render(&still(0.0), &settings(e, mode, 512, 33));
    let apart = compare_renders(&out, &centre, 16, 16, 1, 1e-3);
    println!(
        "{label}: {}; against one instant: {} pixels failing, mean z {:.1}; violations \
         {violations}",
        describe(&pixels, &blocks),
        apart.failing,
        apart.mean_z
    );
    assert_eq!(pixels.failing, 0, "{label}: {pixels:?}");
    assert_eq!(blocks.failing, 0, "{label}: {blocks:?}");
    assert!(pixels.mean_z < pixels.z_threshold, "{label}: {pixels:?}");
    // The test has power: the blur differs from the frame's instant, pixel by pixel or in
    // the image mean.
    assert!(
        apart.failing >= 8 || apart.mean_z > 6.0,
        "{label}: {apart:?}"
    );
    assert_eq!(violations, 0, "{label}");
}

/// A camera sliding sideways under the shutter (a glTF translation animation) against still
/// cameras.
#[test]
fn camera_motion_blur_is_the_shutter_average_of_still_cameras() {
    let (d, moving) = blur::animated("camera", 0, [0.0, 0.0, 2.2], [0.8, 0.0, 0.0], &|_| {});
    assert!(
        moving.camera_motion.is_some(),
        "the camera moves during the shutter"
    );
    let still = |dt: f64| {
        let mut still = blur::scene("m.vdb", [0.0; 3], json!({}), json!({}));
        still["nodes"][0]["translation"] = json!([0.8 * dt, 0.0, 2.2]);
        blur::load(&d, &format!("still_{dt}.gltf"), &still)
    };
    assert_shutter_average("camera blur", &moving, &still);
}

/// A medium node moving diagonally under the shutter (a glTF translation animation) against
/// still renders with the node placed at each instant.
#[test]
fn medium_node_motion_blur_is_the_shutter_average_of_still_media() {
    let (d, moving) = blur::animated("medium_node", 2, [0.0; 3], [0.6, 0.3, 0.0], &|_| {});
    assert!(
        moving.vdb_media[0].motion.is_some(),
        "the medium moves during the shutter"
    );
    let still = |dt: f64| {
        let doc = blur::scene("m.vdb", [0.6 * dt, 0.3 * dt, 0.0], json!({}), json!({}));
        blur::load(&d, &format!("still_{dt}.gltf"), &doc)
    };
    assert_shutter_average("medium node blur", &moving, &still);
}

/// A point light sweeping across the blob under the shutter (a glTF translation animation)
/// against still renders with the light at each instant.
#[test]
fn light_motion_blur_is_the_shutter_average_of_still_lights() {
    // A bright light close by, under a dim sky, so that where it shines shows.
    let bright = |doc: &mut serde_json::Value| {
        doc["extensions"]["KHR_lights_punctual"]["lights"][0]["intensity"] = json!(200.0);
        doc["extensions"]["BRUME_environment"]["strength"] = json!(0.1);
    };
    let (d, moving) = blur::animated("light", 1, [0.0, 1.0, 0.8], [2.0, 0.0, 0.0], &bright);
    assert!(
        moving.light_motion[0].is_some(),
        "the light moves during the shutter"
    );
    let still = |dt: f64| {
        let mut doc = blur::scene("m.vdb", [0.0; 3], json!({}), json!({}));
        bright(&mut doc);
        doc["nodes"][1]["translation"] = json!([2.0 * dt, 1.0, 0.8]);
        blur::load(&d, &format!("still_{dt}.gltf"), &doc)
    };
    assert_shutter_average("light blur", &moving, &still);
}

/// A parent node carrying an opaque box and a box of scattering homogeneous medium slides and
/// turns under the shutter (glTF translation and rotation animations) against still renders
/// with the parent posed at each instant: hits, normals, shadows and medium boundaries all at
/// the sample's time.
#[test]
fn mesh_motion_blur_is_the_shutter_average_of_still_meshes() {
    let d = blur::dir("meshes");
    let moving = blur::moving_meshes_scene(&d, None);
    let moves = moving.moving_meshes.as_ref().map_or(0, |m| m.meshes.len());
    assert_eq!(moves, 2, "both boxes move during the shutter");
    let still = |dt: f64| blur::moving_meshes_scene(&d, Some(dt as f32));
    assert_shutter_average("mesh blur", &moving, &still);
}
