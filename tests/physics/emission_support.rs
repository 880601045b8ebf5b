//! Volume emission where the density is 0 (`render::emission_bounds`): Principled Volume's
//! emission does not scale with density, so a flame reaching past its smoke, a glow with no
//! emission grid and a fire with no density at all emit wherever their grids say, in every
//! majorant mode and on both backends.
//! - A smoke blob whose flame grid reaches past it: per-leaf, culled and adaptive bounds
//!   render what the global bound does, for delta and decomposition tracking (per-pixel
//!   z-tests, Sidak-corrected at 99.9 %; before the walk bounds took the emission into
//!   account, the per-leaf walk left out the emission outside the smoke).
//! - A flame grid reaching past the density grid's box widens that box (the walks end
//!   there): along a pencil through the flame alone, the exact emission integral in every
//!   mode, on the CPU and on the GPU (no flame cut off at the smoke's box);
//!   a flame whose smoke grid has no voxels at all glows alike.
//! - A medium with no density, seen along one pencil: its emission grid's integral along the
//!   pencil (`common::stress::optical_depth`, exact), and a constant emission times the chord
//!   through its emission region (the box of the grid's active voxels, `[min - 1, max + 2]`
//!   as Cycles' volume mesh), in every mode, on the CPU and on the GPU.
use crate::common;
use common::gpu::gpu_or_skip;
use common::overlap::{dir, overlap_settings, write_scene, N, VOXEL};
use common::render::*;
use common::stress::blob_voxels;

use std::path::Path;
use std::sync::atomic::AtomicBool;

use brume::backend::cpu::RenderOutput;
use brume::backend::gpu::{self, render::render_with_timings, GpuContext};
use brume::render::{Estimator, MajorantMode, RenderScene, RenderSettings};
use serde_json::{json, Value};

/// Voxel shift of the flame against the smoke: it reaches six voxels past the blob, inside
/// the smoke grid's cell box.
const FLAME_SHIFT: i32 = 6;

/// `smoke.vdb`: the blob as `density`, and as `flame` shifted along +x.
fn write_grids(path: &Path) {
    write_grids_shifted(path, FLAME_SHIFT);
}

/// The blob as `density`, and as `flame` shifted `shift` voxels along +x.
fn write_grids_shifted(path: &Path, shift: i32) {
    write_grids_offset(path, [shift, 0, 0]);
}

/// The blob as `density`, and as `flame` moved by `offset` voxels.
fn write_grids_offset(path: &Path, offset: [i32; 3]) {
    let c = N as f64 * VOXEL * 0.5;
    let mut density = brume_ffi::GridSpec::fog("density", VOXEL, [-c + 0.5 * VOXEL; 3]);
    density.voxels = blob_voxels(N);
    let mut flame = brume_ffi::GridSpec::fog("flame", VOXEL, [-c + 0.5 * VOXEL; 3]);
    flame.voxels = blob_voxels(N)
        .into_iter()
        .map(|(p, v)| (std::array::from_fn(|a| p[a] + offset[a]), v))
        .collect();
    brume_ffi::write_float_grids(path, &[density, flame]).unwrap();
}

/// A scene with `medium` seen from `(0, 0, 3)` along -Z (vertical field of view `yfov`)
/// under a sky of radiance `SKY`.
fn scene(medium: Value, yfov: f32) -> Value {
    scene_at(medium, yfov, 0.0)
}

/// [`scene`] with the camera at `(x, 0, 3)`.
fn scene_at(medium: Value, yfov: f32, x: f32) -> Value {
    json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [
            {"camera": 0, "translation": [x, 0.0, 3.0]},
            {"extensions": {"BRUME_medium_vdb": medium}}
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": yfov, "znear": 0.01}}],
        "extensions": {"BRUME_environment": {"color": SKY, "strength": 1.0}},
        "extensionsUsed": ["BRUME_medium_vdb", "BRUME_environment"],
    })
}

const SKY: [f32; 3] = [0.2, 0.3, 0.4];
const EMISSION: [f32; 3] = [1.0, 0.5, 0.2];

fn load(d: &Path, name: &str, doc: &Value) -> brume::scene::Scene {
    let p = write_scene(d, name, doc);
    brume::scene::load(&p).unwrap_or_else(|e| panic!("{e}"))
}

/// The smoke with its flame: density 4, the flame grid emitting at strength 2 (its files in
/// `dir_name`: each test its own, as tests run in parallel).
fn flame_scene(dir_name: &str) -> brume::scene::Scene {
    let d = dir(dir_name);
    write_grids(&d.join("smoke.vdb"));
    let medium = json!({"uri": "smoke.vdb", "densityScale": 4.0, "color": [0.8, 0.8, 0.8],
        "absorptionColor": [0.3, 0.3, 0.3], "anisotropy": 0.3, "emissionGrid": "flame",
        "emissionStrength": 2.0, "emissionColor": EMISSION});
    load(&d, "flame.gltf", &scene(medium, 0.9))
}

/// A medium with no density (`densityScale` 0) emitting through `emission` (the density grid
/// itself, or none: constant), seen along one pencil (files in `dir_name`).
fn glow_scene(dir_name: &str, name: &str, emission_grid: Option<&str>) -> brume::scene::Scene {
    let d = dir(dir_name);
    write_grids(&d.join("smoke.vdb"));
    let mut medium = json!({"uri": "smoke.vdb", "densityScale": 0.0,
        "emissionStrength": 2.0, "emissionColor": EMISSION});
    if let Some(g) = emission_grid {
        medium["emissionGrid"] = json!(g);
    }
    load(&d, name, &scene(medium, 1e-4))
}

/// Z-tests two independent images pixel by pixel and by their means.
fn agree(a: &RenderOutput, b: &RenderOutput, s: &RenderSettings, alpha: f64, label: &str) {
    let r = compare_renders(a, b, s.width as usize, s.height as usize, 1, alpha);
    println!(
        "{label}: {:.5} vs {:.5} (mean z {:.2}), worst pixel z {:.2} (threshold {:.2}), {} of {} failing",
        r.mean_a, r.mean_b, r.mean_z, r.worst_z, r.z_threshold, r.failing, r.pixels
    );
    assert_eq!(r.failing, 0, "{label}: {r:?}");
    assert!(r.mean_z < sidak_z(alpha, 3), "{label}: {r:?}");
}

#[test]
fn a_flame_past_its_smoke_renders_alike_in_every_majorant_mode() {
    let scene = flame_scene("emission_flame");
    let rs = RenderScene::new(&scene, false).unwrap();
    let m = &rs.vdb[0];
    let walk = m
        .walk_bounds
        .as_ref()
        .expect("the flame reaches cells with no smoke");
    let raised = walk
        .cells
        .iter()
        .zip(&m.density.grid.bounds.cells)
        .filter(|(w, d)| w.max > d.max)
        .count();
    println!("flame: {raised} of {} leaf cells raised", walk.cells.len());
    assert!(raised > 0);
    // Raised bounds still bound the density (they only grow).
    for (w, d) in walk.cells.iter().zip(&m.density.grid.bounds.cells) {
        assert!(w.max >= d.max && w.min == d.min);
    }
    // The voxels are raised by per-cell floors over the density's own table, which the walk
    // bounds share rather than copy (a byte a brick voxel).
    let density = &m.density.grid.bounds;
    assert!(std::sync::Arc::ptr_eq(&walk.voxel_q, &density.voxel_q));
    let floored = walk.voxel_floor.iter().filter(|&&f| f > 0).count();
    println!("flame: {floored} leaf cells with a voxel floor");
    assert!(floored > 0);
    // The GPU's one table is the same bounds: every voxel max(q, its cell's floor).
    let table = brume::volume::voxel_bounds::floored_voxel_q(walk, &m.density.grid.grid.cells);
    for (c, &entry) in m.density.grid.grid.cells.iter().enumerate() {
        if entry & brume::volume::grid::CONSTANT_BIT == 0 {
            let b = entry as usize * 512;
            for v in b..b + 512 {
                assert_eq!(table[v], density.voxel_q[v].max(walk.voxel_floor[c]));
            }
        }
    }
    // Wherever it emits, the walk bounds are positive: the leaf cell's and the voxel's.
    let e = m.emission.as_ref().unwrap();
    let cells = brume::volume::LeafCulling::new(walk).unwrap();
    let voxels =
        brume::volume::VoxelCulling::new(walk, &m.density.grid.grid.cells, m.sigma_t_bound)
            .unwrap();
    let lo = walk.cell_origin.map(|c| c as f32 * 8.0);
    let size = walk.dims.map(|d| d as f32 * 8.0);
    let world_from_index = m.density.index_from_world.inverse();
    let mut rng = brume::sampling::Rng::new(5, 0, 1);
    let lookups = std::cell::Cell::new(0);
    let (mut emitting, mut missed) = (0, Vec::new());
    for _ in 0..200_000 {
        let p =
            glam::Vec3::from_array(std::array::from_fn(|a| lo[a] + size[a] * rng.uniform_f32()));
        if e.radiance(world_from_index.transform_point3(p), &lookups)
            .max_element()
            > 0.0
        {
            emitting += 1;
            let voxel = voxels.bound_at(p).unwrap_or(f32::INFINITY);
            if !(cells.bound_at(p) > 0.0 && voxel > 0.0) {
                missed.push((p, cells.bound_at(p), voxel));
            }
        }
    }
    println!(
        "flame: {emitting} of 200000 points emit, {} outside the walk bounds",
        missed.len()
    );
    assert!(missed.is_empty(), "{:?}", &missed[..missed.len().min(5)]);
    let estimators = [Estimator::Delta, Estimator::Decomposition];
    let modes = [
        MajorantMode::Leaf,
        MajorantMode::Culled,
        MajorantMode::Adaptive,
    ];
    let alpha = 1e-3 / (estimators.len() * modes.len()) as f64;
    let mut seed = 40;
    for e in estimators {
        let global = render(&scene, &overlap_settings(e, MajorantMode::Global, seed));
        for mode in modes {
            seed += 1;
            let s = overlap_settings(e, mode, seed);
            let out = render(&scene, &s);
            agree(
                &global,
                &out,
                &s,
                alpha,
                &format!("flame {e} {mode:?} vs global"),
            );
        }
        seed += 1;
    }
}

/// Voxel shift of the far flame: wholly past the smoke grid's cell box along +x.
const FAR_SHIFT: i32 = 40;

/// World x of the far flame's centre (and of its pencil).
fn far_x() -> f32 {
    (FAR_SHIFT as f64 * VOXEL) as f32
}

/// The smoke with its flame [`FAR_SHIFT`] voxels away, seen along one pencil through the
/// flame's centre, where there is no smoke (files in `dir_name`).
fn far_flame_scene(dir_name: &str) -> brume::scene::Scene {
    let d = dir(dir_name);
    write_grids_shifted(&d.join("smoke.vdb"), FAR_SHIFT);
    let medium = json!({"uri": "smoke.vdb", "densityScale": 4.0, "emissionGrid": "flame",
        "emissionStrength": 2.0, "emissionColor": EMISSION});
    load(&d, "far.gltf", &scene_at(medium, 1e-4, far_x()))
}

#[test]
fn a_flame_past_the_smokes_box_widens_it_and_glows_exactly() {
    // Inside the density grid's box: the box stays as it is.
    let inside = flame_scene("emission_inside");
    assert!(inside.warnings.iter().all(|w| !w.contains("emissionGrid")));
    let box_of = |s: &brume::scene::Scene, g: usize| s.vdb_media[0].grids[g].index_bounds.unwrap();
    let own = brume::scene::media::load_grid(&inside.vdb_media[0].vdb_path, "density")
        .unwrap()
        .0
        .index_bounds
        .unwrap();
    assert_eq!(box_of(&inside, 0), own);
    // Shifted 40 voxels: the flame lies past the smoke's box, which is widened to reach it
    // (both grids share one index space).
    let scene = far_flame_scene("emission_outside");
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let widened = box_of(&scene, 0);
    println!("density box {own:?}, widened to {widened:?}");
    // The flame's voxels end at x = FAR_SHIFT + N - 1, and its lookups a voxel further: the
    // widened box takes the leaf cell holding that.
    let last = (FAR_SHIFT + N) as f32;
    assert_eq!(widened.min, own.min);
    assert_eq!((widened.max.y, widened.max.z), (own.max.y, own.max.z));
    assert_eq!(widened.max.x, 8.0 * (last / 8.0).floor() + 8.0);
    // A flame 20,000 voxels away on every axis would need 2500^3 cells: the box stays, and a
    // warning names the grid.
    let d = dir("emission_far_away");
    write_grids_offset(&d.join("smoke.vdb"), [20_000; 3]);
    let medium = json!({"uri": "smoke.vdb", "densityScale": 4.0, "emissionGrid": "flame",
        "emissionStrength": 2.0, "emissionColor": EMISSION});
    let far = load(&d, "far_away.gltf", &self::scene(medium, 0.9));
    println!("{:?}", far.warnings);
    assert_eq!(box_of(&far, 0), own);
    assert!(far.warnings.iter().any(|w| w.contains("emissionGrid")
        && w.contains("\"flame\"")
        && w.contains("inside that box only")));
    // A smoke grid with no voxels at all: the box is the flame's, and it glows.
    let d = dir("emission_no_smoke");
    let c = N as f64 * VOXEL * 0.5;
    let density = brume_ffi::GridSpec::fog("density", VOXEL, [-c + 0.5 * VOXEL; 3]);
    let mut flame = brume_ffi::GridSpec::fog("flame", VOXEL, [-c + 0.5 * VOXEL; 3]);
    flame.voxels = blob_voxels(N);
    brume_ffi::write_float_grids(d.join("smoke.vdb"), &[density, flame]).unwrap();
    let medium = json!({"uri": "smoke.vdb", "densityScale": 4.0, "emissionGrid": "flame",
        "emissionStrength": 2.0, "emissionColor": EMISSION});
    let bare = load(&d, "bare.gltf", &scene_at(medium, 1e-4, 0.0));
    assert!(bare.warnings.iter().all(|w| !w.contains("emissionGrid")));
    let rs = RenderScene::new(&bare, false).unwrap();
    assert_eq!(rs.vdb.len(), 1, "the flame is rendered");
    let out = render(&bare, &glow_settings(MajorantMode::Adaptive, 115));
    check_glow(
        &out,
        glow_expected(&rs, false, 0.0),
        "flame with no smoke voxels",
    );
    // Along the pencil there is no smoke: the sky plus the flame's exact integral.
    let rs = RenderScene::new(&scene, false).unwrap();
    let expected = glow_expected(&rs, false, far_x());
    for (k, mode) in MajorantMode::ALL.into_iter().enumerate() {
        let out = render(&scene, &glow_settings(mode, 110 + k as u32));
        check_glow(&out, expected, &format!("far flame {mode:?}"));
    }
}

/// The pencil's exact radiance in a glow scene: the sky plus the emission's integral along
/// the pencil (from `(x, 0, 3)` along -Z), per channel.
fn glow_expected(rs: &RenderScene, constant: bool, x: f32) -> [f64; 3] {
    let m = &rs.vdb[0];
    let integral = if constant {
        // A constant emission fills the emission region (Cycles' volume mesh, the grid's
        // active voxels' box): the pencil's chord through it, in world units (the map to
        // index space is affine, so ray parameters are world distances).
        let r = m.emission.as_ref().and_then(|e| e.region).unwrap();
        let (o, d) = (
            glam::Vec3::new(x, 0.0, 3.0),
            glam::Vec3::new(0.0, 0.0, -1.0),
        );
        let (t0, t1) = r
            .bounds
            .intersect(
                &brume::math::Ray::new(
                    r.index_from_world.transform_point3(o),
                    r.index_from_world.transform_vector3(d),
                ),
                0.0,
                f32::INFINITY,
            )
            .unwrap();
        (t1 - t0) as f64
    } else {
        // The emission grid is the density grid (the medium tracks a grid of zeros instead,
        // `emission_bounds::without_density`): its exact integral along the pencil.
        let e = m.emission.as_ref().and_then(|e| e.grid.as_ref()).unwrap();
        let ray_w = brume::math::Ray::new(
            glam::Vec3::new(x, 0.0, 3.0),
            glam::Vec3::new(0.0, 0.0, -1.0),
        );
        let ray_i = brume::math::Ray::new(
            e.index_from_world.transform_point3(ray_w.o),
            e.index_from_world.transform_vector3(ray_w.d),
        );
        common::stress::optical_depth(&e.grid.grid, &ray_i, 0.0, 6.0, 1.0)
    };
    std::array::from_fn(|c| SKY[c] as f64 + 2.0 * EMISSION[c] as f64 * integral)
}

/// Checks a one-pixel glow render against `expected` (19 checks share the 99.9 % level).
fn check_glow(out: &RenderOutput, expected: [f64; 3], label: &str) {
    for (c, &e) in expected.iter().enumerate() {
        let mean = out.film.mean(0, 0)[c] as f64;
        let se = (out.film.variance_of_mean(0, 0)[c] as f64).sqrt().max(1e-9);
        let z = (mean - e) / se;
        println!("{label} channel {c}: {mean:.5} vs {e:.5} (z {z:.2})");
        assert!(
            z.abs() < sidak_z(1e-3 / 19.0, 3),
            "{label} channel {c}: {mean} vs {e}"
        );
    }
}

fn glow_settings(majorant: MajorantMode, seed: u32) -> RenderSettings {
    RenderSettings {
        width: 1,
        height: 1,
        spp: 4096,
        majorant,
        seed,
        max_pass_spp: 4096,
        ..RenderSettings::default()
    }
}

#[test]
fn a_medium_with_no_density_glows_by_its_emission_in_every_majorant_mode() {
    for (name, grid) in [("grid.gltf", Some("density")), ("constant.gltf", None)] {
        let scene = glow_scene("emission_glow", name, grid);
        let rs = RenderScene::new(&scene, false).unwrap();
        assert_eq!(rs.vdb.len(), 1, "{name}: the medium is rendered");
        let expected = glow_expected(&rs, grid.is_none(), 0.0);
        for (k, mode) in MajorantMode::ALL.into_iter().enumerate() {
            let out = render(&scene, &glow_settings(mode, 70 + k as u32));
            check_glow(&out, expected, &format!("{name} {mode:?}"));
        }
    }
}

fn gpu_render(ctx: &GpuContext, scene: &brume::scene::Scene, s: &RenderSettings) -> RenderOutput {
    let rs = RenderScene::new(scene, false).unwrap();
    gpu::supports(&rs).unwrap();
    let (out, t) = render_with_timings(ctx, &rs, s, &AtomicBool::new(false), &|_, _, _| {})
        .unwrap_or_else(|e| panic!("{e}"));
    println!("GPU variant {}", t.variant);
    out
}

/// GPU renders of a glow scene with the global bound and adaptive bounds (seeds `seed`,
/// `seed + 1`), each checked against `expected`.
fn gpu_glows(
    ctx: &GpuContext,
    scene: &brume::scene::Scene,
    expected: [f64; 3],
    seed: u32,
    label: &str,
) {
    for (k, mode) in [MajorantMode::Global, MajorantMode::Adaptive]
        .into_iter()
        .enumerate()
    {
        let out = gpu_render(ctx, scene, &glow_settings(mode, seed + k as u32));
        check_glow(&out, expected, &format!("{label} {mode:?}"));
    }
}

#[test]
fn emission_without_density_renders_on_the_gpu() {
    let Some(ctx) = gpu_or_skip("emission_without_density_renders_on_the_gpu") else {
        return;
    };
    for (name, grid) in [("grid.gltf", Some("density")), ("constant.gltf", None)] {
        let scene = glow_scene("emission_glow_gpu", name, grid);
        let rs = RenderScene::new(&scene, false).unwrap();
        let expected = glow_expected(&rs, grid.is_none(), 0.0);
        gpu_glows(&ctx, &scene, expected, 90, &format!("GPU {name}"));
    }
    // The flame past the smoke's box, along its pencil.
    let scene = far_flame_scene("emission_outside_gpu");
    let rs = RenderScene::new(&scene, false).unwrap();
    let expected = glow_expected(&rs, false, far_x());
    gpu_glows(&ctx, &scene, expected, 120, "GPU far flame");
    // The flame past its smoke: the GPU's adaptive render against the CPU's global one.
    let scene = flame_scene("emission_flame_gpu");
    let s = overlap_settings(Estimator::Delta, MajorantMode::Adaptive, 95);
    let g = gpu_render(&ctx, &scene, &s);
    let c = render(
        &scene,
        &overlap_settings(Estimator::Delta, MajorantMode::Global, 96),
    );
    agree(&g, &c, &s, 1e-3, "flame GPU adaptive vs CPU global");
}
