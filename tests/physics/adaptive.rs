//! Adaptive sampling leaves the image's expectation alone: the cloud's image mean with a noise
//! threshold against the fixed-count render's, z-tested per channel.
use crate::common::render::{load_scene, render, sidak_z};

use brume::render::RenderSettings;

#[test]
fn adaptive_sampling_keeps_the_image_mean() {
    for name in ["cloud.gltf", "cloud_sky.gltf"] {
        let scene = load_scene(name);
        let base = RenderSettings {
            width: 32,
            height: 24,
            spp: 512,
            ..RenderSettings::default()
        };
        let adaptive = render(
            &scene,
            &RenderSettings {
                noise_threshold: Some(0.02),
                seed: 1,
                ..base.clone()
            },
        );
        let fixed = render(&scene, &RenderSettings { seed: 2, ..base });
        let n = adaptive.film.pixels().len() as f64;
        let mean_spp = adaptive
            .film
            .pixels()
            .iter()
            .map(|p| p.count as f64)
            .sum::<f64>()
            / n;
        let mut worst = 0f64;
        for c in 0..3 {
            let stats = |o: &brume::backend::cpu::RenderOutput| {
                o.film.pixels().iter().fold((0.0, 0.0), |(m, v), p| {
                    (m + p.mean[c] / n, v + p.variance_of_mean()[c] / (n * n))
                })
            };
            let ((ma, va), (mf, vf)) = (stats(&adaptive), stats(&fixed));
            let z = (ma - mf).abs() / (va + vf).sqrt();
            worst = worst.max(z);
            println!("{name} channel {c}: adaptive {ma:.5}, fixed {mf:.5}, z {z:.2}");
        }
        println!("{name}: {mean_spp:.1} spp a pixel on average against 512");
        assert!(mean_spp < 512.0, "{name}: nothing stopped");
        assert!(
            worst < sidak_z(1e-3, 3),
            "{name}: image means differ (z {worst:.2})"
        );
    }
}
