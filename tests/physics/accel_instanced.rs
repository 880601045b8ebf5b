//! The two-level BVH (each primitive stored once in its mesh's local space, under a BVH of its
//! placements) must answer the closest hits the flat BVH over the world-space triangles
//! answers: the same triangle, in the flat order, and `t` and the barycentrics from Brume's
//! triangle test on the same world-space corners, so bit for bit, except where two triangles
//! are hit at one point (an exact tie, or a shared edge where the local test, run in another
//! space, rounds the other way), and the rare ray through the crack between two triangles in
//! world space, which the local test hits. Checked on the instancing examples and on the heavy scene at a
//! reduced size, and through a render: with the same seed, an instanced scene's image through
//! the two-level BVH is the flat BVH's image, and both groves agree in the mean. Embree over
//! the same stored primitives and placements (what `--accel auto` takes for such scenes) is
//! held to the same comparison.
use brume::accel::{intersect_triangle, Accel, Hit, TriangleBvh};
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

/// Whether `y` is a hit on an edge of its triangle that Brume's test on the triangle's world
/// corners misses, nearer than the flat BVH's answer `a`: a ray through the crack between two
/// triangles in world space, which the local-space test run by the two-level BVH closes.
fn through_a_crack(flat: &TriangleBvh, ray: &Ray, a: Option<Hit>, y: Hit) -> bool {
    let on_edge = y.b1.min(y.b2).min(1.0 - y.b1 - y.b2) < 1e-4;
    let corners = &flat.triangles()[y.triangle as usize];
    on_edge
        && intersect_triangle(ray, corners, 0.0, f32::INFINITY).is_none()
        && a.map_or(true, |a| a.t > y.t)
}

/// Compares `other`'s closest hits with the scene's flat BVH's on `rays` rays from the scene's
/// bounds grown by a tenth; returns (hits, ties) and fails on any other difference than ties
/// and rare rays through a crack (see [`through_a_crack`]).
pub fn compare_with(
    scene: &Scene,
    what: &str,
    seed: u64,
    rays: usize,
    other: impl Fn(&Ray) -> Option<Hit>,
) -> (usize, usize) {
    let name = format!("{} ({what})", scene.source.display());
    let flat = scene.bvh();
    let pad = 0.1 * (scene.bounds.max - scene.bounds.min);
    let (lo, hi) = (scene.bounds.min - pad, scene.bounds.max + pad);
    let mut rng = Rng(seed);
    let (mut hits, mut ties, mut cracks, mut mismatches) = (0, 0, 0, 0);
    for _ in 0..rays {
        let ray = Ray::new(rng.in_box(lo, hi), rng.direction());
        let a = flat.closest_hit(&ray, 0.0, f32::INFINITY);
        let b = other(&ray);
        hits += a.is_some() as usize;
        match (a, b) {
            _ if a == b => {}
            (Some(x), Some(y)) if close(&ray, x.t, y.t) => ties += 1,
            (_, Some(y)) if through_a_crack(flat, &ray, a, y) => cracks += 1,
            _ => {
                mismatches += 1;
                if mismatches <= 5 {
                    eprintln!(
                        "  {name}: ray {:?} -> {:?}: flat {a:?}, other {b:?}",
                        ray.o, ray.d
                    );
                }
            }
        }
    }
    eprintln!(
        "{name}: {rays} rays, {hits} hits, {ties} ties, {cracks} through a crack, \
         {mismatches} mismatches"
    );
    assert_eq!(mismatches, 0, "{name}: closest hits differ beyond ties");
    assert!(
        cracks * 100_000 <= hits.max(1),
        "{name}: {cracks} rays of {hits} hits through a crack"
    );
    // Ties need two triangles at one point; they stay rare.
    assert!(
        ties * 1000 <= hits.max(1),
        "{name}: {ties} ties of {hits} hits"
    );
    (hits, ties)
}

/// [`compare_with`] for the two-level BVH, then for Embree over the same stored primitives
/// (through `Scene::closest_hit`, as a render asks); returns the two-level BVH's (hits, ties).
fn compare(scene: &mut Scene, seed: u64) -> (usize, usize) {
    let two_level = scene
        .instanced
        .as_ref()
        .unwrap_or_else(|| panic!("{}: no two-level BVH", scene.source.display()));
    let out = compare_with(scene, "two-level BVH", seed, RAYS, |ray| {
        two_level.closest_hit(ray, 0.0, f32::INFINITY)
    });
    let used = scene.use_accel(Accel::Embree).unwrap();
    assert_eq!(used.accel, Accel::Embree);
    assert!(scene.embree.as_ref().is_some_and(|e| e.is_instanced()));
    compare_with(scene, "instanced Embree", seed, RAYS, |ray| {
        scene.closest_hit(ray, 0.0, f32::INFINITY, 0.0)
    });
    scene.use_accel(Accel::Bvh).unwrap();
    out
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
        let mut scene = load(&scene_path(name));
        let (hits, _) = compare(&mut scene, 500 + k as u64);
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
        let mut scene = load(&path);
        assert_eq!(scene.triangle_count(), w.placed_triangles);
        let two_level = scene.instanced.as_ref().expect("a two-level BVH");
        assert_eq!(two_level.len(), w.placed_triangles);
        assert_eq!(two_level.placements(), w.placements);
        compare(&mut scene, 900 + k as u64);
    }
}

/// A scene without a repeated primitive keeps the flat BVH, built with the scene.
#[test]
fn scenes_without_repeats_keep_the_flat_bvh() {
    let scene = load(&scene_path("cornell_smoke.gltf"));
    assert!(scene.instanced.is_none());
    assert!(scene.built_flat_bvh().is_some());
}

/// `--accel auto` gives an instanced scene Embree over each stored primitive once, under the
/// two-level BVH's placements: neither the world arrays nor the flat BVH are built for it.
/// `--accel bvh` traces through the two-level BVH alone.
#[test]
fn auto_takes_instanced_embree_and_bvh_the_two_level_bvh() {
    let mut scene = load(&scene_path("instancing/grove_ext.gltf"));
    let used = scene.use_accel(Accel::Auto).unwrap();
    assert_eq!(used.accel, Accel::Embree);
    assert!(scene.embree.as_ref().is_some_and(|e| e.is_instanced()));
    assert!(scene.instanced.is_some());
    assert!(!scene.world_arrays_built() && scene.built_flat_bvh().is_none());
    let used = scene.use_accel(Accel::Bvh).unwrap();
    assert_eq!(used.accel, Accel::Bvh);
    assert!(scene.embree.is_none() && scene.instanced.is_some());
    let two_level = scene.instanced.as_ref().unwrap();
    let mut rng = Rng(7);
    let (lo, hi) = (scene.bounds.min, scene.bounds.max);
    for _ in 0..1000 {
        let ray = Ray::new(rng.in_box(lo, hi), rng.direction());
        let a: Option<Hit> = scene.closest_hit(&ray, 0.0, f32::INFINITY, 0.0);
        assert_eq!(a, two_level.closest_hit(&ray, 0.0, f32::INFINITY));
    }
}

/// With one seed, rendering through the two-level BVH gives instanced Embree's and the flat
/// BVH's image (hits equal bit for bit but for ties); and the grove placed by instancing rows renders the same in the
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
    ext.use_accel(Accel::Embree).unwrap();
    let embree = render(&ext, &settings);
    let (same, all) = same_seed_close(&two_level, &embree);
    println!("instanced Embree: {same} of {all} pixel values equal the two-level BVH's");
    assert!(same * 100 >= all * 99, "{same} of {all} pixel values equal");
    ext.use_accel(Accel::Bvh).unwrap();
    ext.instanced = None;
    let flat = render(&ext, &settings);
    let (same, all) = same_seed_close(&two_level, &flat);
    println!("flat BVH: {same} of {all} pixel values equal the two-level BVH's");
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
