//! The film's coverage (alpha) and the transparent film: a homogeneous slab's alpha against
//! `1 - exp(-sigma_t L)` over each pixel's footprint, and a transparent render laid over a
//! constant plate against the opaque render whose sky is that plate.
use crate::common::boxes::boxes_scene;
use crate::common::render::{footprint_mean, render, sidak_z};
use crate::common::scratch::dir as scratch;

use brume::render::{RenderScene, RenderSettings};
use glam::Vec3;

const W: u32 = 16;
const SIGMA_T: f32 = 1.5;
/// The slab: a box of homogeneous medium 1 deep in z, wider than the view.
const LO: [f32; 3] = [-2.0, -2.0, -0.5];
const HI: [f32; 3] = [2.0, 2.0, 0.5];

fn settings(spp: u32, seed: u32, transparent: bool) -> RenderSettings {
    RenderSettings {
        width: W,
        height: W,
        spp,
        seed,
        film_transparent: transparent,
        ..RenderSettings::default()
    }
}

/// Length of `o + t d` inside the slab (both faces crossed: the box is wider than the view).
fn chord(o: Vec3, d: Vec3) -> f32 {
    let (t0, t1) = ((HI[2] - o.z) / d.z, (LO[2] - o.z) / d.z);
    (t1 - t0).abs() * d.length()
}

/// Each pixel's expected coverage: `1 - exp(-sigma_t L)` averaged over a 16 x 16 grid of
/// points of its footprint (L varies smoothly across it, so the grid's error is far below the
/// render's noise).
fn expected_alpha(rs: &RenderScene) -> Vec<f64> {
    let coverage = |ray: &brume::math::Ray| 1.0 - (-(SIGMA_T * chord(ray.o, ray.d)) as f64).exp();
    (0..W * W)
        .map(|k| footprint_mean(rs, W, (k % W, k / W), coverage))
        .collect()
}

/// Alpha of a scattering homogeneous slab seen through: each pixel's mean against its
/// expected coverage, z-tested with the film's own variance of the alpha mean.
#[test]
fn slab_alpha_is_one_minus_its_transmittance() {
    let d = scratch("film_alpha_slab");
    let scene = brume::scene::load(&boxes_scene(&d, &[(LO, HI, SIGMA_T, 0.8)], false, 0.6))
        .unwrap_or_else(|e| panic!("{e}"));
    let s = settings(1024, 5, true);
    let rs = RenderScene::prepare(&scene, &s).unwrap();
    let expected = expected_alpha(&rs);
    let out = render(&scene, &s);
    let threshold = sidak_z(1e-3, expected.len());
    let (mut failing, mut worst, mut sum_got, mut sum_var) = (0, 0f64, 0.0, 0.0);
    for (i, e) in expected.iter().enumerate() {
        let p = out.film.pixels()[i];
        let (got, var) = (p.mean[3], p.variance_of_mean()[3]);
        let z = (got - e).abs() / var.sqrt();
        worst = worst.max(z);
        failing += (z > threshold) as usize;
        sum_got += got - e;
        sum_var += var;
    }
    let mean_z = sum_got.abs() / sum_var.sqrt();
    let mean_expected = expected.iter().sum::<f64>() / expected.len() as f64;
    println!(
        "slab alpha: expected mean {mean_expected:.5}; {failing} of {} pixels failing (worst z \
         {worst:.2}, threshold {threshold:.2}); image mean z {mean_z:.2}",
        expected.len()
    );
    assert_eq!(failing, 0);
    assert!(mean_z < 4.0, "image mean z {mean_z}");
}

/// A transparent render laid over a constant plate (`RGB + (1 - A) plate`) against the opaque
/// render of the scene whose sky is that plate: equal in expectation for a grey medium, since
/// the camera ray's transmittance is then the same in every channel.
#[test]
fn transparent_film_over_its_sky_is_the_opaque_render() {
    let d = scratch("film_alpha_over");
    let boxes = [([-0.6, -0.6, -0.5], [0.6, 0.6, 0.5], 2.0, 0.8)];
    let scene =
        brume::scene::load(&boxes_scene(&d, &boxes, false, 0.6)).unwrap_or_else(|e| panic!("{e}"));
    // boxes_scene's sky: white, strength 1.
    let plate = 1.0;
    let transparent = render(&scene, &settings(512, 7, true));
    let opaque = render(&scene, &settings(512, 8, false));
    let n = (W * W) as usize;
    let threshold = sidak_z(1e-3, 3 * n);
    let (mut failing, mut worst, mut covered) = (0, 0f64, 0);
    for i in 0..n {
        let (t, o) = (transparent.film.pixels()[i], opaque.film.pixels()[i]);
        let a = t.mean[3];
        covered += (a > 0.05) as usize;
        // Alpha samples lie in [0, 1]: their variance is at most a (1 - a).
        let sd_alpha = (a * (1.0 - a) / t.count as f64).sqrt();
        for c in 0..3 {
            let over = t.mean[c] + (1.0 - a) * plate;
            let sd = t.variance_of_mean()[c].sqrt() + plate * sd_alpha;
            let z = (over - o.mean[c]).abs() / (sd * sd + o.variance_of_mean()[c]).sqrt();
            worst = worst.max(z);
            failing += (z > threshold) as usize;
        }
    }
    println!(
        "over a plate: {covered} of {n} pixels covered; {failing} of {} values failing (worst z \
         {worst:.2}, threshold {threshold:.2})",
        3 * n
    );
    assert!(covered > n / 4, "the box covers the view");
    assert_eq!(failing, 0);
}
