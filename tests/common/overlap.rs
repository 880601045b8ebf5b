//! The overlapping-media scenes of `tests/physics/media_overlap.rs` and `tests/gpu/media_overlap.rs`:
//! two blobs of `common::stress::blob_voxels` overlapping over about half their width, and
//! one grid holding their voxel-wise sum.
use super::stress::blob_voxels;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use brume::render::{Absorption, Estimator, MajorantMode, RenderSettings};
use serde_json::{json, Value};

pub const VOXEL: f64 = 0.0625;
pub const N: i32 = 16;
/// Voxel shift of the second blob: they overlap over about half their width.
pub const SHIFT: [i32; 3] = [7, 4, 2];

pub fn dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("media_overlap")
        .join(name);
    std::fs::create_dir_all(&d).unwrap();
    d
}

pub fn write_grid(path: &Path, voxels: Vec<([i32; 3], f32)>) {
    let c = N as f64 * VOXEL * 0.5;
    let mut g = brume_ffi::GridSpec::fog("density", VOXEL, [-c + 0.5 * VOXEL; 3]);
    g.voxels = voxels;
    brume_ffi::write_float_grids(path, &[g]).unwrap();
}

pub fn shifted() -> Vec<([i32; 3], f32)> {
    blob_voxels(N)
        .into_iter()
        .map(|(p, d)| ([p[0] + SHIFT[0], p[1] + SHIFT[1], p[2] + SHIFT[2]], 0.7 * d))
        .collect()
}

pub fn summed() -> Vec<([i32; 3], f32)> {
    let mut sum: BTreeMap<[i32; 3], f32> = BTreeMap::new();
    for (p, d) in blob_voxels(N).into_iter().chain(shifted()) {
        *sum.entry(p).or_default() += d;
    }
    sum.into_iter().collect()
}

pub fn medium(uri: &str, chromatic: bool) -> Value {
    let mut m = json!({"uri": uri, "densityScale": 4.0, "color": [0.8, 0.8, 0.8],
                       "absorptionColor": [0.3, 0.3, 0.3], "anisotropy": 0.4});
    if chromatic {
        m["color"] = json!([0.3, 0.6, 0.9]);
        m["absorptionColor"] = json!([0.8, 0.4, 0.1]);
    }
    m
}

/// A camera on +Z looking at the media, a point light and a dim sky.
pub fn scene(media: Vec<Value>) -> Value {
    let mut nodes = vec![
        json!({"camera": 0, "translation": [0.2, 0.15, 1.7]}),
        json!({"translation": [1.5, 2.0, 1.0], "extensions": {"KHR_lights_punctual": {"light": 0}}}),
    ];
    for m in media {
        nodes.push(json!({"extensions": {"BRUME_medium_vdb": m}}));
    }
    json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.01}}],
        "extensions": {
            "KHR_lights_punctual": {"lights": [{"type": "point", "color": [1, 1, 1], "intensity": 20.0}]},
            "BRUME_environment": {"color": [0.4, 0.5, 0.7], "strength": 1.0}
        },
        "extensionsUsed": ["BRUME_medium_vdb", "KHR_lights_punctual", "BRUME_environment"],
    })
}

pub fn write_scene(d: &Path, name: &str, doc: &Value) -> PathBuf {
    let p = d.join(name);
    super::write_whole(&p, doc.to_string().as_bytes());
    p
}

/// The two-media scene and the one-grid scene holding their sum.
pub fn pair(chromatic: bool) -> (brume::scene::Scene, brume::scene::Scene) {
    let d = dir(if chromatic { "pair_rgb" } else { "pair" });
    write_grid(&d.join("a.vdb"), blob_voxels(N));
    write_grid(&d.join("b.vdb"), shifted());
    write_grid(&d.join("sum.vdb"), summed());
    let two = write_scene(
        &d,
        "two.gltf",
        &scene(vec![medium("a.vdb", chromatic), medium("b.vdb", chromatic)]),
    );
    let one = write_scene(&d, "one.gltf", &scene(vec![medium("sum.vdb", chromatic)]));
    let load = |p: &Path| brume::scene::load(p).unwrap_or_else(|e| panic!("{e}"));
    (load(&two), load(&one))
}

/// The settings of the two-media comparisons: 16 x 16 pixels, 256 spp.
pub fn overlap_settings(estimator: Estimator, majorant: MajorantMode, seed: u32) -> RenderSettings {
    RenderSettings {
        width: 16,
        height: 16,
        spp: 256,
        estimator,
        majorant,
        seed,
        ..RenderSettings::default()
    }
}

/// The configurations the two media are compared with their sum in (on the CPU and the GPU):
/// every estimator in the global and adaptive modes (weighted decomposition with the global
/// bound at 1024 spp on 4 x 4 blocks: its signed weights in empty space are heavy-tailed),
/// decomposition with per-leaf majorants and absorption events, weighted delta with
/// `b = 0.6` (blocks), and forced spectral tracking. Calls `check(settings, block, alpha,
/// label)` for each, `alpha` Sidak-split over them.
pub fn for_each_overlap_config(mut check: impl FnMut(&RenderSettings, usize, f64, &str)) {
    let modes = [MajorantMode::Global, MajorantMode::Adaptive];
    let n = Estimator::ALL.len() * modes.len() + 3;
    let alpha = 1e-3 / n as f64;
    let mut seed = 1;
    for e in Estimator::ALL {
        for m in modes {
            let mut s = overlap_settings(e, m, seed);
            seed += 1;
            let heavy = e == Estimator::WeightedDecomposition && m == MajorantMode::Global;
            if heavy {
                s.spp = 1024;
            }
            check(&s, if heavy { 4 } else { 1 }, alpha, &format!("{e} {m:?}"));
        }
    }
    let mut s = overlap_settings(Estimator::Decomposition, MajorantMode::Leaf, seed);
    s.absorption = Absorption::Event;
    check(&s, 1, alpha, "decomposition leaf, absorption events");
    let s = RenderSettings {
        b: 0.6,
        ..overlap_settings(Estimator::WeightedDelta, MajorantMode::Adaptive, seed + 1)
    };
    check(&s, 4, alpha, "weighted delta b 0.6");
    let s = RenderSettings {
        force_spectral: true,
        ..overlap_settings(Estimator::Delta, MajorantMode::Global, seed + 2)
    };
    check(&s, 1, alpha, "spectral, global");
}

/// The optical depth of VDB medium `m` along the pencil of `common::boxes::boxes_scene` (from
/// `(0, 0, 3)` along -Z), integrated from its voxels (`common::stress::optical_depth`).
pub fn pencil_depth(m: &brume::render::media::VdbMedium) -> f64 {
    use brume::math::Ray;
    let ray_w = Ray::new(
        glam::Vec3::new(0.0, 0.0, 3.0),
        glam::Vec3::new(0.0, 0.0, -1.0),
    );
    let ray_i = Ray::new(
        m.density.index_from_world.transform_point3(ray_w.o),
        m.density.index_from_world.transform_vector3(ray_w.d),
    );
    super::stress::optical_depth(&m.density.grid.grid, &ray_i, 0.0, 6.0, 3.0)
}
