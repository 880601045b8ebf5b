//! `--accel auto` picks the accelerator by the scene's static triangle count: the BVH below
//! `EMBREE_FROM_TRIANGLES`, Embree from it on, and the BVH with the reason kept where Embree
//! cannot be built; an explicit `--accel embree` that cannot be built is an error.
use std::path::PathBuf;

use brume::accel::embree::EmbreeGeometry;
use brume::accel::{Accel, EMBREE_FROM_TRIANGLES};
use brume::scene::Scene;
use serde_json::json;

/// Writes (as `name`, distinct per test) and loads a scene of `n` small disjoint triangles in
/// a row, under a camera.
fn scene_of(name: &str, n: usize) -> Scene {
    let dir = crate::common::scratch::dir(&format!("accel_auto_{name}"));
    let bin = format!("{name}.bin");
    let mut bytes = Vec::with_capacity(36 * n + 12 * n);
    for k in 0..n {
        let x = k as f32 * 0.01;
        for p in [[x, 0.0, 0.0], [x + 0.005, 0.0, 0.0], [x, 0.005, 0.0]] {
            bytes.extend(p.iter().flat_map(|c: &f32| c.to_le_bytes()));
        }
    }
    let positions = bytes.len();
    bytes.extend((0..3 * n as u32).flat_map(|i| i.to_le_bytes()));
    crate::common::write_whole(&dir.join(&bin), &bytes);
    let x_max = (n - 1) as f32 * 0.01 + 0.005;
    let doc = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"camera": 0, "translation": [0.0, 0.0, 5.0]}, {"mesh": 0}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.9, "znear": 0.01}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "buffers": [{"uri": bin, "byteLength": bytes.len()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": positions},
            {"buffer": 0, "byteOffset": positions, "byteLength": 12 * n}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3 * n, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [x_max, 0.005, 0.0]},
            {"bufferView": 1, "componentType": 5125, "count": 3 * n, "type": "SCALAR"}
        ]
    });
    let path: PathBuf = dir.join(format!("{name}.gltf"));
    crate::common::write_whole(&path, doc.to_string().as_bytes());
    let scene = brume::scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.triangle_count(), n);
    scene
}

#[test]
fn auto_takes_the_bvh_below_the_threshold_and_embree_from_it() {
    let mut below = scene_of("below", EMBREE_FROM_TRIANGLES - 1);
    let used = below.use_accel(Accel::Auto).unwrap();
    assert_eq!((used.accel, used.fallback), (Accel::Bvh, None));
    assert!(below.embree.is_none());

    let mut at = scene_of("at", EMBREE_FROM_TRIANGLES);
    let used = at.use_accel(Accel::Auto).unwrap();
    assert_eq!((used.accel, used.fallback), (Accel::Embree, None));
    assert!(at.embree.is_some());
    // Asked for by name, each is used whatever the size.
    assert_eq!(at.use_accel(Accel::Bvh).unwrap().accel, Accel::Bvh);
    assert!(at.embree.is_none());
    assert_eq!(below.use_accel(Accel::Embree).unwrap().accel, Accel::Embree);
}

#[test]
fn auto_falls_back_to_the_bvh_where_embree_fails_and_embree_by_name_is_an_error() {
    let mut scene = scene_of("failing", EMBREE_FROM_TRIANGLES);
    let fail = |_: EmbreeGeometry<'_>| Err("no Embree device".to_string());
    let used = scene.use_accel_with(Accel::Auto, fail).unwrap();
    assert_eq!(used.accel, Accel::Bvh);
    assert_eq!(used.fallback.as_deref(), Some("no Embree device"));
    assert!(scene.embree.is_none());
    let err = scene.use_accel_with(Accel::Embree, fail).unwrap_err();
    assert!(err.to_string().contains("no Embree device"), "{err}");
}

#[test]
fn auto_resolves_by_triangle_count() {
    let n = EMBREE_FROM_TRIANGLES;
    assert_eq!(Accel::Auto.for_triangles(0), Accel::Bvh);
    assert_eq!(Accel::Auto.for_triangles(n - 1), Accel::Bvh);
    assert_eq!(Accel::Auto.for_triangles(n), Accel::Embree);
    assert_eq!(Accel::Bvh.for_triangles(n), Accel::Bvh);
    assert_eq!(Accel::Embree.for_triangles(1), Accel::Embree);
    assert_eq!(Accel::default(), Accel::Auto);
}
