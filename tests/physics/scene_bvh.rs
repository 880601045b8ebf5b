//! The BVH must answer exactly what brute force over every triangle answers: both use the same
//! triangle test, so any difference is a traversal bug.
use brume::accel::{intersect_triangle, TriangleBvh};
use brume::math::Ray;
use glam::{Vec3, Vec3A};

use crate::common::rays::Rng;

fn random_triangles(rng: &mut Rng, n: usize) -> Vec<[Vec3A; 3]> {
    (0..n)
        .map(|_| {
            let c = rng.vec(-5.0, 5.0);
            let size = 0.05 + 0.6 * rng.next();
            [0, 1, 2].map(|_| Vec3A::from(c + rng.vec(-size, size)))
        })
        .collect()
}

fn brute_closest(tris: &[[Vec3A; 3]], ray: &Ray, t_max: f32) -> Option<(f32, u32)> {
    let mut best: Option<(f32, u32)> = None;
    for (k, t) in tris.iter().enumerate() {
        if let Some((t_hit, _, _)) = intersect_triangle(ray, t, 0.0, t_max) {
            if best.is_none_or_greater(t_hit) {
                best = Some((t_hit, k as u32));
            }
        }
    }
    best
}

trait Closer {
    fn is_none_or_greater(&self, t: f32) -> bool;
}
impl Closer for Option<(f32, u32)> {
    fn is_none_or_greater(&self, t: f32) -> bool {
        self.map_or(true, |(b, _)| t < b)
    }
}

#[test]
fn bvh_matches_brute_force_on_random_rays() {
    let mut rng = Rng(7);
    let tris = random_triangles(&mut rng, 2000);
    let bvh = TriangleBvh::build(tris.clone());
    bvh.validate().unwrap();
    let (mut hits, mut misses) = (0, 0);
    for k in 0..4000 {
        let o = rng.vec(-7.0, 7.0);
        // Half the rays aim at a triangle so hits are common; the rest go anywhere. Some have
        // unnormalised directions and finite t_max.
        let d = if k % 2 == 0 {
            let target = Vec3::from(tris[(rng.next() * 1999.0) as usize][0]);
            (target - o) * (0.5 + rng.next())
        } else {
            rng.vec(-1.0, 1.0)
        };
        if d.length() < 1e-3 {
            continue;
        }
        let t_max = if k % 3 == 0 {
            0.5 + 5.0 * rng.next()
        } else {
            f32::INFINITY
        };
        let ray = Ray::new(o, d);
        let expect = brute_closest(&tris, &ray, t_max);
        let got = bvh.closest_hit(&ray, 0.0, t_max);
        match (expect, got) {
            (None, None) => misses += 1,
            (Some((t, tri)), Some(h)) => {
                hits += 1;
                assert_eq!(h.t, t, "ray {k}: t differs");
                // Equal t on two triangles (shared points) may pick either one.
                if h.triangle != tri {
                    let other =
                        intersect_triangle(&ray, &tris[h.triangle as usize], 0.0, t_max).unwrap();
                    assert_eq!(other.0, t, "ray {k}: different triangle at a different t");
                }
            }
            (e, g) => panic!("ray {k}: brute force {e:?}, BVH {g:?}"),
        }
        assert_eq!(
            bvh.any_hit(&ray, 0.0, t_max),
            expect.is_some(),
            "ray {k}: any-hit disagrees"
        );
        let brute_all = tris
            .iter()
            .filter(|t| intersect_triangle(&ray, t, 0.0, t_max).is_some())
            .count();
        assert_eq!(
            bvh.all_hits(&ray, 0.0, t_max).len(),
            brute_all,
            "ray {k}: all-hits count differs"
        );
    }
    assert!(
        hits > 1000 && misses > 300,
        "test rays should both hit and miss ({hits} hits, {misses} misses)"
    );
}

/// Meshes of at most `SMALL_MESH_TRIANGLES` triangles are hit by testing all of them four or
/// eight at a time: the hit record must be the scalar brute force's exactly (t, triangle,
/// barycentrics; ties to the lowest index), at both widths, on both sides of the threshold and
/// for partial last batches, on random soups and on a closed box with rays from inside (the
/// usual boundary mesh).
#[test]
fn small_meshes_match_brute_force_exactly() {
    use brume::accel::SmallMeshLanes;
    small_meshes_match_brute_force(SmallMeshLanes::Four);
    if SmallMeshLanes::Eight.available() {
        small_meshes_match_brute_force(SmallMeshLanes::Eight);
    } else {
        // The renderer never takes the eight-lane test here, so there is nothing to check.
        eprintln!("eight-lane small-mesh test not run: this CPU has no AVX");
    }
}

fn small_meshes_match_brute_force(lanes: brume::accel::SmallMeshLanes) {
    use brume::accel::SMALL_MESH_TRIANGLES;
    let mut rng = Rng(11);
    let corner = |i: usize| {
        Vec3A::new(
            if i & 1 == 0 { -1.0 } else { 1.0 },
            if i & 2 == 0 { -1.0 } else { 1.0 },
            if i & 4 == 0 { -1.0 } else { 1.0 },
        )
    };
    // Two triangles per face of the cube, corners numbered by their bits (x 1, y 2, z 4).
    #[rustfmt::skip]
    let faces = [
        [0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
        [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3],
    ];
    let cube: Vec<[Vec3A; 3]> = faces.iter().map(|f| f.map(corner)).collect();
    let mut meshes = vec![cube];
    for n in [
        1,
        2,
        3,
        4,
        5,
        7,
        12,
        SMALL_MESH_TRIANGLES - 1,
        SMALL_MESH_TRIANGLES,
    ] {
        // Large triangles over the rays' box, so that most rays hit several.
        meshes.push(
            (0..n)
                .map(|_| [0, 1, 2].map(|_| Vec3A::from(rng.vec(-2.0, 2.0))))
                .collect(),
        );
    }
    let mut hits = 0;
    for tris in &meshes {
        let bvh = TriangleBvh::build_with(tris.clone(), lanes);
        assert_eq!(bvh.small_lanes(), Some(lanes), "{} triangles", tris.len());
        for k in 0..3000 {
            let o = rng.vec(-0.9, 0.9) * if k % 2 == 0 { 1.0 } else { 6.0 };
            let d = rng.vec(-1.0, 1.0);
            if d.length() < 1e-3 {
                continue;
            }
            let (t_min, t_max) = if k % 3 == 0 {
                (0.1 * rng.next(), 0.5 + 3.0 * rng.next())
            } else {
                (0.0, f32::INFINITY)
            };
            let ray = Ray::new(o, d);
            let mut expect: Option<(f32, u32, f32, f32)> = None;
            for (i, tri) in tris.iter().enumerate() {
                if let Some((t, b1, b2)) = intersect_triangle(&ray, tri, t_min, t_max) {
                    if expect.map_or(true, |(best, ..)| t < best) {
                        expect = Some((t, i as u32, b1, b2));
                    }
                }
            }
            let got = bvh
                .closest_hit(&ray, t_min, t_max)
                .map(|h| (h.t, h.triangle, h.b1, h.b2));
            let bits = |h: Option<(f32, u32, f32, f32)>| {
                h.map(|(t, i, b1, b2)| (t.to_bits(), i, b1.to_bits(), b2.to_bits()))
            };
            assert_eq!(
                bits(got),
                bits(expect),
                "{} triangles, {lanes:?} lanes, ray {k}: {got:?} against brute force {expect:?}",
                tris.len()
            );
            hits += got.is_some() as u32;
        }
    }
    assert!(hits > 6000, "test rays should hit often ({hits} hits)");
}

#[test]
fn t_min_skips_nearer_hits() {
    let tri = |z: f32| {
        [
            Vec3A::new(-1.0, -1.0, z),
            Vec3A::new(1.0, -1.0, z),
            Vec3A::new(0.0, 1.0, z),
        ]
    };
    let bvh = TriangleBvh::build(vec![tri(-1.0), tri(-2.0), tri(-3.0)]);
    let ray = Ray::new(Vec3::ZERO, Vec3::NEG_Z);
    assert_eq!(
        bvh.closest_hit(&ray, 0.0, f32::INFINITY).unwrap().triangle,
        0
    );
    assert_eq!(
        bvh.closest_hit(&ray, 1.5, f32::INFINITY).unwrap().triangle,
        1
    );
    assert!(bvh.closest_hit(&ray, 3.5, f32::INFINITY).is_none());
    assert!(!bvh.any_hit(&ray, 0.0, 0.5));
    let h = bvh.closest_hit(&ray, 0.0, 10.0).unwrap();
    // Barycentrics of the point (0, 0) in the triangle (-1,-1), (1,-1), (0,1).
    assert!(
        (h.b1 - 0.25).abs() < 1e-6 && (h.b2 - 0.5).abs() < 1e-6,
        "{h:?}"
    );
}

#[test]
fn empty_and_single_triangle_bvhs() {
    let empty = TriangleBvh::build(Vec::new());
    empty.validate().unwrap();
    let ray = Ray::new(Vec3::ZERO, Vec3::X);
    assert!(empty.closest_hit(&ray, 0.0, f32::INFINITY).is_none());
    assert!(!empty.any_hit(&ray, 0.0, f32::INFINITY));

    let one = TriangleBvh::build(vec![[
        Vec3A::new(2.0, -1.0, -1.0),
        Vec3A::new(2.0, 1.0, -1.0),
        Vec3A::new(2.0, 0.0, 1.0),
    ]]);
    one.validate().unwrap();
    assert_eq!(one.closest_hit(&ray, 0.0, f32::INFINITY).unwrap().t, 2.0);
    // Non-finite rays miss instead of panicking.
    assert!(one
        .closest_hit(&Ray::new(Vec3::NAN, Vec3::X), 0.0, 1.0)
        .is_none());
}

#[test]
fn rays_at_a_flat_grids_edges_and_corners_hit_what_brute_force_hits() {
    // A flat axis-aligned grid (its nodes' boxes have no thickness) and rays aimed at its
    // vertices and edge midpoints, where a box test without slack loses hits to rounding.
    // Several triangles are hit at the same t there, so only t and hit-or-miss must agree.
    let mut tris: Vec<[Vec3A; 3]> = Vec::new();
    for i in 0..16 {
        for j in 0..16 {
            let p = |a: f32, b: f32| Vec3A::new(i as f32 + a - 8.0, j as f32 + b - 8.0, 0.0);
            tris.push([p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0)]);
            tris.push([p(0.0, 0.0), p(1.0, 1.0), p(0.0, 1.0)]);
        }
    }
    let bvh = TriangleBvh::build(tris.clone());
    assert!(
        bvh.small_lanes().is_none(),
        "the BVH must answer, not brute force"
    );
    let mut rng = Rng(13);
    let (rays, mut differ, mut occlusion_differs) = (20_000, 0, 0);
    for _ in 0..rays {
        let o = rng.vec(0.0, 1.0) * Vec3::new(16.0, 16.0, 3.5) + Vec3::new(-8.0, -8.0, 0.5);
        let half = |x: f32| (2.0 * x).round() / 2.0;
        let target = Vec3::new(
            half(o.x + rng.next() - 0.5),
            half(o.y + rng.next() - 0.5),
            0.0,
        );
        let ray = Ray::new(o, target - o);
        let brute = brute_closest(&tris, &ray, f32::INFINITY).map(|h| h.0);
        let got = bvh.closest_hit(&ray, 0.0, f32::INFINITY).map(|h| h.t);
        if got != brute {
            differ += 1;
            if differ <= 5 {
                eprintln!(
                    "ray {:?} -> {:?}: BVH t {got:?}, brute force t {brute:?}",
                    ray.o, ray.d
                );
            }
        }
        occlusion_differs += (bvh.any_hit(&ray, 0.0, 2.0) != brute.is_some()) as usize;
    }
    assert_eq!(
        differ, 0,
        "{differ} of {rays} closest hits differ from brute force"
    );
    assert_eq!(
        occlusion_differs, 0,
        "{occlusion_differs} of {rays} occlusion answers differ"
    );
}
