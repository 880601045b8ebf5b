//! Equiangular sampling towards point and spot lights in media (`integrator::equiangular`,
//! `shaders/common/equiangular.wgsl`) on the GPU against the CPU: with the same seed the GPU
//! replays the CPU's streams, and with another seed the images agree (per-pixel z-tests), in
//! a VDB medium among surfaces (the Cornell smoke), a lamp inside a dense plume and a
//! homogeneous slab, for MIS and equiangular sampling alone, and two overlapping VDB media (the
//! mixture variant).
use crate::common;
use crate::render::{agree, gpu_render, print_parity};
use common::boxes::lit_slab_scene;
use common::gpu::gpu_or_skip;
use common::render::*;

use brume::backend::gpu;
use brume::render::{RenderScene, RenderSettings, VolumeSampling};

fn settings(spp: u32, seed: u32, sampling: VolumeSampling) -> RenderSettings {
    RenderSettings {
        width: 20,
        height: 16,
        spp,
        seed,
        volume_sampling: sampling,
        media_lights: false,
        ..RenderSettings::default()
    }
}

#[test]
fn equiangular_sampling_agrees_with_the_cpu() {
    let Some(ctx) = gpu_or_skip("equiangular_sampling_agrees_with_the_cpu") else {
        return;
    };
    let scenes = [
        ("cornell_smoke", load_scene("cornell_smoke.gltf")),
        ("plume_bulb", load_scene("plume_bulb.gltf")),
        (
            "lit slab",
            lit_slab_scene(
                "gpu_equiangular_slab",
                [-2.0, -2.0, -0.5],
                [2.0, 2.0, 0.5],
                [0.8, 0.1, 0.0],
            ),
        ),
    ];
    for (name, scene) in &scenes {
        for sampling in [VolumeSampling::Mis, VolumeSampling::Equiangular] {
            let s = settings(16, 41, sampling);
            let label = format!("{name} {}", sampling.name());
            let rs = RenderScene::prepare(scene, &s).unwrap();
            gpu::supports_with(&rs, &s).unwrap_or_else(|e| panic!("{label}: {e}"));
            let g = gpu_render(&ctx, scene, &s, &label);
            let c = render(
                scene,
                &RenderSettings {
                    seed: s.seed + 1000,
                    ..s.clone()
                },
            );
            print_parity(Some(&ctx), &label, scene, &s, &g, &c);
            agree(&label, &g, &c, 1e-3);
        }
    }
}

/// Two overlapping VDB media with a point light (the mixture variant): the GPU against the
/// CPU, same seed replayed and another seed's image.
#[test]
fn equiangular_sampling_in_overlapping_media_agrees_with_the_cpu() {
    let Some(ctx) = gpu_or_skip("equiangular_sampling_in_overlapping_media") else {
        return;
    };
    let (two, _) = common::overlap::pair(false);
    let s = settings(16, 43, VolumeSampling::Mis);
    let rs = RenderScene::prepare(&two, &s).unwrap();
    assert!(rs.features.overlapping && !rs.lights.positional.is_empty());
    let label = "two overlapping media mis";
    let g = gpu_render(&ctx, &two, &s, label);
    let c = render(
        &two,
        &RenderSettings {
            seed: s.seed + 1000,
            ..s.clone()
        },
    );
    print_parity(Some(&ctx), label, &two, &s, &g, &c);
    agree(label, &g, &c, 1e-3);
}
