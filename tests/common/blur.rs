//! Scenes for velocity motion blur: a density grid and a velocity grid in one file, and a
//! glTF placing it under a camera, a point light and a sky, with a shutter.
use std::path::{Path, PathBuf};

use brume_ffi::{write_float_grids, GridClass, GridSpec};
use serde_json::{json, Value};

/// Voxel size of the blur fixtures.
pub const VOXEL: f64 = 0.0625;

pub fn dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("motion_blur")
        .join(name);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Writes `path` with the float grid `density` (voxels of size [`VOXEL`], index origin at
/// world `origin`) and the Vec3 grid `vel`: `background` everywhere but at `vectors`.
pub fn write_medium(
    path: &Path,
    density: Vec<([i32; 3], f32)>,
    origin: [f64; 3],
    background: [f32; 3],
    vectors: Vec<([i32; 3], [f32; 3])>,
    class: GridClass,
) {
    let mut d = GridSpec::fog("density", VOXEL, origin);
    d.voxels = density;
    let mut v = GridSpec::vec3("vel", class, VOXEL, origin);
    let vv = v.vectors.as_mut().unwrap();
    vv.background = background;
    vv.voxels = vectors;
    write_float_grids(path, &[d, v]).unwrap();
}

/// A scene with the medium of `uri` at `translation`: `extra` members are added to its
/// `BRUME_medium_vdb`, `render` is the `BRUME_render` object.
pub fn scene(uri: &str, translation: [f64; 3], extra: Value, render: Value) -> Value {
    let mut medium = json!({"uri": uri, "densityScale": 6.0, "color": [0.8, 0.8, 0.8],
                            "absorptionColor": [0.3, 0.3, 0.3], "anisotropy": 0.3});
    for (k, v) in extra.as_object().unwrap() {
        medium[k] = v.clone();
    }
    json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2]}],
        "nodes": [
            {"camera": 0, "translation": [0.0, 0.0, 2.2]},
            {"translation": [1.5, 2.0, 1.0], "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"translation": translation, "extensions": {"BRUME_medium_vdb": medium}}
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.9, "znear": 0.01}}],
        "extensions": {
            "KHR_lights_punctual": {"lights": [{"type": "point", "color": [1, 1, 1], "intensity": 20.0}]},
            "BRUME_environment": {"color": [0.4, 0.5, 0.7], "strength": 1.0},
            "BRUME_render": render
        },
        "extensionsUsed": ["BRUME_medium_vdb", "KHR_lights_punctual", "BRUME_environment", "BRUME_render"],
    })
}

/// Writes `doc` to `d/name` and loads it.
pub fn load(d: &Path, name: &str, doc: &Value) -> brume::scene::Scene {
    let p = d.join(name);
    super::write_whole(&p, doc.to_string().as_bytes());
    brume::scene::load(&p).unwrap_or_else(|e| panic!("{e}"))
}

/// Adds to `doc` a LINEAR animation of node `node`'s translation from `from` at time 0 to
/// `to` at `t1` seconds, its keys in the buffer file `d/bin`.
pub fn animate_translation(
    doc: &mut Value,
    d: &Path,
    bin: &str,
    node: usize,
    from: [f32; 3],
    to: [f32; 3],
    t1: f32,
) {
    let mut bytes = Vec::new();
    for x in [0.0, t1].into_iter().chain(from).chain(to) {
        bytes.extend_from_slice(&f32::to_le_bytes(x));
    }
    super::write_whole(&d.join(bin), &bytes);
    doc["buffers"] = json!([{"uri": bin, "byteLength": bytes.len()}]);
    doc["bufferViews"] = json!([
        {"buffer": 0, "byteOffset": 0, "byteLength": 8},
        {"buffer": 0, "byteOffset": 8, "byteLength": 24}
    ]);
    doc["accessors"] = json!([
        {"bufferView": 0, "componentType": 5126, "count": 2, "type": "SCALAR", "min": [0.0], "max": [t1]},
        {"bufferView": 1, "componentType": 5126, "count": 2, "type": "VEC3"}
    ]);
    doc["animations"] = json!([{
        "channels": [{"sampler": 0, "target": {"node": node, "path": "translation"}}],
        "samplers": [{"input": 0, "output": 1, "interpolation": "LINEAR"}]
    }]);
}
