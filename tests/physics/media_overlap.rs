//! Overlapping and nested media (`integrator::mixture`, `render::stack`):
//! - two overlapping VDB media render the same image as ONE grid holding their voxel-wise sum
//!   (trilinear reconstruction is linear, so the two scenes are the same medium), for every
//!   estimator and spectral tracking, in the global and adaptive majorant modes: per-pixel
//!   z-test, Sidak-corrected at 99.9 %, and a z-test of the image means, independent seeds;
//! - a VDB medium inside a homogeneous KHR_materials_volume box, and two nested boxes, purely
//!   absorbing, seen along one narrow pencil of rays: the pixel is `env * exp(-tau)` with
//!   `tau` integrated independently (z-test on the Bernoulli/weighted estimates);
//! - media meshes nested deeper than the stack holds are refused with the file and the node.
use crate::common;
use common::overlap::*;
use common::render::*;
use common::stress::blob_voxels;

use std::path::{Path, PathBuf};

use brume::render::{Absorption, Estimator, MajorantMode, RenderScene, RenderSettings};
use serde_json::{json, Value};

/// Renders both scenes with `s` (independent seeds) and z-tests them pixel by pixel (in
/// `block` x `block` blocks when `block > 1`).
fn agree(
    two: &brume::scene::Scene,
    one: &brume::scene::Scene,
    s: &RenderSettings,
    block: usize,
    alpha: f64,
    label: &str,
) {
    let a = render(two, s);
    let b = render(
        one,
        &RenderSettings {
            seed: s.seed + 1000,
            ..s.clone()
        },
    );
    assert!(a.features.overlapping, "{label}: the mixture ran");
    let (w, h) = (s.width as usize, s.height as usize);
    let r = compare_renders(&a, &b, w, h, block, alpha);
    let ta = brume::film::totals(&a.records);
    println!(
        "{label}: two media {:.5} vs summed grid {:.5} (mean z {:.2}), worst pixel z {:.2} (threshold {:.2}), {} failing",
        r.mean_a, r.mean_b, r.mean_z, r.worst_z, r.z_threshold, r.failing
    );
    assert_eq!(r.failing, 0, "{label}: {r:?}");
    assert!(r.mean_z < 3.3, "{label}: {r:?}");
    assert_eq!(ta.counters.majorant_violations, 0, "{label}");
}

#[test]
fn two_overlapping_grids_render_as_their_sum_for_every_estimator() {
    let (two, one) = pair(false);
    let rs = RenderScene::new(&two, false).unwrap();
    assert!(rs.features.overlapping && !rs.features.nested);
    // The test has power: the first grid alone is told apart from the sum.
    let d = dir("pair");
    let alone = write_scene(&d, "alone.gltf", &scene(vec![medium("a.vdb", false)]));
    let alone = brume::scene::load(&alone).unwrap();
    let s = overlap_settings(Estimator::Delta, MajorantMode::Adaptive, 99);
    let (ma, mb) = (moments(&render(&alone, &s)), moments(&render(&one, &s)));
    let r = compare((&ma.0, &ma.1), (&mb.0, &mb.1), 1e-3);
    println!(
        "one grid alone vs the sum: {} of {} pixel channels fail",
        r.failing, r.pixels
    );
    assert!(r.failing > r.pixels / 20, "{r:?}");
    for_each_overlap_config(|s, block, alpha, label| agree(&two, &one, s, block, alpha, label));
}

#[test]
fn chromatic_overlapping_grids_render_as_their_sum_with_spectral_tracking() {
    let (two, one) = pair(true);
    let alpha = 1e-3 / 2.0;
    for (i, m) in [MajorantMode::Global, MajorantMode::Adaptive]
        .into_iter()
        .enumerate()
    {
        let s = overlap_settings(Estimator::Delta, m, 50 + i as u32);
        agree(&two, &one, &s, 1, alpha, &format!("spectral {m:?}"));
    }
}

/// The absorbing scene of [`common::boxes::boxes_scene`], seen along one pencil of rays.
fn absorbing_scene(d: &Path, boxes: &[([f32; 3], [f32; 3], f32)], vdb: bool) -> PathBuf {
    let boxes: Vec<_> = boxes.iter().map(|&(lo, hi, s)| (lo, hi, s, 0.0)).collect();
    common::boxes::boxes_scene(d, &boxes, vdb, 1e-4)
}

/// Renders the one-pixel pencil with every estimator (both majorant modes) and z-tests each
/// against `expected`.
fn pencil_agrees(path: &Path, expected: f64, label: &str) {
    let scene = brume::scene::load(path).unwrap_or_else(|e| panic!("{e}"));
    let mut seed = 7;
    for e in Estimator::ALL {
        for m in [MajorantMode::Global, MajorantMode::Adaptive] {
            for absorption in [Absorption::Weight, Absorption::Event] {
                let s = RenderSettings {
                    width: 1,
                    height: 1,
                    spp: 4096,
                    estimator: e,
                    majorant: m,
                    absorption,
                    seed,
                    max_pass_spp: 4096,
                    ..RenderSettings::default()
                };
                seed += 1;
                let out = render(&scene, &s);
                let mean = out.film.mean(0, 0)[0] as f64;
                let se = (out.film.variance_of_mean(0, 0)[0] as f64).sqrt();
                // Bernoulli estimates: the standard error of the expected value bounds it.
                let se = se.max((expected * (1.0 - expected) / s.spp as f64).sqrt());
                let z = (mean - expected) / se;
                println!("{label} {e} {m:?} {absorption:?}: {mean:.5} vs exp(-tau) {expected:.5} (z {z:.2})");
                // 32 tests at 99.9 % overall: |z| < 4.0 (Sidak 3.97).
                assert!(
                    z.abs() < 4.0,
                    "{label} {e} {m:?} {absorption:?}: {mean} vs {expected}"
                );
            }
        }
    }
}

#[test]
fn a_grid_inside_an_absorbing_box_attenuates_by_both() {
    let d = dir("grid_in_box");
    write_grid(&d.join("grid.vdb"), blob_voxels(N));
    let sigma = 0.4f32;
    let path = absorbing_scene(&d, &[([-0.8, -0.8, -0.8], [0.8, 0.8, 0.8], sigma)], true);
    let scene = brume::scene::load(&path).unwrap();
    let rs = RenderScene::new(&scene, false).unwrap();
    assert!(rs.features.nested && rs.features.overlapping);
    // The grid's optical depth along the axis, integrated from the voxels.
    let tau_grid = pencil_depth(&rs.vdb[0]);
    let tau = tau_grid + sigma as f64 * 1.6;
    pencil_agrees(&path, (-tau).exp(), "grid in box");
}

#[test]
fn nested_boxes_keep_a_medium_stack() {
    let d = dir("nested_boxes");
    // Outer box sigma 0.3 over [-1, 1], inner sigma 1.2 over [-0.4, 0.4]: the inner medium
    // replaces the outer inside it (glTF containment), and the outer resumes after it.
    let path = absorbing_scene(
        &d,
        &[([-1.0; 3], [1.0; 3], 0.3), ([-0.4; 3], [0.4; 3], 1.2)],
        false,
    );
    let scene = brume::scene::load(&path).unwrap();
    let rs = RenderScene::new(&scene, false).unwrap();
    assert!(rs.features.nested && !rs.features.overlapping);
    let tau: f64 = 0.3 * 1.2 + 1.2 * 0.8;
    pencil_agrees(&path, (-tau).exp(), "nested boxes");
}

#[test]
fn media_nested_deeper_than_the_stack_are_refused() {
    let d = dir("too_deep");
    let boxes: Vec<_> = (0..5)
        .map(|k| {
            let h = 1.0 - 0.15 * k as f32;
            ([-h; 3], [h; 3], 0.1)
        })
        .collect();
    let path = absorbing_scene(&d, &boxes, false);
    let scene = brume::scene::load(&path).unwrap();
    let err = RenderScene::new(&scene, false).err().expect("refused");
    println!("{err}");
    assert!(
        err.contains("scene.gltf") && err.contains("/nodes/5"),
        "{err}"
    );
    assert!(
        err.contains("5 nested media") && err.contains("at most 4"),
        "{err}"
    );
    // Four levels are fine.
    let path = absorbing_scene(&d, &boxes[..4], false);
    let scene = brume::scene::load(&path).unwrap();
    assert!(RenderScene::new(&scene, false).is_ok());
}

#[test]
fn overlapping_media_with_different_albedos_add_their_coefficients() {
    // The same grid twice with albedos 0.9 and 0.5 (sigma_s = 0.9 + 0.5, sigma_a = 0.1 + 0.5
    // per unit density and densityScale) is one medium of twice the densityScale with
    // albedo 0.7: the scattering event must pick each medium's albedo in proportion to its
    // sigma_s, and decomposition's control must split below both albedos.
    let d = dir("albedos");
    write_grid(&d.join("a.vdb"), blob_voxels(N));
    let m = |c: f32, scale: f32| {
        json!({"uri": "a.vdb", "densityScale": scale, "color": [c, c, c],
               "absorptionColor": [0.0, 0.0, 0.0], "anisotropy": 0.4})
    };
    let two = write_scene(&d, "two.gltf", &scene(vec![m(0.9, 3.0), m(0.5, 3.0)]));
    let one = write_scene(&d, "one.gltf", &scene(vec![m(0.7, 6.0)]));
    let load = |p: &Path| brume::scene::load(p).unwrap_or_else(|e| panic!("{e}"));
    let (two, one) = (load(&two), load(&one));
    let alpha = 1e-3 / 4.0;
    let mut seed = 300;
    for e in [Estimator::Delta, Estimator::Decomposition] {
        for absorption in [Absorption::Weight, Absorption::Event] {
            let s = RenderSettings {
                absorption,
                ..overlap_settings(e, MajorantMode::Adaptive, seed)
            };
            seed += 1;
            agree(
                &two,
                &one,
                &s,
                1,
                alpha,
                &format!("albedos {e} {absorption:?}"),
            );
        }
    }
}

#[test]
fn overlapping_emitting_grids_add_their_emission() {
    // Emission through an emission grid is linear in the grid's values too: two media whose
    // emission grid is their own density emit what one medium emitting through the summed
    // grid does, so each medium's emission is collected at every tentative collision.
    let d = dir("emission");
    write_grid(&d.join("a.vdb"), blob_voxels(N));
    write_grid(&d.join("b.vdb"), shifted());
    write_grid(&d.join("sum.vdb"), summed());
    let m = |uri: &str| {
        let mut m = medium(uri, false);
        m["emissionGrid"] = json!("density");
        m["emissionStrength"] = json!(2.0);
        m["emissionColor"] = json!([1.0, 0.5, 0.2]);
        m
    };
    let two = write_scene(&d, "two.gltf", &scene(vec![m("a.vdb"), m("b.vdb")]));
    let one = write_scene(&d, "one.gltf", &scene(vec![m("sum.vdb")]));
    let load = |p: &Path| brume::scene::load(p).unwrap_or_else(|e| panic!("{e}"));
    let (two, one) = (load(&two), load(&one));
    assert!(RenderScene::new(&two, false).unwrap().features.emission);
    let alpha = 1e-3 / 4.0;
    let mut seed = 400;
    for e in [Estimator::Delta, Estimator::Decomposition] {
        for m in [MajorantMode::Global, MajorantMode::Adaptive] {
            agree(
                &two,
                &one,
                &overlap_settings(e, m, seed),
                1,
                alpha,
                &format!("emission {e} {m:?}"),
            );
            seed += 1;
        }
    }
}

#[test]
fn twenty_overlapping_media_add_like_one() {
    // More media along a ray than the inline span buffer holds (16): twenty copies of the
    // absorbing blob, each with a twentieth of the density scale, attenuate as one.
    let d = dir("twenty");
    write_grid(&d.join("grid.vdb"), blob_voxels(N));
    let path = absorbing_scene(&d, &[], true);
    let mut doc: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    let medium = doc["nodes"][1].clone();
    let mut nodes = vec![doc["nodes"][0].clone()];
    for _ in 0..20 {
        let mut m = medium.clone();
        m["extensions"]["BRUME_medium_vdb"]["densityScale"] = json!(0.15);
        nodes.push(m);
    }
    doc["scenes"][0]["nodes"] = json!((0..nodes.len()).collect::<Vec<_>>());
    doc["nodes"] = json!(nodes);
    let path = write_scene(&d, "twenty.gltf", &doc);
    let scene = brume::scene::load(&path).unwrap();
    let rs = RenderScene::new(&scene, false).unwrap();
    assert_eq!(rs.vdb.len(), 20);
    let tau = pencil_depth(&rs.vdb[0]);
    pencil_agrees(&path, (-tau).exp(), "twenty media");
}
