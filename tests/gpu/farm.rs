//! A GPU part merges with CPU parts: samples [16, 64) rendered by the wavefront integrator
//! (lavapipe in CI) merged with samples [0, 16) from the CPU agree with an independent CPU
//! render of [0, 64) by the GPU tests' parity bounds (per-pixel z-test, Sidak-corrected at
//! 99.9 %, and the image means), in the beauty and in each data pass kept beside it. The GPU
//! part replays the CPU's random streams at the same sample indices: printed as a parity
//! figure against the same-seed CPU part.
use crate::common;
use common::gpu::gpu_or_skip;
use common::render::*;

use std::sync::atomic::AtomicBool;

use brume::backend::cpu::{self, RenderOutput};
use brume::backend::gpu::render::render as gpu_render;
use brume::farm::{self, Coverage, PartInfo};
use brume::film::passes::DATA_PASSES;
use brume::film::{write_exr_with_state, Metadata};
use brume::render::{RenderScene, RenderSettings};

fn part_file(name: &str, s: &RenderSettings, out: &RenderOutput) -> std::path::PathBuf {
    let path = common::scratch::file(name);
    let mut meta = Metadata::new();
    PartInfo {
        scene_hash: "cloud".into(),
        settings: farm::settings_key(s, None),
        seed: s.seed.to_string(),
        version: env!("CARGO_PKG_VERSION").into(),
        width: s.width,
        height: s.height,
        coverage: vec![Coverage {
            start: s.sample_start,
            end: s.sample_start + out.spp,
            region: [0, 0, s.width, s.height],
        }],
        target: Some((s.sample_start, s.spp)),
        seconds: out.seconds,
        parts: 1,
    }
    .write_into(&mut meta);
    write_exr_with_state(&path, &out.film, &meta).unwrap();
    path
}

#[test]
fn a_gpu_part_merges_with_a_cpu_part() {
    let Some(ctx) = gpu_or_skip("a_gpu_part_merges_with_a_cpu_part") else {
        return;
    };
    let scene = load_scene("cloud.gltf");
    let rs = RenderScene::new(&scene, false).unwrap();
    let base = RenderSettings {
        width: 16,
        height: 12,
        spp: 64,
        seed: 7,
        data_passes: true,
        ..RenderSettings::default()
    };
    let cpu_part = RenderSettings {
        spp: 16,
        ..base.clone()
    };
    let gpu_part = RenderSettings {
        sample_start: 16,
        ..base.clone()
    };
    let stop = AtomicBool::new(false);
    let c = cpu::render(&rs, &cpu_part, &stop, &|_, _, _| {});
    let g = gpu_render(&ctx, &rs, &gpu_part, &stop, &|_, _, _| {}).unwrap();
    assert_eq!(g.spp, 48);
    assert!(g.film.pixels().iter().all(|p| p.count == 48));

    // Parity: the GPU replays the CPU's streams at samples 16..64 (not 0..48).
    let same = cpu::render(&rs, &gpu_part, &stop, &|_, _, _| {});
    let (close, n) = same_seed_close(&g, &same);
    println!(
        "GPU part 16..64: {close} of {n} pixel values equal to the same-seed CPU part to 1e-4"
    );
    // Rounding may flip a decision in a few pixels on another device; a GPU part at the wrong
    // sample indices would match almost none.
    assert!(close * 2 > n, "the GPU part did not render samples 16..64");

    let files = [
        part_file("gpu.exr", &gpu_part, &g),
        part_file("cpu.exr", &cpu_part, &c),
    ];
    let (film, meta) = farm::merge_files(&files).unwrap();
    assert_eq!(meta.text("brume:coverage"), Some("0..64@0,0,16,12"));
    let merged = RenderOutput {
        film,
        records: Vec::new(),
        lookups: Vec::new(),
        spp: 64,
        seconds: 0.0,
        features: c.features,
        interrupted: false,
    };
    let independent = render_cpu_seed(&scene, &base, 1007);
    let (mm, mv) = moments(&merged);
    let (im, iv) = moments(&independent);
    let alpha = 1e-3;
    let a = compare((&mm, &mv), (&im, &iv), alpha);
    println!(
        "CPU 0..16 + GPU 16..64 merged: mean {:.5}, independent CPU mean {:.5}, mean z {:.2}; worst pixel z {:.2} (threshold {:.2}), {} of {} values fail",
        a.mean_a, a.mean_b, a.mean_z, a.worst_z, a.z_threshold, a.failing, a.pixels
    );
    assert_eq!(a.failing, 0, "{a:?}");
    assert!(a.mean_z < sidak_z(alpha, 3), "{a:?}");
    assert!(a.mean_b > 1e-3);

    // The data passes merge with the beauty's counts, as the CPU's parts do.
    assert_eq!(
        merged.film.passes().unwrap().names(),
        DATA_PASSES.map(String::from)
    );
    for (k, pass) in DATA_PASSES.into_iter().enumerate() {
        let ((mm, mv), (im, iv)) = (pass_moments(&merged, k), pass_moments(&independent, k));
        let pass_alpha = alpha / DATA_PASSES.len() as f64;
        let a = compare((&mm, &mv), (&im, &iv), pass_alpha);
        println!(
            "{pass} merged: worst pixel z {:.2} (threshold {:.2}), {} of {} values fail; \
             image-mean z {:.2}",
            a.worst_z, a.z_threshold, a.failing, a.pixels, a.mean_z
        );
        assert_eq!(a.failing, 0, "{pass}: {a:?}");
        assert!(a.mean_z < sidak_z(pass_alpha, 3), "{pass}: {a:?}");
    }
}

fn render_cpu_seed(scene: &brume::scene::Scene, s: &RenderSettings, seed: u32) -> RenderOutput {
    render(scene, &RenderSettings { seed, ..s.clone() })
}

/// Pass `k`'s per-pixel means and variances of the mean, flattened (pixel, channel).
fn pass_moments(out: &RenderOutput, k: usize) -> (Vec<f64>, Vec<f64>) {
    let p = out.film.passes().expect("passes kept");
    let pixels = out.film.pixels().iter().enumerate();
    let mean = pixels.clone().flat_map(|(i, _)| p.mean(i, k)).collect();
    let var = pixels.flat_map(|(i, q)| p.variance_of_mean(i, k, q.count));
    (mean, var.collect())
}
