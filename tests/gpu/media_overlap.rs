//! Overlapping, several and nested media on the GPU (the mixture variant,
//! `shaders/common/mixture.wgsl`), as `tests/physics/media_overlap.rs` checks them on the CPU:
//! - two overlapping VDB media render the same image on the GPU as ONE grid holding their
//!   voxel-wise sum, for every estimator in the global and adaptive majorant modes, with
//!   absorption events and per-leaf majorants, with a weighted-delta `b`, and with spectral
//!   tracking (grey media forced, and chromatic media): per-pixel z-test, Sidak-corrected at
//!   99.9 %, and a z-test of the image means, independent seeds;
//! - the GPU agrees with the CPU on the two-media scene, on two emitting overlapping media,
//!   on two media side by side (each tracked alone) and on the example scenes made of
//!   several media (`fire2`: two grids; `smoke_tank`: a grid inside a glass tank), and with
//!   the same seed replays the CPU's samples on a CPU adapter (every medium thinning by its
//!   own per-voxel bounds);
//! - a VDB medium inside an absorbing `KHR_materials_volume` box, seen along one pencil:
//!   the pixel is `env * exp(-tau)` with `tau` integrated independently.
//!
//! Tiny images: lavapipe runs the kernels on the CPU.
use crate::common;
use crate::render::free_flight;
use common::gpu::gpu_or_skip;
use common::overlap::*;
use common::render::*;
use common::stress::blob_voxels;

use std::sync::atomic::AtomicBool;

use brume::backend::cpu::RenderOutput;
use brume::backend::gpu::{self, render::render_with_timings, GpuContext};
use brume::render::{
    Absorption, Estimator, MajorantMode, RenderScene, RenderSettings, VolumeSampling,
};
use serde_json::json;

/// Renders on the GPU and checks what every render must hold; returns the image and the
/// variant's name.
fn gpu_render(
    ctx: &GpuContext,
    scene: &brume::scene::Scene,
    s: &RenderSettings,
    label: &str,
) -> (RenderOutput, String) {
    let rs = RenderScene::new(scene, s.force_spectral).unwrap();
    gpu::supports(&rs).unwrap_or_else(|e| panic!("{label}: {e}"));
    let (out, t) = render_with_timings(ctx, &rs, s, &AtomicBool::new(false), &|_, _, _| {})
        .unwrap_or_else(|e| panic!("{label}: {e}"));
    assert_eq!(out.spp, s.spp, "{label}");
    let totals = brume::film::totals(&out.records);
    assert_eq!(totals.counters.guard_fired, 0, "{label}");
    assert_eq!(totals.counters.majorant_violations, 0, "{label}");
    let (m, _) = moments(&out);
    assert!(
        m.iter().all(|v| v.is_finite()),
        "{label}: non-finite pixels"
    );
    (out, t.variant)
}

/// Z-tests two independent images pixel by pixel (in `block` x `block` blocks when
/// `block > 1`) and by their means.
fn agree(
    a: &RenderOutput,
    b: &RenderOutput,
    s: &RenderSettings,
    block: usize,
    alpha: f64,
    label: &str,
) {
    let (w, h) = (s.width as usize, s.height as usize);
    let r = compare_renders(a, b, w, h, block, alpha);
    println!(
        "{label}: {:.5} vs {:.5} (mean z {:.2}), worst pixel z {:.2} (threshold {:.2}), {} of {} failing",
        r.mean_a, r.mean_b, r.mean_z, r.worst_z, r.z_threshold, r.failing, r.pixels
    );
    assert_eq!(r.failing, 0, "{label}: {r:?}");
    assert!(r.mean_z < sidak_z(alpha, 3), "{label}: {r:?}");
    assert!(r.mean_b > 1e-3, "{label}: black image");
}

/// The two-media scene on the GPU against the summed grid on the GPU (another seed).
fn gpu_sum_agrees(
    ctx: &GpuContext,
    two: &brume::scene::Scene,
    one: &brume::scene::Scene,
    s: &RenderSettings,
    block: usize,
    alpha: f64,
    label: &str,
) {
    let s = &free_flight(s);
    let (a, variant) = gpu_render(ctx, two, s, &format!("{label} two"));
    assert!(variant.contains("mixture"), "{label}: {variant}");
    let s1 = RenderSettings {
        seed: s.seed + 1000,
        ..s.clone()
    };
    let (b, variant1) = gpu_render(ctx, one, &s1, &format!("{label} one"));
    assert!(!variant1.contains("mixture"), "{label}: {variant1}");
    agree(&a, &b, s, block, alpha, &format!("{label} [{variant}]"));
}

#[test]
fn two_overlapping_grids_render_as_their_sum_on_the_gpu_for_every_estimator() {
    let Some(ctx) = gpu_or_skip("two_overlapping_grids_render_as_their_sum_on_the_gpu") else {
        return;
    };
    let (two, one) = pair(false);
    for_each_overlap_config(|s, block, alpha, label| {
        gpu_sum_agrees(&ctx, &two, &one, s, block, alpha, &format!("GPU {label}"))
    });
}

#[test]
fn chromatic_overlapping_grids_render_as_their_sum_on_the_gpu() {
    let Some(ctx) = gpu_or_skip("chromatic_overlapping_grids_render_as_their_sum_on_the_gpu")
    else {
        return;
    };
    let (two, one) = pair(true);
    let alpha = 1e-3 / 3.0;
    for (i, (m, absorption)) in [
        (MajorantMode::Global, Absorption::Weight),
        (MajorantMode::Adaptive, Absorption::Weight),
        (MajorantMode::Adaptive, Absorption::Event),
    ]
    .into_iter()
    .enumerate()
    {
        let s = RenderSettings {
            absorption,
            ..overlap_settings(Estimator::Delta, m, 60 + i as u32)
        };
        gpu_sum_agrees(
            &ctx,
            &two,
            &one,
            &s,
            1,
            alpha,
            &format!("GPU chromatic {m:?} {absorption:?}"),
        );
    }
}

/// GPU against CPU (another seed) on `scene`, and the GPU's replay of the CPU's samples
/// (the same seed).
fn gpu_against_cpu(
    ctx: &GpuContext,
    scene: &brume::scene::Scene,
    s: &RenderSettings,
    alpha: f64,
    label: &str,
) {
    let s = &free_flight(s);
    let (g, variant) = gpu_render(ctx, scene, s, label);
    assert!(variant.contains("mixture"), "{label}: {variant}");
    let c = render(
        scene,
        &RenderSettings {
            seed: s.seed + 1000,
            ..s.clone()
        },
    );
    let (close, n) = same_seed_close(&g, &render(scene, s));
    println!("{label}: same seed: {close} of {n} pixel values equal to 1e-4 (relative)");
    // With the same seed the GPU replays the CPU's random streams: every medium's walks thin
    // by its own per-voxel bounds on both. Asserted where the device rounds like the CPU (a
    // CPU adapter, as in tests/gpu/render.rs); printed elsewhere.
    if ctx.adapter_info.device_type == wgpu::DeviceType::Cpu {
        assert_eq!(close, n, "{label}: the GPU does not replay the CPU");
    }
    let (gt, ct) = (
        brume::film::totals(&g.records),
        brume::film::totals(&c.records),
    );
    println!(
        "{label}: lookups/sample GPU {:.2} CPU {:.2}; emission lookups GPU {} CPU {}",
        gt.counters.lookups_per_sample(),
        ct.counters.lookups_per_sample(),
        gt.counters.emission_lookups,
        ct.counters.emission_lookups
    );
    agree(
        &g,
        &c,
        s,
        1,
        alpha,
        &format!("{label} [{variant}] GPU vs CPU"),
    );
}

#[test]
fn several_media_agree_with_the_cpu() {
    let Some(ctx) = gpu_or_skip("several_media_agree_with_the_cpu") else {
        return;
    };
    let alpha = 1e-3 / 7.0;
    let (two, _) = pair(false);
    gpu_against_cpu(
        &ctx,
        &two,
        &overlap_settings(Estimator::Delta, MajorantMode::Adaptive, 300),
        alpha,
        "two media, delta adaptive",
    );
    gpu_against_cpu(
        &ctx,
        &two,
        &overlap_settings(Estimator::Decomposition, MajorantMode::Global, 301),
        alpha,
        "two media, decomposition global",
    );
    // Two emitting media: each one's emission gathered at every tentative collision.
    let d = dir("gpu_emission");
    write_grid(&d.join("a.vdb"), blob_voxels(N));
    write_grid(&d.join("b.vdb"), shifted());
    let m = |uri: &str| {
        let mut m = medium(uri, false);
        m["emissionGrid"] = json!("density");
        m["emissionStrength"] = json!(2.0);
        m["emissionColor"] = json!([1.0, 0.5, 0.2]);
        m
    };
    let path = write_scene(&d, "two.gltf", &scene(vec![m("a.vdb"), m("b.vdb")]));
    let emitting = brume::scene::load(&path).unwrap();
    gpu_against_cpu(
        &ctx,
        &emitting,
        &overlap_settings(Estimator::Delta, MajorantMode::Adaptive, 302),
        alpha,
        "two emitting media",
    );
    // Two media side by side (no overlap): each tracked alone, in order along the ray.
    let d = dir("gpu_apart");
    write_grid(&d.join("a.vdb"), blob_voxels(N));
    let apart: Vec<([i32; 3], f32)> = blob_voxels(N)
        .into_iter()
        .map(|(p, v)| ([p[0] + 2 * N, p[1], p[2]], 0.7 * v))
        .collect();
    write_grid(&d.join("b.vdb"), apart);
    let path = write_scene(
        &d,
        "apart.gltf",
        &scene(vec![medium("a.vdb", false), medium("b.vdb", true)]),
    );
    let apart = brume::scene::load(&path).unwrap();
    let rs = RenderScene::new(&apart, false).unwrap();
    assert!(!rs.features.overlapping && rs.vdb.len() == 2);
    gpu_against_cpu(
        &ctx,
        &apart,
        &overlap_settings(Estimator::WeightedDelta, MajorantMode::Leaf, 303),
        alpha,
        "two media apart, one chromatic",
    );
    // The example scenes made of several media, with their surfaces and lights.
    for (i, file) in ["fire2.gltf", "smoke_tank.gltf"].into_iter().enumerate() {
        let scene = load_scene(file);
        let rs = RenderScene::new(&scene, false).unwrap();
        assert!(rs.features.overlapping, "{file}");
        let s = RenderSettings {
            width: 24,
            height: 16,
            spp: 64,
            seed: 310 + i as u32,
            ..RenderSettings::default()
        };
        gpu_against_cpu(&ctx, &scene, &s, alpha, file);
    }
}

#[test]
fn a_grid_inside_an_absorbing_box_attenuates_by_both_on_the_gpu() {
    let Some(ctx) = gpu_or_skip("a_grid_inside_an_absorbing_box_attenuates_by_both_on_the_gpu")
    else {
        return;
    };
    let d = dir("gpu_grid_in_box");
    write_grid(&d.join("grid.vdb"), blob_voxels(N));
    let sigma = 0.4f32;
    let path = common::boxes::boxes_scene(
        &d,
        &[([-0.8, -0.8, -0.8], [0.8, 0.8, 0.8], sigma, 0.0)],
        true,
        1e-4,
    );
    let scene = brume::scene::load(&path).unwrap();
    let rs = RenderScene::new(&scene, false).unwrap();
    assert!(rs.features.nested && rs.features.overlapping);
    let tau = pencil_depth(&rs.vdb[0]) + sigma as f64 * 1.6;
    let expected = (-tau).exp();
    let mut seed = 500;
    for e in Estimator::ALL {
        for absorption in [Absorption::Weight, Absorption::Event] {
            let s = RenderSettings {
                width: 1,
                height: 1,
                spp: 4096,
                estimator: e,
                majorant: MajorantMode::Adaptive,
                absorption,
                seed,
                max_pass_spp: 4096,
                ..RenderSettings::default()
            };
            seed += 1;
            let (out, variant) = gpu_render(&ctx, &scene, &s, "grid in box");
            let mean = out.film.mean(0, 0)[0] as f64;
            let se = (out.film.variance_of_mean(0, 0)[0] as f64).sqrt();
            let se = se.max((expected * (1.0 - expected) / s.spp as f64).sqrt());
            let z = (mean - expected) / se;
            println!("grid in box on the GPU [{variant}] {e} {absorption:?}: {mean:.5} vs exp(-tau) {expected:.5} (z {z:.2})");
            // 8 tests at 99.9 % overall: |z| < 3.7 (Sidak 3.66).
            assert!(z.abs() < 3.7, "{e} {absorption:?}: {mean} vs {expected}");
        }
    }
}

#[test]
fn more_media_than_the_gpu_binds_are_refused_in_one_line() {
    let (two, _) = pair(false);
    let mut rs = RenderScene::new(&two, false).unwrap();
    gpu::supports(&rs).expect("two media");
    while rs.vdb.len() <= brume::gpu_types::GPU_MAX_VDB_MEDIA {
        rs.vdb.push(rs.vdb[0].clone());
    }
    let why = gpu::supports(&rs).expect_err("too many media");
    println!("{} VDB media: refused: {why}", rs.vdb.len());
    assert!(!why.contains('\n'));
}

/// The CPU's equiangular sampling towards the point light, alone and weighed by MIS, against
/// the GPU's free flight on the two media: the same light by other strategies (z-tests,
/// independent seeds).
#[test]
fn free_flight_on_the_gpu_agrees_with_equiangular_sampling_on_the_cpu() {
    let Some(ctx) = gpu_or_skip("free_flight_on_the_gpu_agrees_with_equiangular_sampling") else {
        return;
    };
    let (two, _) = pair(false);
    let s = overlap_settings(Estimator::Delta, MajorantMode::Adaptive, 400);
    let (g, _) = gpu_render(&ctx, &two, &free_flight(&s), "two media, free flight");
    let alpha = 1e-3 / 2.0;
    for (i, mode) in [VolumeSampling::Mis, VolumeSampling::Equiangular]
        .into_iter()
        .enumerate()
    {
        let c = render(
            &two,
            &RenderSettings {
                volume_sampling: mode,
                seed: s.seed + 1000 + i as u32,
                ..s.clone()
            },
        );
        let label = format!("GPU distance against CPU {}", mode.name());
        agree(&g, &c, &s, 1, alpha, &label);
    }
}
