//! Rendering helpers for the image tests: in-process CPU renders and the statistics that
//! compare them.
use std::path::Path;
use std::sync::atomic::AtomicBool;

use brume::backend::cpu::{self, RenderOutput};
use brume::render::{RenderScene, RenderSettings};
use brume::scene::Scene;

pub fn scene_path(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name)
}

/// Every scene in `scenes/` (a test checks that none is missing).
pub const EXAMPLE_SCENES: [&str; 16] = [
    "cloud.gltf",
    "cornell_smoke.gltf",
    "glass_volume.gltf",
    "fire.gltf",
    "chromatic.gltf",
    "chromatic_smoke.gltf",
    "furnace.gltf",
    "plume_sun.gltf",
    "plume_sky.gltf",
    "plume_blur.gltf",
    "plume_bulb.gltf",
    "dense_fog.gltf",
    "textured_backdrop.gltf",
    "cloud_sky.gltf",
    "fire2.gltf",
    "smoke_tank.gltf",
];

pub fn load_scene(name: &str) -> Scene {
    brume::scene::load(&scene_path(name)).unwrap_or_else(|e| panic!("{e}"))
}

pub fn render(scene: &Scene, settings: &RenderSettings) -> RenderOutput {
    let rs = RenderScene::prepare(scene, settings).unwrap();
    cpu::render(&rs, settings, &AtomicBool::new(false), &|_, _, _| {})
}

/// Per-channel pixel means and variances of the mean, flattened.
pub fn moments(out: &RenderOutput) -> (Vec<f64>, Vec<f64>) {
    let (w, h) = (out.film.width(), out.film.height());
    let mut mean = Vec::new();
    let mut var = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let m = out.film.mean(x, y);
            let v = out.film.variance_of_mean(x, y);
            for c in 0..3 {
                mean.push(m[c] as f64);
                var.push(v[c] as f64);
            }
        }
    }
    (mean, var)
}

/// How many pixel values of `a` equal those of `b` to 1e-4 (relative), and how many there
/// are: a GPU image's replay of the same-seed CPU image.
pub fn same_seed_close(a: &RenderOutput, b: &RenderOutput) -> (usize, usize) {
    let (am, _) = moments(a);
    let (bm, _) = moments(b);
    let close = am
        .iter()
        .zip(&bm)
        .filter(|(x, y)| (*x - *y).abs() <= 1e-4 * (1.0 + y.abs()))
        .count();
    (close, am.len())
}

/// Two-sided z threshold for a family of `n` tests at overall level `alpha` (Sidak).
pub fn sidak_z(alpha: f64, n: usize) -> f64 {
    let a = 1.0 - (1.0 - alpha).powf(1.0 / n as f64);
    inverse_normal_two_sided(a)
}

pub use brume::study::stats::{erfc, two_sided_z as inverse_normal_two_sided};

/// Result of comparing two images (or an image with a constant).
#[derive(Debug)]
pub struct Agreement {
    pub pixels: usize,
    pub failing: usize,
    pub z_threshold: f64,
    pub worst_z: f64,
    pub mean_a: f64,
    pub mean_b: f64,
    pub mean_z: f64,
}

impl Agreement {
    /// Prints `label` with [`Self::summary`] and asserts the agreement: no value failing its
    /// z-test, and the image means within 4 standard errors.
    pub fn assert_holds(&self, label: &str) {
        println!("{label}: {}", self.summary());
        assert_eq!(self.failing, 0, "{label}");
        assert!(self.mean_z < 4.0, "{label}: image mean z {}", self.mean_z);
    }

    /// One line for a test's output: the image means, their z, and the failing values.
    pub fn summary(&self) -> String {
        format!(
            "image mean {:.5} against {:.5} (z {:.2}); {} of {} values failing (worst z {:.2}, \
             threshold {:.2})",
            self.mean_a,
            self.mean_b,
            self.mean_z,
            self.failing,
            self.pixels,
            self.worst_z,
            self.z_threshold
        )
    }
}

/// Per-pixel (per channel) z-test of `a` against `b` with both variances, Sidak-corrected at
/// overall level `alpha`, and a z-test of the image means. Values with zero variance on both
/// sides must be equal to 1e-6.
pub fn compare(a: (&[f64], &[f64]), b: (&[f64], &[f64]), alpha: f64) -> Agreement {
    let n = a.0.len();
    let z_threshold = sidak_z(alpha, n);
    let mut failing = 0;
    let mut worst_z = 0f64;
    for i in 0..n {
        let d = a.0[i] - b.0[i];
        let v = a.1[i] + b.1[i];
        // As `brume compare`: the standard error gets a floor of a few f32 ulps of the value,
        // which two devices' rounding of a deterministic value can put between them.
        let floor = brume::study::compare::ROUNDING_ULPS * f32::EPSILON as f64 * b.0[i].abs();
        let v = v + floor * floor;
        let z = if v > 0.0 {
            d.abs() / v.sqrt()
        } else if d.abs() < 1e-6 {
            0.0
        } else {
            f64::INFINITY
        };
        worst_z = worst_z.max(z);
        if z > z_threshold {
            failing += 1;
        }
    }
    // Image means per channel: pixels are independent, channels of one pixel are not.
    let mut mean_z = 0f64;
    let (mut mean_a, mut mean_b) = (0.0, 0.0);
    let pixels = n / 3;
    for c in 0..3 {
        let sum = |x: &[f64]| (0..pixels).map(|i| x[3 * i + c]).sum::<f64>();
        let (ma, mb) = (sum(a.0) / pixels as f64, sum(b.0) / pixels as f64);
        let se = ((sum(a.1) + sum(b.1)) / (pixels as f64 * pixels as f64)).sqrt();
        let z = if se > 0.0 {
            (ma - mb).abs() / se
        } else if (ma - mb).abs() < 1e-9 {
            0.0
        } else {
            f64::INFINITY
        };
        mean_z = mean_z.max(z);
        mean_a += ma / 3.0;
        mean_b += mb / 3.0;
    }
    Agreement {
        pixels: n,
        failing,
        z_threshold,
        worst_z,
        mean_a,
        mean_b,
        mean_z,
    }
}

/// `b` x `b` block means of per-pixel [`moments`] (`w` x `h` pixels, RGB), with the variance
/// of each block mean (the pixels are independent): a heavy-tailed estimator's rare large
/// weights are better represented in a block's pooled samples than in one pixel's, so the
/// normal approximation of a z-test holds at fewer samples per pixel.
pub fn block_moments(
    m: &(Vec<f64>, Vec<f64>),
    w: usize,
    h: usize,
    b: usize,
) -> (Vec<f64>, Vec<f64>) {
    let (bw, bh) = (w / b, h / b);
    let mut mean = vec![0.0; bw * bh * 3];
    let mut var = vec![0.0; bw * bh * 3];
    let n = (b * b) as f64;
    for y in 0..bh * b {
        for x in 0..bw * b {
            for c in 0..3 {
                let i = ((y / b) * bw + x / b) * 3 + c;
                mean[i] += m.0[(y * w + x) * 3 + c] / n;
                var[i] += m.1[(y * w + x) * 3 + c] / (n * n);
            }
        }
    }
    (mean, var)
}

/// [`compare`] of two renders of `w` x `h` pixels, pixel by pixel, or on `block` x `block`
/// [`block_moments`] when `block > 1`.
pub fn compare_renders(
    a: &RenderOutput,
    b: &RenderOutput,
    w: usize,
    h: usize,
    block: usize,
    alpha: f64,
) -> Agreement {
    let (ma, mb) = (moments(a), moments(b));
    if block > 1 {
        let (x, y) = (
            block_moments(&ma, w, h, block),
            block_moments(&mb, w, h, block),
        );
        compare((&x.0, &x.1), (&y.0, &y.1), alpha)
    } else {
        compare((&ma.0, &ma.1), (&mb.0, &mb.1), alpha)
    }
}

/// The mean of `f` over the camera rays through a 16 x 16 grid of points of pixel `(x, y)`
/// of a square `w` x `w` image: a pixel's expected value where `f` varies smoothly across it.
pub fn footprint_mean(
    rs: &RenderScene,
    w: u32,
    (x, y): (u32, u32),
    f: impl Fn(&brume::math::Ray) -> f64,
) -> f64 {
    const Q: u32 = 16;
    let mut sum = 0.0;
    for j in 0..Q {
        for i in 0..Q {
            let fx = (x as f32 + (i as f32 + 0.5) / Q as f32) / w as f32;
            let fy = (y as f32 + (j as f32 + 0.5) / Q as f32) / w as f32;
            sum += f(&rs.pinhole.primary_ray(fx, fy, 1.0).0);
        }
    }
    sum / (Q * Q) as f64
}

/// Asserts that two films hold the same beauty and coverage, bit for bit (what keeping passes
/// must leave alone).
pub fn assert_same_beauty(a: &brume::film::Film, b: &brume::film::Film, label: &str) {
    for (i, (p, q)) in a.pixels().iter().zip(b.pixels()).enumerate() {
        assert_eq!(
            (p.count, p.mean, p.m2),
            (q.count, q.mean, q.m2),
            "{label}: keeping the passes changed the beauty at pixel {i}"
        );
    }
}

/// A furnace render against 1 in every pixel ([`compare`] at level `alpha`), printed as one
/// line under `label`; returns the agreement and the render's [`moments`].
pub fn against_one(
    out: &RenderOutput,
    alpha: f64,
    label: &str,
) -> (Agreement, (Vec<f64>, Vec<f64>)) {
    let (mean, var) = moments(out);
    let (ones, zeros) = (vec![1.0; mean.len()], vec![0.0; mean.len()]);
    let a = compare((&mean, &var), (&ones, &zeros), alpha);
    println!(
        "{label}: image mean {:.5} (z {:.2}), worst pixel z {:.2} (threshold {:.2}), {} of {} values fail",
        a.mean_a, a.mean_z, a.worst_z, a.z_threshold, a.failing, a.pixels
    );
    (a, (mean, var))
}

/// `furnace.gltf` with its index-matched box filled by a white homogeneous medium of
/// scattering coefficient `sigma_s` (m^-1, no absorption) and phase function `phase`, around
/// the cloud where `cloud` (the media then add up) or alone: every pixel still estimates 1.
pub fn homogeneous_furnace(
    phase: brume::volume::phases::Phase,
    sigma_s: f32,
    cloud: bool,
) -> Scene {
    let mut scene = load_scene("furnace.gltf");
    if !cloud {
        scene.vdb_media.clear();
    }
    scene
        .homogeneous_media
        .push(brume::scene::material::HomogeneousMedium {
            sigma_a: [0.0; 3],
            sigma_s: [sigma_s; 3],
            phase,
            material: 0,
        });
    scene.materials[0].interior_medium = 0;
    scene.validate().unwrap();
    scene
}
