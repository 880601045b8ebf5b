//! Passes on the GPU against the CPU's. The light passes (`FEATURE_LIGHT_PASSES`): on scenes
//! that fill different passes, each pass agrees with the CPU's by per-pixel z-tests (another
//! seed), the same seed replays the CPU's passes, the passes add up to the GPU beauty, and
//! keeping them leaves that beauty as it is, bit for bit. The data passes
//! (`FEATURE_DATA_PASSES`): on scenes with media and surfaces, each agrees with the CPU's by
//! per-pixel z-tests, the same seed replays them (the depth of a deterministic first surface
//! to rounding on any adapter), and with the light passes beside them (`--passes light,data`) each
//! kind is what it is alone, the beauty unchanged. The light groups (`FEATURE_LIGHT_GROUPS`):
//! on scenes with several sources of light, each group agrees with the CPU's by per-pixel
//! z-tests (another seed), the same seed replays the CPU's groups, the groups add up to the GPU
//! beauty, and keeping them leaves that beauty as it is, bit for bit.
use crate::common;
use crate::render::{gpu_render, parity_asserted};
use common::gpu::gpu_or_skip;
use common::render::*;

use brume::backend::cpu::RenderOutput;
use brume::film::passes::{DATA_PASSES, LIGHT_PASSES};
use brume::gpu_types::{
    GPU_LIGHT_PASSES, PASS_BACKGROUND, PASS_EMISSION, PASS_SURFACE_DIRECT, PASS_VOLUME_DIRECT,
};
use brume::render::light_groups::LightGroups;
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

fn data_settings(light_passes: bool, seed: u32) -> RenderSettings {
    RenderSettings {
        data_passes: true,
        ..settings(light_passes, seed)
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

/// Pass `k`'s per-pixel means and variances of the mean, flattened (pixel, channel), as
/// [`moments`] has the beauty's.
fn one_pass_moments(out: &RenderOutput, k: usize) -> (Vec<f64>, Vec<f64>) {
    let passes = out.film.passes().expect("passes kept");
    let (mut mean, mut var) = (Vec::new(), Vec::new());
    for (i, p) in out.film.pixels().iter().enumerate() {
        mean.extend(passes.mean(i, k));
        var.extend(passes.variance_of_mean(i, k, p.count));
    }
    (mean, var)
}

/// Every light pass's per-pixel means and variances of the mean, flattened (pass, pixel,
/// channel).
fn pass_moments(out: &RenderOutput) -> (Vec<f64>, Vec<f64>) {
    let (mut mean, mut var) = (Vec::new(), Vec::new());
    for k in 0..LIGHT_PASSES.len() {
        let (m, v) = one_pass_moments(out, k);
        mean.extend(m);
        var.extend(v);
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

/// The scenes of the data passes, each with the passes its camera rays make a function of the
/// jitter alone (the same seed then gives the CPU's to rounding on any adapter): smoke between
/// walls lit by a lamp (a camera ray may scatter before any surface: the throughput as albedo,
/// the view direction as normal, depth 0); smoke in a glass tank on a floor under a sky (the
/// depth of the glass, the albedo past it, the floor's, the sky's; the first surface is fixed
/// by the jitter, what lies past the glass is not); opaque textured surfaces under a sky.
const DATA_SCENES: [(&str, &[&str]); 3] = [
    ("cornell_smoke.gltf", &[]),
    ("smoke_tank.gltf", &["depth"]),
    ("textured_backdrop.gltf", &["albedo", "normal", "depth"]),
];

/// How many values of `a` equal those of `b` to `rel` (relative, at least 1 absolute), and
/// the largest relative difference.
fn close_values(a: &[f64], b: &[f64], rel: f64) -> (usize, f64) {
    let mut worst = 0f64;
    let mut close = 0;
    for (x, y) in a.iter().zip(b) {
        let d = (x - y).abs() / (1.0 + y.abs());
        worst = worst.max(d);
        close += (d <= rel) as usize;
    }
    (close, worst)
}

/// The depth pass's values of the pixels none of whose samples escaped in either render (a
/// mean below 1e6 m; one escape in 16 samples puts `BACKGROUND_DEPTH / 16` into it): there the
/// depth is that of surfaces and of media scattering first, which the escapes' 1e10 would
/// drown in the test. Both renders' samples are independent, so conditioning each pixel on no
/// escape in either leaves them equally distributed.
fn surface_depths(
    (gm, gv): &(Vec<f64>, Vec<f64>),
    (cm, cv): &(Vec<f64>, Vec<f64>),
) -> [Vec<f64>; 4] {
    let keep: Vec<usize> = (0..gm.len())
        .filter(|&i| gm[i] < 1e6 && cm[i] < 1e6)
        .collect();
    [gm, gv, cm, cv].map(|v| keep.iter().map(|&i| v[i]).collect())
}

#[test]
fn data_passes_agree_with_the_cpu() {
    let Some(ctx) = gpu_or_skip("data_passes_agree_with_the_cpu") else {
        return;
    };
    // Every pass of every scene is one family of per-pixel tests, the depth of surfaces one
    // more.
    let alpha = 1e-3 / (DATA_SCENES.len() * (DATA_PASSES.len() + 1)) as f64;
    for (n, (file, deterministic)) in DATA_SCENES.into_iter().enumerate() {
        let scene = load_scene(file);
        let seed = 60 + n as u32;
        let s = data_settings(false, seed);
        let g = gpu_render(&ctx, &scene, &s, file);
        let names = g.film.passes().expect("data passes kept").names();
        assert_eq!(names, DATA_PASSES.map(String::from), "{file}");
        let c = render(&scene, &data_settings(false, seed + 1000));
        let same = render(&scene, &s);
        for (k, pass) in DATA_PASSES.into_iter().enumerate() {
            // (a) Against the CPU's with another seed: per-pixel z-tests over every pixel and
            // channel, Sidak-corrected (`compare`), and the image means.
            let (gp, cp) = (one_pass_moments(&g, k), one_pass_moments(&c, k));
            assert!(
                gp.0.iter().all(|v| v.is_finite()),
                "{file}: non-finite {pass}"
            );
            let a = compare((&gp.0, &gp.1), (&cp.0, &cp.1), alpha);
            println!(
                "{file}: {pass}: worst pixel z {:.2} (threshold {:.2}), {} of {} values fail; \
                 image-mean z {:.2} (GPU {:.4}, CPU {:.4})",
                a.worst_z, a.z_threshold, a.failing, a.pixels, a.mean_z, a.mean_a, a.mean_b
            );
            assert_eq!(a.failing, 0, "{file}: {pass}: {a:?}");
            assert!(a.mean_z < sidak_z(alpha, 3), "{file}: {pass}: {a:?}");
            assert!(
                a.mean_a != 0.0 && a.mean_b != 0.0,
                "{file}: {pass} is empty"
            );
            if pass == "depth" {
                let [gm, gv, cm, cv] = surface_depths(&gp, &cp);
                let a = compare((&gm, &gv), (&cm, &cv), alpha);
                println!(
                    "{file}: depth of surfaces: worst pixel z {:.2} (threshold {:.2}), {} of {} \
                     values fail; image-mean z {:.2} (GPU {:.4} m, CPU {:.4} m)",
                    a.worst_z, a.z_threshold, a.failing, a.pixels, a.mean_z, a.mean_a, a.mean_b
                );
                assert!(a.pixels > 0, "{file}: every pixel sees the background");
                assert_eq!(a.failing, 0, "{file}: depth of surfaces: {a:?}");
            }

            // (b) With the same seed the GPU replays the CPU's passes; those its camera rays
            // make a function of the jitter alone on any adapter (a rare silhouette may flip).
            let (sm, _) = one_pass_moments(&same, k);
            let (close, worst) = close_values(&gp.0, &sm, 1e-5);
            let fixed = deterministic.contains(&pass);
            println!(
                "{file}: {pass}: same seed: {close} of {} values equal to 1e-5 (relative), \
                 largest difference {worst:.1e}{}",
                gp.0.len(),
                if fixed { " (fixed by the jitter)" } else { "" }
            );
            if fixed {
                assert!(
                    close * 100 >= gp.0.len() * 99,
                    "{file}: {pass}: same seed: {close}"
                );
            } else {
                assert!(
                    !parity_asserted(&ctx) || close * 100 >= gp.0.len() * 97,
                    "{file}: {pass}: same seed: {close} of {}",
                    gp.0.len()
                );
            }
        }
    }
}

/// `--passes light,data` on the GPU: the light and the data passes kept together are each what they
/// are alone, bit for bit, in `RenderSettings::pass_names`' order, and the beauty is the one
/// rendered without passes.
#[test]
fn light_and_data_passes_together_are_each_as_alone() {
    let Some(ctx) = gpu_or_skip("light_and_data_passes_together_are_each_as_alone") else {
        return;
    };
    let file = "smoke_tank.gltf";
    let scene = load_scene(file);
    let seed = 70;
    let all = gpu_render(&ctx, &scene, &data_settings(true, seed), file);
    let light = gpu_render(&ctx, &scene, &settings(true, seed), file);
    let data = gpu_render(&ctx, &scene, &data_settings(false, seed), file);
    let none = gpu_render(&ctx, &scene, &settings(false, seed), file);
    let passes = all.film.passes().expect("passes kept");
    let names: Vec<&str> = LIGHT_PASSES.iter().chain(&DATA_PASSES).copied().collect();
    assert_eq!(passes.names(), names);
    let (light, data) = (light.film.passes().unwrap(), data.film.passes().unwrap());
    let alone = |k: usize| {
        if k < LIGHT_PASSES.len() {
            (light, k)
        } else {
            (data, k - LIGHT_PASSES.len())
        }
    };
    for (k, name) in names.iter().enumerate() {
        let (other, j) = alone(k);
        for i in 0..all.film.pixels().len() {
            assert_eq!(
                (passes.mean(i, k), passes.m2(i, k)),
                (other.mean(i, j), other.m2(i, j)),
                "{name} at pixel {i}"
            );
        }
    }
    println!(
        "{file}: the {} passes kept together == each kind alone, bit for bit",
        names.len()
    );
    assert_same_beauty(
        &all.film,
        &none.film,
        &format!("{file}: all passes on the GPU"),
    );
    println!("{file}: GPU beauty with all passes == without, bit for bit");
}

/// The scenes of the light groups, each with the groups its sources must fill: a lamp in smoke
/// between walls under an emissive ceiling; a flame's medium beside smoke under a sky (two
/// grids: the mixture variant); a sun and a sky lighting a cloud.
const GROUP_SCENES: [(&str, &[&str]); 3] = [
    ("cornell_smoke.gltf", &["light.bulb", "surfaces"]),
    ("fire2.gltf", &["environment", "medium.flame"]),
    ("cloud.gltf", &["light.sun", "environment"]),
];

fn group_settings(scene: &brume::scene::Scene, groups: bool, seed: u32) -> RenderSettings {
    RenderSettings {
        light_groups: match groups {
            true => LightGroups::of(scene).expect("light groups").names,
            false => Vec::new(),
        },
        ..settings(false, seed)
    }
}

/// Every group's per-pixel means and variances of the mean, flattened (group, pixel,
/// channel), and each group's sum over the image.
fn group_moments(out: &RenderOutput) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let groups = out.film.passes().expect("light groups kept").names().len();
    let (mut mean, mut var, mut totals) = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..groups {
        let (m, v) = one_pass_moments(out, k);
        totals.push(m.iter().sum());
        mean.extend(m);
        var.extend(v);
    }
    (mean, var, totals)
}

/// The largest difference of the groups' sum from the beauty, relative to the beauty (at
/// least 1e-3).
fn largest_group_sum_difference(out: &RenderOutput) -> f64 {
    let groups = out.film.passes().expect("light groups kept");
    let n = groups.names().len();
    let mut worst = 0f64;
    for (i, p) in out.film.pixels().iter().enumerate() {
        for c in 0..3 {
            let sum: f64 = (0..n).map(|k| groups.mean(i, k)[c]).sum();
            worst = worst.max((sum - p.mean[c]).abs() / p.mean[c].abs().max(1e-3));
        }
    }
    worst
}

#[test]
fn light_groups_agree_with_the_cpu() {
    let Some(ctx) = gpu_or_skip("light_groups_agree_with_the_cpu") else {
        return;
    };
    let alpha = 1e-3 / GROUP_SCENES.len() as f64;
    for (n, (file, filled)) in GROUP_SCENES.into_iter().enumerate() {
        let scene = load_scene(file);
        let names = LightGroups::of(&scene).expect("light groups").names;
        let seed = 80 + n as u32;
        let s = group_settings(&scene, true, seed);
        let g = gpu_render(&ctx, &scene, &s, file);
        assert_eq!(
            g.film.passes().expect("groups kept").names(),
            names.as_slice()
        );

        // (a) Each group against the CPU's with another seed: per-pixel z-tests over every
        // group, pixel and channel, Sidak-corrected (`compare`).
        let c = render(&scene, &group_settings(&scene, true, seed + 1000));
        let (gm, gv, gt) = group_moments(&g);
        let (cm, cv, ct) = group_moments(&c);
        assert!(
            gm.iter().all(|v| v.is_finite()),
            "{file}: non-finite groups"
        );
        let a = compare((&gm, &gv), (&cm, &cv), alpha);
        println!(
            "{file}: light groups: worst pixel z {:.2} (threshold {:.2}), {} of {} values fail; \
             image-mean z {:.2}",
            a.worst_z, a.z_threshold, a.failing, a.pixels, a.mean_z
        );
        assert_eq!(a.failing, 0, "{file}: {a:?}");
        assert!(a.mean_z < sidak_z(alpha, 3), "{file}: {a:?}");
        let shares: Vec<String> = names
            .iter()
            .zip(gt.iter().zip(&ct))
            .map(|(name, (g, c))| format!("{name} {g:.3}/{c:.3}"))
            .collect();
        println!("{file}: group totals GPU/CPU: {}", shares.join(", "));
        for group in filled {
            let k = names
                .iter()
                .position(|p| p == group)
                .expect("the scene's group");
            assert!(gt[k] > 0.0 && ct[k] > 0.0, "{file}: {group} is empty");
        }

        // (b) With the same seed the GPU replays the CPU's groups.
        let (sm, _, _) = group_moments(&render(&scene, &s));
        let (close, worst) = close_values(&gm, &sm, 1e-4);
        println!(
            "{file}: same seed: {close} of {} group values equal to 1e-4 (relative), largest \
             difference {worst:.1e}",
            gm.len()
        );
        assert!(
            !parity_asserted(&ctx) || close * 100 >= gm.len() * 97,
            "{file}: same seed: {close} of {}",
            gm.len()
        );

        // (c) The groups add up to the beauty: they take the same f32 terms, summed apart.
        let worst = largest_group_sum_difference(&g);
        println!(
            "{file}: largest difference of the GPU groups' sum from the beauty: {worst:.2e} \
             (relative)"
        );
        assert!(worst < 1e-5, "{file}: {worst}");

        // (d) Keeping the groups leaves the beauty as it is, bit for bit.
        let without = gpu_render(&ctx, &scene, &group_settings(&scene, false, seed), file);
        assert!(without.film.passes().is_none(), "{file}");
        assert_same_beauty(&g.film, &without.film, &format!("{file} on the GPU"));
        println!("{file}: GPU beauty with light groups == without, bit for bit");
    }
}
