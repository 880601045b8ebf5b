//! Light passes on the GPU (`FEATURE_LIGHT_PASSES`) against the CPU's: on scenes that fill
//! different passes, each pass agrees with the CPU's by per-pixel z-tests (another seed), the
//! same seed replays the CPU's passes, the passes add up to the GPU beauty, and keeping them
//! leaves that beauty as it is, bit for bit.
use crate::common;
use crate::render::{gpu_render, parity_asserted};
use common::gpu::gpu_or_skip;
use common::render::*;

use brume::backend::cpu::RenderOutput;
use brume::film::passes::LIGHT_PASSES;
use brume::gpu_types::{
    GPU_LIGHT_PASSES, PASS_BACKGROUND, PASS_EMISSION, PASS_SURFACE_DIRECT, PASS_VOLUME_DIRECT,
};
use brume::render::RenderSettings;

fn settings(light_passes: bool, seed: u32) -> RenderSettings {
    RenderSettings {
        width: 16,
        height: 12,
        spp: 16,
        seed,
        light_passes,
        ..RenderSettings::default()
    }
}

/// The scenes, each with the passes its light must fill: the sky seen and lighting a cloud,
/// a lamp seen and lighting walls and smoke, a flame seen.
const SCENES: [(&str, &[&str]); 3] = [
    (
        "cloud_sky.gltf",
        &["background", "volume.direct", "volume.indirect"],
    ),
    (
        "cornell_smoke.gltf",
        &[
            "emission",
            "volume.direct",
            "surface.direct",
            "surface.indirect",
        ],
    ),
    ("fire.gltf", &["emission"]),
];

/// Every pass's per-pixel means and variances of the mean, flattened (pass, pixel, channel),
/// as [`moments`] has the beauty's.
fn pass_moments(out: &RenderOutput) -> (Vec<f64>, Vec<f64>) {
    let passes = out.film.passes().expect("light passes kept");
    let (mut mean, mut var) = (Vec::new(), Vec::new());
    for k in 0..LIGHT_PASSES.len() {
        for (i, p) in out.film.pixels().iter().enumerate() {
            mean.extend(passes.mean(i, k));
            var.extend(passes.variance_of_mean(i, k, p.count));
        }
    }
    (mean, var)
}

/// Each pass's sum over the image (all channels).
fn pass_totals(out: &RenderOutput) -> [f64; LIGHT_PASSES.len()] {
    let passes = out.film.passes().expect("light passes kept");
    std::array::from_fn(|k| {
        (0..out.film.pixels().len())
            .map(|i| passes.mean(i, k).iter().sum::<f64>())
            .sum()
    })
}

/// The largest difference of the passes' sum from the beauty, relative to the beauty (at
/// least 1e-3).
fn largest_sum_difference(out: &RenderOutput) -> f64 {
    let passes = out.film.passes().expect("light passes kept");
    let mut worst = 0f64;
    for (i, p) in out.film.pixels().iter().enumerate() {
        for c in 0..3 {
            let sum: f64 = (0..LIGHT_PASSES.len()).map(|k| passes.mean(i, k)[c]).sum();
            worst = worst.max((sum - p.mean[c]).abs() / p.mean[c].abs().max(1e-3));
        }
    }
    worst
}

/// The pass indices the WGSL routes by are those of `LIGHT_PASSES`, and a direct pass's
/// indirect one follows it.
#[test]
fn the_gpu_pass_indices_name_the_films_passes() {
    assert_eq!(GPU_LIGHT_PASSES as usize, LIGHT_PASSES.len());
    let name = |k: u32| LIGHT_PASSES[k as usize];
    assert_eq!(name(PASS_EMISSION), "emission");
    assert_eq!(name(PASS_BACKGROUND), "background");
    assert_eq!(name(PASS_VOLUME_DIRECT), "volume.direct");
    assert_eq!(name(PASS_VOLUME_DIRECT + 1), "volume.indirect");
    assert_eq!(name(PASS_SURFACE_DIRECT), "surface.direct");
    assert_eq!(name(PASS_SURFACE_DIRECT + 1), "surface.indirect");
}

#[test]
fn light_passes_agree_with_the_cpu() {
    let Some(ctx) = gpu_or_skip("light_passes_agree_with_the_cpu") else {
        return;
    };
    let alpha = 1e-3 / SCENES.len() as f64;
    for (n, (file, filled)) in SCENES.into_iter().enumerate() {
        let scene = load_scene(file);
        let seed = 40 + n as u32;
        let s = settings(true, seed);
        let g = gpu_render(&ctx, &scene, &s, file);

        // (a) Each pass against the CPU's with another seed: per-pixel z-tests over every
        // pass, pixel and channel, Sidak-corrected (`compare`).
        let c = render(&scene, &settings(true, seed + 1000));
        let (gm, gv) = pass_moments(&g);
        let (cm, cv) = pass_moments(&c);
        assert!(
            gm.iter().all(|v| v.is_finite()),
            "{file}: non-finite passes"
        );
        let a = compare((&gm, &gv), (&cm, &cv), alpha);
        println!(
            "{file}: passes: worst pixel z {:.2} (threshold {:.2}), {} of {} values fail; \
             image-mean z {:.2}",
            a.worst_z, a.z_threshold, a.failing, a.pixels, a.mean_z
        );
        assert_eq!(a.failing, 0, "{file}: {a:?}");
        assert!(a.mean_z < sidak_z(alpha, 3), "{file}: {a:?}");
        let (gt, ct) = (pass_totals(&g), pass_totals(&c));
        let shares: Vec<String> = LIGHT_PASSES
            .iter()
            .zip(gt.iter().zip(ct))
            .filter(|(_, (g, c))| **g != 0.0 || *c != 0.0)
            .map(|(name, (g, c))| format!("{name} {g:.3}/{c:.3}"))
            .collect();
        println!("{file}: pass totals GPU/CPU: {}", shares.join(", "));
        for pass in filled {
            let k = LIGHT_PASSES.iter().position(|p| p == pass).unwrap();
            assert!(gt[k] > 0.0 && ct[k] > 0.0, "{file}: {pass} is empty");
        }

        // (b) With the same seed the GPU replays the CPU's passes.
        let same = render(&scene, &s);
        let (sm, _) = pass_moments(&same);
        let close = gm
            .iter()
            .zip(&sm)
            .filter(|(x, y)| (*x - *y).abs() <= 1e-4 * (1.0 + y.abs()))
            .count();
        println!(
            "{file}: same seed: {close} of {} pass values equal to 1e-4 (relative)",
            gm.len()
        );
        assert!(
            !parity_asserted(&ctx) || close * 100 >= gm.len() * 97,
            "{file}: same seed: {close} of {}",
            gm.len()
        );

        // (c) The passes add up to the beauty: they take the same f32 terms, summed apart.
        let worst = largest_sum_difference(&g);
        println!("{file}: largest difference of the GPU passes' sum from the beauty: {worst:.2e} (relative)");
        assert!(worst < 1e-5, "{file}: {worst}");

        // (d) Keeping the passes leaves the beauty as it is, bit for bit.
        let without = gpu_render(&ctx, &scene, &settings(false, seed), file);
        assert!(without.film.passes().is_none(), "{file}");
        assert_same_beauty(&g.film, &without.film, &format!("{file} on the GPU"));
        println!("{file}: GPU beauty with passes == without, bit for bit");
    }
}
