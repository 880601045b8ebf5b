//! The data passes against what they must hold: an opaque box's face gives its base colour,
//! its normal and its depth exactly; a slab of medium gives the expected albedo of a camera
//! ray that scatters in it with probability `1 - exp(-sigma_t L)` or sees the sky.
use crate::common::boxes::boxes_scene;
use crate::common::render::{footprint_mean, render, sidak_z};
use crate::common::scratch::dir as scratch;

use brume::render::{RenderScene, RenderSettings};

const W: u32 = 16;

fn settings(spp: u32) -> RenderSettings {
    RenderSettings {
        width: W,
        height: W,
        spp,
        seed: 9,
        data_passes: true,
        ..RenderSettings::default()
    }
}

#[test]
fn an_opaque_face_gives_its_base_colour_normal_and_depth() {
    let d = scratch("data_passes_opaque");
    let path = boxes_scene(
        &d,
        &[([-2.0, -2.0, -0.5], [2.0, 2.0, 0.5], 1.0, 0.5)],
        false,
        0.6,
    );
    // The box made opaque: a diffuse base colour, no transmission.
    let mut doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    doc["materials"][0] = serde_json::json!({"pbrMetallicRoughness":
        {"baseColorFactor": [0.6, 0.3, 0.1, 1], "metallicFactor": 0, "roughnessFactor": 0.8}});
    let opaque = d.join("opaque.gltf");
    std::fs::write(&opaque, doc.to_string()).unwrap();
    let scene = brume::scene::load(&opaque).unwrap_or_else(|e| panic!("{e}"));
    let out = render(&scene, &settings(8));
    let passes = out.film.passes().unwrap();
    let mut worst = [0f64; 3];
    for i in 0..out.film.pixels().len() {
        let (albedo, normal, depth) = (passes.mean(i, 0), passes.mean(i, 1), passes.mean(i, 2));
        for (c, want) in [0.6f64, 0.3, 0.1].into_iter().enumerate() {
            worst[0] = worst[0].max((albedo[c] - want).abs());
        }
        worst[1] = worst[1].max((normal[0]).abs() + normal[1].abs() + (normal[2] - 1.0).abs());
        worst[2] = worst[2].max((depth[0] - 2.5).abs());
    }
    println!(
        "opaque face: largest differences: albedo {:.1e}, normal {:.1e}, depth {:.1e}",
        worst[0], worst[1], worst[2]
    );
    assert!(
        worst[0] < 1e-6 && worst[1] < 1e-6 && worst[2] < 1e-5,
        "{worst:?}"
    );
}

#[test]
fn a_slab_of_medium_gives_the_expected_albedo() {
    const SIGMA_T: f64 = 1.5;
    const ALBEDO: f64 = 0.8;
    let d = scratch("data_passes_slab");
    let lo = [-2.0, -2.0, -0.5];
    let hi = [2.0, 2.0, 0.5];
    let path = boxes_scene(&d, &[(lo, hi, SIGMA_T as f32, ALBEDO as f32)], false, 0.6);
    let scene = brume::scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let s = settings(1024);
    let rs = RenderScene::prepare(&scene, &s).unwrap();
    let out = render(&scene, &s);
    let passes = out.film.passes().unwrap();
    // The camera ray either scatters first (albedo 0.8, the throughput past the event) or
    // crosses the slab to the white sky (albedo 1): over each pixel's footprint.
    let threshold = sidak_z(1e-3, (W * W) as usize);
    let (mut failing, mut worst) = (0, 0f64);
    let albedo = |ray: &brume::math::Ray| {
        // The slab is 1 deep in z and wider than the view: the chord is 1 / |cos|.
        let t = (-SIGMA_T * (ray.d.length() / ray.d.z.abs()) as f64).exp();
        (1.0 - t) * ALBEDO + t
    };
    for y in 0..W {
        for x in 0..W {
            let expected = footprint_mean(&rs, W, (x, y), albedo);
            let k = (y * W + x) as usize;
            let count = out.film.pixels()[k].count;
            let (got, var) = (
                passes.mean(k, 0)[0],
                passes.variance_of_mean(k, 0, count)[0],
            );
            let z = (got - expected).abs() / var.sqrt();
            worst = worst.max(z);
            failing += (z > threshold) as usize;
        }
    }
    println!(
        "slab albedo: {failing} of {} pixels failing (worst z {worst:.2}, threshold {threshold:.2})",
        W * W
    );
    assert_eq!(failing, 0);
}
