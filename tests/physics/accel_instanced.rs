//! The two-level BVH (each primitive stored once in its mesh's local space, under a BVH of its
//! placements) must answer the closest hits the flat BVH over the world-space triangles
//! answers: the same triangle, in the flat order, and `t` and the barycentrics from Brume's
//! triangle test on the same world-space corners, so bit for bit, except where two triangles
//! are hit at one point (an exact tie, or a shared edge where the local test, run in another
//! space, rounds the other way). Checked on the instancing examples and on the heavy scene at a
//! reduced size, and through a render: with the same seed, an instanced scene's image through
//! the two-level BVH is the flat BVH's image, and both groves agree in the mean.
use brume::accel::{Accel, Hit};
use brume::math::Ray;
use brume::render::RenderSettings;
use brume::scene::Scene;

use crate::accel_embree::make_heavy;
use crate::common::render::{render, same_seed_close, scene_path, sidak_z};
use crate::common::scratch;

/// Random rays per scene.
const RAYS: usize = 200_000;

use crate::common::rays::Rng;

/// Whether `t` values name one point along `ray` (unit direction) to a few ulps of the
/// coordinates involved: two tests, in two spaces, round a point on a shared edge apart by the
/// coordinates' ulps, not by `t`'s.
fn close(ray: &Ray, a: f32, b: f32) -> bool {
    let scale = ray.o.abs().max_element() + a.abs().max(b.abs());
    (a - b).abs() <= 64.0 * f32::EPSILON * scale
}

/// Compares the scene's two-level closest hits with its flat BVH's on `RAYS` rays from the
/// scene's bounds grown by a tenth; returns (hits, ties) and fails on any other difference.
fn compare(scene: &Scene, seed: u64) -> (usize, usize) {
    let name = scene.source.display();
    let two_level = scene
        .instanced
        .as_ref()
        .unwrap_or_else(|| panic!("{name}: no two-level BVH"));
    let flat = scene.bvh();
    let pad = 0.1 * (scene.bounds.max - scene.bounds.min);
    let (lo, hi) = (scene.bounds.min - pad, scene.bounds.max + pad);
    let mut rng = Rng(seed);
    let (mut hits, mut ties, mut mismatches) = (0, 0, 0);
    for _ in 0..RAYS {
        let ray = Ray::new(rng.in_box(lo, hi), rng.direction());
        let a = flat.closest_hit(&ray, 0.0, f32::INFINITY);
        let b = two_level.closest_hit(&ray, 0.0, f32::INFINITY);
        hits += a.is_some() as usize;
        match (a, b) {
            _ if a == b => {}
            (Some(x), Some(y)) if close(&ray, x.t, y.t) => ties += 1,
            _ => {
                mismatches += 1;
                if mismatches <= 5 {
                    eprintln!(
                        "  {name}: ray {:?} -> {:?}: flat {a:?}, two-level {b:?}",
                        ray.o, ray.d
                    );
                }
            }
        }
    }
    eprintln!("{name}: {RAYS} rays, {hits} hits, {ties} ties, {mismatches} mismatches");
    assert_eq!(mismatches, 0, "{name}: closest hits differ beyond ties");
    // Ties need two triangles at one point; they stay rare.
    assert!(
        ties * 1000 <= hits.max(1),
        "{name}: {ties} ties of {hits} hits"
    );
    (hits, ties)
}

fn load(path: &std::path::Path) -> Scene {
    brume::scene::load(path).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn two_level_and_flat_bvh_agree_on_the_instancing_examples() {
    for (k, name) in ["instancing/grove_ext.gltf", "instancing/grove_nodes.gltf"]
        .iter()
        .enumerate()
    {
        let scene = load(&scene_path(name));
        let (hits, _) = compare(&scene, 500 + k as u64);
        assert!(hits > RAYS / 20, "{name}: too few hits ({hits}) to test");
    }
}

/// The heavy scene at a reduced size, both with one instancing node per mesh and one node per
/// instance: terrain placed once, rocks and trees placed many times.
#[test]
fn two_level_and_flat_bvh_agree_on_a_reduced_heavy_scene() {
    for (k, nodes) in [false, true].into_iter().enumerate() {
        let path = scratch::dir("accel_instanced").join(format!("heavy_{nodes}.gltf"));
        let params = make_heavy::Params {
            terrain_triangles: 20_000,
            instances: 300,
            nodes,
            detail: 1,
        };
        let w = make_heavy::write_scene(&path, &params).unwrap();
        let scene = load(&path);
        assert_eq!(scene.triangle_count(), w.placed_triangles);
        let two_level = scene.instanced.as_ref().expect("a two-level BVH");
        assert_eq!(two_level.len(), w.placed_triangles);
        assert_eq!(two_level.placements(), w.placements);
        compare(&scene, 900 + k as u64);
    }
}

/// A scene without a repeated primitive keeps the flat BVH, built with the scene.
#[test]
fn scenes_without_repeats_keep_the_flat_bvh() {
    let scene = load(&scene_path("cornell_smoke.gltf"));
    assert!(scene.instanced.is_none());
    assert!(scene.built_flat_bvh().is_some());
}

/// `--accel auto` keeps the two-level BVH of an instanced scene (Embree would hold every
/// placement's copy); `--accel embree` builds Embree over the flat triangles, and its hits
/// agree with the two-level BVH's on the same triangles.
#[test]
fn auto_keeps_the_two_level_bvh_and_embree_still_answers_by_name() {
    let mut scene = load(&scene_path("instancing/grove_ext.gltf"));
    let used = scene.use_accel(Accel::Auto).unwrap();
    assert_eq!(used.accel, Accel::Bvh);
    assert!(scene.embree.is_none() && scene.instanced.is_some());
    let used = scene.use_accel(Accel::Embree).unwrap();
    assert_eq!(used.accel, Accel::Embree);
    let two_level = scene.instanced.as_ref().unwrap();
    let mut rng = Rng(7);
    let (lo, hi) = (scene.bounds.min, scene.bounds.max);
    let mut differ = 0;
    for _ in 0..20_000 {
        let ray = Ray::new(rng.in_box(lo, hi), rng.direction());
        let a: Option<Hit> = scene.closest_hit(&ray, 0.0, f32::INFINITY, 0.0);
        let b = two_level.closest_hit(&ray, 0.0, f32::INFINITY);
        differ += match (a, b) {
            (Some(x), Some(y)) => (x.triangle != y.triangle && !close(&ray, x.t, y.t)) as usize,
            (x, y) => (x.is_some() != y.is_some()) as usize,
        };
    }
    assert!(
        differ <= 2,
        "Embree and the two-level BVH differ on {differ} rays"
    );
}

/// With one seed, rendering through the two-level BVH gives the flat BVH's image (hits equal
/// bit for bit but for ties); and the grove placed by instancing rows renders the same in the
/// mean as the grove placed by one node per instance (per channel, z-tested).
#[test]
fn instanced_groves_render_as_the_flat_ones() {
    let settings = RenderSettings {
        width: 24,
        height: 16,
        spp: 64,
        seed: 5,
        ..RenderSettings::default()
    };
    let mut ext = load(&scene_path("instancing/grove_ext.gltf"));
    let two_level = render(&ext, &settings);
    ext.instanced = None;
    let flat = render(&ext, &settings);
    let (same, all) = same_seed_close(&two_level, &flat);
    assert!(same * 100 >= all * 99, "{same} of {all} pixel values equal");

    let nodes = load(&scene_path("instancing/grove_nodes.gltf"));
    let other = render(
        &nodes,
        &RenderSettings {
            seed: 6,
            ..settings.clone()
        },
    );
    let n = two_level.film.pixels().len() as f64;
    for c in 0..3 {
        let stats = |o: &brume::backend::cpu::RenderOutput| {
            o.film.pixels().iter().fold((0.0, 0.0), |(m, v), p| {
                (m + p.mean[c] / n, v + p.variance_of_mean()[c] / (n * n))
            })
        };
        let ((ma, va), (mb, vb)) = (stats(&two_level), stats(&other));
        let z = (ma - mb).abs() / (va + vb).sqrt().max(1e-12);
        println!("channel {c}: rows {ma:.5}, nodes {mb:.5}, z {z:.2}");
        assert!(
            z < sidak_z(1e-3, 3),
            "channel {c}: image means differ (z {z:.2})"
        );
    }
}
