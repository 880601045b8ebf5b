//! Embree (`--accel embree`) must answer the closest hits the BVH answers: Embree only chooses
//! the triangle and Brume's triangle test gives `t` and the barycentrics, so the hits agree in
//! triangle and `t` bit for bit, except where two triangles are hit at the same point: at
//! exactly the same `t`, or on their shared edge, where the one test run on each triangle
//! (its corners in another order) rounds `t` a few ulps apart (a tie either may win). Occlusion uses each accelerator's own triangle test, so rays that
//! graze an edge may differ there; such rays are counted and must stay rare. Each example
//! scene and the heavy scene take 10^6 random rays.
use brume::accel::embree::EmbreeTriangles;
use brume::accel::{intersect_triangle, Accel, Hit, TriangleBvh};
use brume::math::Ray;
use brume::render::RenderSettings;
use brume::scene::Scene;
use glam::{Vec3, Vec3A};

use crate::common::render::{load_scene, render, EXAMPLE_SCENES};
use crate::common::scratch;

#[allow(dead_code)]
#[path = "../../scenes/make_heavy.rs"]
pub mod make_heavy;

/// Random rays per scene on which the accelerators are compared.
const RAYS: usize = 1_000_000;

use crate::common::rays::Rng;

/// What comparing the two accelerators over a set of rays found.
#[derive(Default, Debug)]
struct Tally {
    rays: usize,
    hits: usize,
    /// Different triangles at exactly the same `t` (allowed).
    ties: usize,
    /// Different triangles, each hit by Brume's test on their shared edge, with `t` a few
    /// ulps apart (allowed: the same point, rounded by two corner orders).
    edge_ties: usize,
    /// Embree's triangle rejected by Brume's test, so the BVH answered.
    fallbacks: usize,
    /// Any other difference in triangle or `t` (must be none).
    mismatches: usize,
    /// Occlusion answers that differ.
    occlusion_differs: usize,
}

/// Compares closest hits and occlusion of `rays` rays with origins in `lo..hi` and uniform
/// directions; the occlusion ray ends at a random point of the box.
fn compare(
    bvh: &TriangleBvh,
    embree: &EmbreeTriangles,
    lo: Vec3,
    hi: Vec3,
    rays: usize,
    seed: u64,
) -> Tally {
    let mut rng = Rng(seed);
    let mut tally = Tally {
        rays,
        ..Tally::default()
    };
    for _ in 0..rays {
        let ray = Ray::new(rng.in_box(lo, hi), rng.direction());
        let a = bvh.closest_hit(&ray, 0.0, f32::INFINITY);
        let b = embree.closest_hit(bvh, &ray, 0.0, f32::INFINITY);
        tally.hits += a.is_some() as usize;
        if let Some(k) = embree.embree_triangle(&ray, 0.0, f32::INFINITY) {
            let tri = &bvh.triangles()[k as usize];
            tally.fallbacks += intersect_triangle(&ray, tri, 0.0, f32::INFINITY).is_none() as usize;
        }
        match (a, b) {
            _ if a == b => {}
            (Some(x), Some(y)) if x.t == y.t => tally.ties += 1,
            (Some(x), Some(y)) if on_shared_edge(bvh, x, y) => tally.edge_ties += 1,
            _ => {
                tally.mismatches += 1;
                if tally.mismatches <= 5 {
                    report_mismatch(bvh, &ray, a, b);
                }
            }
        }
        let t_max = (rng.in_box(lo, hi) - ray.o).length();
        let occluded = bvh.any_hit(&ray, 0.0, t_max);
        tally.occlusion_differs += (occluded != embree.occluded(&ray, 0.0, t_max)) as usize;
    }
    tally
}

/// Whether hits `x` and `y` are one point on the edge two triangles share: `t` within 8 ulps,
/// one of the barycentric coordinates of either 0, and the triangles sharing two corners.
fn on_shared_edge(bvh: &TriangleBvh, x: Hit, y: Hit) -> bool {
    let close = (x.t - y.t).abs() <= 8.0 * f32::EPSILON * x.t.abs().max(y.t.abs());
    let on_edge = |h: Hit| h.b1 == 0.0 || h.b2 == 0.0 || h.b1 + h.b2 >= 1.0;
    let corners = |h: Hit| bvh.triangles()[h.triangle as usize];
    let (a, b) = (corners(x), corners(y));
    let shared = a.iter().filter(|p| b.contains(p)).count();
    close && (on_edge(x) || on_edge(y)) && shared >= 2
}

fn report_mismatch(bvh: &TriangleBvh, ray: &Ray, a: Option<Hit>, b: Option<Hit>) {
    let t_of = |h: Option<Hit>| {
        h.and_then(|h| {
            intersect_triangle(
                ray,
                &bvh.triangles()[h.triangle as usize],
                0.0,
                f32::INFINITY,
            )
        })
    };
    eprintln!(
        "  mismatch: ray {:?} -> {:?}: bvh {a:?} (Brume's test {:?}), embree {b:?} (Brume's test {:?})",
        ray.o,
        ray.d,
        t_of(a),
        t_of(b)
    );
}

/// Embree over the scene's static triangles, built the way `Scene::use_accel` builds it.
fn embree_of(scene: &Scene) -> EmbreeTriangles {
    let vertices: Vec<[f32; 3]> = scene.vertices().iter().map(|v| v.position).collect();
    let indices: Vec<[u32; 3]> = scene.triangles().iter().map(|t| t.vertices).collect();
    EmbreeTriangles::build(&vertices, &indices)
        .unwrap_or_else(|e| panic!("{}: {e}", scene.source.display()))
}

fn check(name: &str, t: &Tally) {
    eprintln!(
        "{name}: {} rays, {} hits, {} exact ties, {} ties on a shared edge, {} fallbacks to the BVH, {} mismatches, {} occlusion differences",
        t.rays, t.hits, t.ties, t.edge_ties, t.fallbacks, t.mismatches, t.occlusion_differs
    );
    assert_eq!(t.mismatches, 0, "{name}: closest hits differ beyond ties");
    // Occlusion differs only for rays grazing an edge (each side uses its own test).
    assert!(
        t.occlusion_differs * 10_000 <= t.rays,
        "{name}: occlusion differs on {} of {} rays",
        t.occlusion_differs,
        t.rays
    );
}

#[test]
fn embree_and_bvh_agree_on_every_example_scene() {
    let mut total = Tally::default();
    for (k, name) in EXAMPLE_SCENES.iter().enumerate() {
        let scene = load_scene(name);
        let embree = embree_of(&scene);
        // Origins in the scene's bounds grown by a tenth, so some rays start outside.
        let pad = 0.1 * (scene.bounds.max - scene.bounds.min);
        let (lo, hi) = (scene.bounds.min - pad, scene.bounds.max + pad);
        let t = compare(scene.bvh(), &embree, lo, hi, RAYS, 1000 + k as u64);
        check(
            &format!("{name} ({} triangles)", scene.triangle_count()),
            &t,
        );
        total.rays += t.rays;
        total.hits += t.hits;
        total.ties += t.ties;
        total.edge_ties += t.edge_ties;
        total.fallbacks += t.fallbacks;
        total.mismatches += t.mismatches;
        total.occlusion_differs += t.occlusion_differs;
    }
    check("all example scenes", &total);
}

/// The heavy scene (`scenes/make_heavy.rs` at its defaults: 511,120 triangles stored,
/// 6.3 million placed), the same comparison; then Embree over the stored primitives under
/// their placements (what `--accel auto` renders it with) against the flat BVH.
#[test]
fn embree_and_bvh_agree_on_the_heavy_scene() {
    let path = scratch::dir("accel_heavy").join("heavy.gltf");
    let w = make_heavy::write_scene(&path, &make_heavy::Params::default()).unwrap();
    let mut scene = brume::scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.triangle_count(), w.placed_triangles);
    let embree = embree_of(&scene);
    let pad = 0.1 * (scene.bounds.max - scene.bounds.min);
    let (lo, hi) = (scene.bounds.min - pad, scene.bounds.max + pad);
    let t = compare(scene.bvh(), &embree, lo, hi, RAYS, 77);
    check(
        &format!("heavy scene ({} triangles)", w.placed_triangles),
        &t,
    );
    drop(embree);
    assert_eq!(scene.use_accel(Accel::Auto).unwrap().accel, Accel::Embree);
    assert!(scene.embree.as_ref().is_some_and(|e| e.is_instanced()));
    crate::accel_instanced::compare_with(&scene, "instanced Embree", 78, RAYS, |ray| {
        scene.closest_hit(ray, 0.0, f32::INFINITY, 0.0)
    });
}

#[test]
fn embree_and_bvh_agree_on_a_triangle_soup() {
    // Through the CWBVH proper (far above the small-mesh size), with touching and crossing
    // triangles: a grid of unit squares (shared edges, so exact ties) plus random triangles.
    let mut rng = Rng(5);
    let mut tris: Vec<[Vec3A; 3]> = Vec::new();
    for i in 0..40 {
        for j in 0..40 {
            let p = |a: f32, b: f32| Vec3A::new(i as f32 + a - 20.0, j as f32 + b - 20.0, 0.0);
            tris.push([p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0)]);
            tris.push([p(0.0, 0.0), p(1.0, 1.0), p(0.0, 1.0)]);
        }
    }
    for _ in 0..20_000 {
        let c = rng.in_box(Vec3::splat(-20.0), Vec3::splat(20.0));
        let s = 0.1 + 1.5 * rng.next();
        tris.push([0, 1, 2].map(|_| Vec3A::from(c + rng.in_box(Vec3::splat(-s), Vec3::splat(s)))));
    }
    let bvh = TriangleBvh::build(tris);
    let embree = EmbreeTriangles::of_bvh(&bvh).unwrap();
    let t = compare(
        &bvh,
        &embree,
        Vec3::splat(-22.0),
        Vec3::splat(22.0),
        200_000,
        77,
    );
    check(&format!("triangle soup ({} triangles)", bvh.len()), &t);
}

/// The nearest hit by Brume's test over every triangle, ties to the lowest index.
fn brute_closest(tris: &[[Vec3A; 3]], ray: &Ray) -> Option<(f32, u32)> {
    let mut best: Option<(f32, u32)> = None;
    for (k, tri) in tris.iter().enumerate() {
        if let Some((t, _, _)) = intersect_triangle(ray, tri, 0.0, f32::INFINITY) {
            if best.map_or(true, |(b, _)| t < b) {
                best = Some((t, k as u32));
            }
        }
    }
    best
}

#[test]
fn rays_through_shared_edges_and_corners_agree_up_to_exact_ties() {
    // A flat grid of unit squares split into two triangles each, and rays aimed at its
    // vertices and edge midpoints: several triangles are hit at the same t, Brume's test may
    // reject the triangle Embree's watertight test picks (the BVH then answers), and either
    // may win a tie. Both are checked against brute force over every triangle: each answer
    // must be brute force's up to exact ties.
    let mut tris: Vec<[Vec3A; 3]> = Vec::new();
    for i in 0..16 {
        for j in 0..16 {
            let p = |a: f32, b: f32| Vec3A::new(i as f32 + a - 8.0, j as f32 + b - 8.0, 0.0);
            tris.push([p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0)]);
            tris.push([p(0.0, 0.0), p(1.0, 1.0), p(0.0, 1.0)]);
        }
    }
    let bvh = TriangleBvh::build(tris);
    let embree = EmbreeTriangles::of_bvh(&bvh).unwrap();
    let mut rng = Rng(13);
    let rays = 20_000;
    let (mut ties, mut fallbacks, mut via_bvh, mut other, mut bvh_wrong) = (0, 0, 0, 0, 0);
    let key = |h: Option<Hit>| h.map(|h| (h.t, h.triangle));
    for _ in 0..rays {
        let o = rng.in_box(Vec3::new(-8.0, -8.0, 0.5), Vec3::new(8.0, 8.0, 4.0));
        let half = |x: f32| (2.0 * x).round() / 2.0;
        let target = Vec3::new(
            half(o.x + rng.next() - 0.5),
            half(o.y + rng.next() - 0.5),
            0.0,
        );
        let ray = Ray::new(o, target - o);
        let brute = brute_closest(bvh.triangles(), &ray);
        // Some(is a tie) where `h` is brute force's answer up to an exact tie.
        let agrees = |h: Option<Hit>| match (key(h), brute) {
            (a, b) if a == b => Some(false),
            (Some((t, _)), Some((u, _))) if t == u => Some(true),
            _ => None,
        };
        if let Some(k) = embree.embree_triangle(&ray, 0.0, f32::INFINITY) {
            let tri = &bvh.triangles()[k as usize];
            fallbacks += intersect_triangle(&ray, tri, 0.0, f32::INFINITY).is_none() as usize;
        }
        let (e, b) = (
            embree.closest_hit(&bvh, &ray, 0.0, f32::INFINITY),
            bvh.closest_hit(&ray, 0.0, f32::INFINITY),
        );
        bvh_wrong += agrees(b).is_none() as usize;
        match agrees(e) {
            Some(tie) => ties += tie as usize,
            None if e == b => via_bvh += 1,
            None => {
                other += 1;
                report_mismatch(&bvh, &ray, b, e);
            }
        }
    }
    eprintln!(
        "rays through a grid's edges and corners: {rays} rays; Embree: {ties} exact ties with \
         brute force, {fallbacks} fallbacks to the BVH, {via_bvh} answers unlike brute force \
         (all the BVH's, through a fallback), {other} other differences; the BVH: {bvh_wrong} \
         answers unlike brute force"
    );
    assert_eq!(
        other, 0,
        "Embree's hits are neither brute force's nor the BVH's"
    );
    assert_eq!(bvh_wrong, 0, "the BVH's hits differ from brute force");
}

#[test]
fn an_empty_scene_misses() {
    let bvh = TriangleBvh::build(Vec::new());
    let embree = EmbreeTriangles::of_bvh(&bvh).unwrap();
    let ray = Ray::new(Vec3::ZERO, Vec3::X);
    assert_eq!(embree.closest_hit(&bvh, &ray, 0.0, f32::INFINITY), None);
    assert!(!embree.occluded(&ray, 0.0, f32::INFINITY));
}

#[test]
fn bad_indices_are_an_error_naming_the_triangle() {
    let err = EmbreeTriangles::build(&[[0.0; 3]; 3], &[[0, 1, 2], [0, 1, 9]]).unwrap_err();
    eprintln!("{err}");
    assert!(err.contains("triangle 1 indexes vertex 9 of 3"), "{err}");
    let err = EmbreeTriangles::build(&[[0.0, f32::NAN, 0.0]], &[[0, 0, 0]]).unwrap_err();
    assert!(err.contains("vertex 0 is not finite"), "{err}");
}

#[test]
fn a_surface_scene_renders_the_same_image_through_embree() {
    let bvh_scene = load_scene("cornell_smoke.gltf");
    let mut embree_scene = load_scene("cornell_smoke.gltf");
    assert_eq!(
        embree_scene.use_accel(Accel::Embree).unwrap().accel,
        Accel::Embree
    );
    let settings = RenderSettings {
        width: 32,
        height: 32,
        spp: 8,
        seed: 3,
        accel: Accel::Embree,
        ..RenderSettings::default()
    };
    let a = render(&bvh_scene, &settings);
    let b = render(&embree_scene, &settings);
    let differ = a
        .film
        .pixels()
        .iter()
        .zip(b.film.pixels())
        .filter(|(x, y)| x.mean != y.mean)
        .count();
    eprintln!("cornell_smoke 32x32, 8 spp: {differ} of 1024 pixels differ");
    assert_eq!(
        differ, 0,
        "the same seed through Embree gives another image"
    );
}
