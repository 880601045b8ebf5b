//! Emitting media sampled as lights (`render::media_lights`) on the GPU against the CPU: the
//! fire scenes (one emitting grid over a floor; a flame beside smoke under a sky, the mixture
//! variant) with the media lights on replay the CPU's random streams with the same seed (the
//! media lights' five uniforms and shadow ray drawn where the CPU draws them, the flights'
//! emission weighed as the CPU weighs it) and agree with the CPU by per-pixel z-tests with
//! another seed. `passes.rs` covers the light passes and groups with the media lights on.
use crate::common;
use crate::render::{agree, gpu_render, print_parity};
use common::gpu::gpu_or_skip;
use common::render::*;

use brume::render::{RenderScene, RenderSettings, VolumeSampling};

fn settings(seed: u32) -> RenderSettings {
    RenderSettings {
        width: 20,
        height: 16,
        spp: 16,
        seed,
        media_lights: true,
        // Equiangular sampling is another strategy; free flight alone here.
        volume_sampling: VolumeSampling::Distance,
        ..RenderSettings::default()
    }
}

/// `fire.gltf` and `fire2.gltf` with the media lights on: the GPU renders them (no refusal),
/// replays the CPU's streams (same seed) and agrees with the CPU (another seed).
#[test]
fn fire_scenes_with_media_lights_agree_with_the_cpu() {
    let files = ["fire.gltf", "fire2.gltf"];
    for file in files {
        let scene = load_scene(file);
        let rs = RenderScene::prepare(&scene, &settings(1)).unwrap();
        let lights = rs
            .media_lights
            .as_ref()
            .expect("an emitting medium sampled");
        println!("{file}: {} cells sampled as lights", lights.cells());
        brume::backend::gpu::supports_with(&rs, &settings(1))
            .unwrap_or_else(|e| panic!("{file}: refused: {e}"));
    }
    let Some(ctx) = gpu_or_skip("fire_scenes_with_media_lights_agree_with_the_cpu") else {
        return;
    };
    let alpha = 1e-3 / files.len() as f64;
    for (i, file) in files.into_iter().enumerate() {
        let scene = load_scene(file);
        let s = settings(610 + i as u32);
        let label = format!("{file} media lights");
        let g = gpu_render(&ctx, &scene, &s, &label);
        let independent = RenderSettings {
            seed: s.seed + 1000,
            ..s.clone()
        };
        let c = render(&scene, &independent);
        agree(&label, &g, &c, alpha);
        print_parity(Some(&ctx), &label, &scene, &s, &g, &c);
    }
}
