//! Light passes: on every example scene they add up to the beauty, which keeping them leaves
//! bit for bit as it is, and each scene fills the passes its light calls for.
use crate::common::render::{assert_same_beauty, load_scene, render, EXAMPLE_SCENES};

use brume::film::passes::LIGHT_PASSES;
use brume::render::RenderSettings;

fn settings(light_passes: bool) -> RenderSettings {
    RenderSettings {
        width: 16,
        height: 12,
        spp: 8,
        seed: 3,
        light_passes,
        ..RenderSettings::default()
    }
}

#[test]
fn light_passes_add_up_to_the_beauty_on_every_example_scene() {
    let mut worst = 0f64;
    for name in EXAMPLE_SCENES {
        let scene = load_scene(name);
        let with = render(&scene, &settings(true));
        let without = render(&scene, &settings(false));
        let passes = with.film.passes().expect("light passes kept");
        let mut totals = [0f64; LIGHT_PASSES.len()];
        assert_same_beauty(&with.film, &without.film, name);
        for (i, p) in with.film.pixels().iter().enumerate() {
            for c in 0..3 {
                let sum: f64 = (0..LIGHT_PASSES.len()).map(|k| passes.mean(i, k)[c]).sum();
                // The passes take the same f32 terms as the beauty; only their sums round
                // differently.
                let scale = p.mean[c].abs().max(1e-3);
                worst = worst.max((sum - p.mean[c]).abs() / scale);
            }
            for (k, t) in totals.iter_mut().enumerate() {
                *t += passes.mean(i, k).iter().sum::<f64>();
            }
        }
        let shares: Vec<String> = LIGHT_PASSES
            .iter()
            .zip(totals)
            .filter(|(_, t)| *t != 0.0)
            .map(|(n, t)| format!("{n} {t:.3}"))
            .collect();
        println!("{name}: {}", shares.join(", "));
        // What each scene's light must fill.
        let filled =
            |pass: &str| totals[LIGHT_PASSES.iter().position(|n| *n == pass).unwrap()] > 0.0;
        if name.starts_with("fire") {
            assert!(filled("emission"), "{name}: its flame is seen directly");
        }
        if name.starts_with("cloud") || name.starts_with("plume") {
            assert!(
                filled("volume.direct") && filled("volume.indirect"),
                "{name}"
            );
        }
        if name.contains("sky") || name == "cloud.gltf" {
            assert!(filled("background"), "{name}: its sky is seen");
        }
        if name.starts_with("cornell") {
            assert!(
                filled("surface.direct") && filled("surface.indirect"),
                "{name}"
            );
        }
    }
    println!("largest difference of the passes' sum from the beauty: {worst:.2e} (relative)");
    assert!(worst < 1e-5, "{worst}");
}
