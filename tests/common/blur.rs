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
    animate(doc, d, bin, node, &[("translation", &from, &to)], t1);
}

/// Appends `value` to the array `doc[key]` (made where absent); returns its index.
fn push(doc: &mut Value, key: &str, value: Value) -> usize {
    if doc[key].is_null() {
        doc[key] = json!([]);
    }
    let a = doc[key].as_array_mut().unwrap();
    a.push(value);
    a.len() - 1
}

/// Adds to `doc` an animation of node `node` with one LINEAR channel per `(path, from, to)`:
/// `from` at time 0 to `to` at `t1` seconds (a rotation's quaternions slerped, as glTF
/// defines), its keys in the buffer file `d/bin`.
pub fn animate(
    doc: &mut Value,
    d: &Path,
    bin: &str,
    node: usize,
    channels: &[(&str, &[f32], &[f32])],
    t1: f32,
) {
    let mut bytes: Vec<u8> = [0.0f32, t1].iter().flat_map(|x| x.to_le_bytes()).collect();
    let mut spans = Vec::new();
    for (_, from, to) in channels {
        let start = bytes.len();
        bytes.extend(from.iter().chain(*to).flat_map(|x| x.to_le_bytes()));
        spans.push((start, bytes.len() - start, from.len()));
    }
    super::write_whole(&d.join(bin), &bytes);
    let buffer = push(
        doc,
        "buffers",
        json!({"uri": bin, "byteLength": bytes.len()}),
    );
    let view = push(
        doc,
        "bufferViews",
        json!({"buffer": buffer, "byteOffset": 0, "byteLength": 8}),
    );
    let input = push(
        doc,
        "accessors",
        json!({"bufferView": view, "componentType": 5126, "count": 2, "type": "SCALAR",
               "min": [0.0], "max": [t1]}),
    );
    let (mut samplers, mut targets) = (Vec::new(), Vec::new());
    for (k, ((path, _, _), (start, len, width))) in channels.iter().zip(spans).enumerate() {
        let view = push(
            doc,
            "bufferViews",
            json!({"buffer": buffer, "byteOffset": start, "byteLength": len}),
        );
        let kind = if width == 4 { "VEC4" } else { "VEC3" };
        let output = push(
            doc,
            "accessors",
            json!({"bufferView": view, "componentType": 5126, "count": 2, "type": kind}),
        );
        samplers.push(json!({"input": input, "output": output, "interpolation": "LINEAR"}));
        targets.push(json!({"sampler": k, "target": {"node": node, "path": path}}));
    }
    push(
        doc,
        "animations",
        json!({"channels": targets, "samplers": samplers}),
    );
}

/// Voxels across the uniform-velocity and camera fixtures' blob.
pub const N: i32 = 16;

/// The blob's index origin: centred on the world origin.
pub fn origin() -> [f64; 3] {
    [-(N as f64) * VOXEL * 0.5 + 0.5 * VOXEL; 3]
}

/// Uniform velocity (world units per second), scale 6 at 24 fps over a shutter of one frame
/// centred on the frame: the blob moves by `dt * 6 * v / 24` at time offset `dt`, 0.6 units
/// (9.6 voxels) across the shutter.
pub const V: [f32; 3] = [2.4, 0.6, 0.0];
pub const SCALE: f64 = 6.0;

/// Voxels across the vortex's blob.
pub const NV: i32 = 48;

/// A vortex about the blob's vertical axis over the blob's box, as a staggered grid
/// (Mantaflow's layout), turning the blob's rim (24 voxels out) by 10 voxels over the shutter.
pub fn vortex() -> Vec<([i32; 3], [f32; 3])> {
    // Rim speed 10 voxels per frame, velocities per frame (`velocityUnit` "frame") over a
    // one-frame shutter.
    let omega = 10.0 / (NV as f64 * 0.5);
    let c = (NV as f64 - 1.0) * 0.5;
    let mut v = Vec::new();
    for i in 0..NV {
        for j in 0..NV {
            for k in 0..NV {
                // Component a of a staggered voxel sits on its lower face along a.
                let at = |a: usize| {
                    let mut p = [i as f64, j as f64, k as f64];
                    p[a] -= 0.5;
                    p
                };
                let (px, py) = (at(0), at(1));
                v.push((
                    [i, j, k],
                    [
                        (-omega * (px[2] - c) * VOXEL) as f32,
                        0.0,
                        (omega * (py[0] - c) * VOXEL) as f32,
                    ],
                ));
            }
        }
    }
    v
}

/// The uniform-velocity fixture under `dir(name)`: the blob of [`N`] voxels moving at [`V`]
/// (velocity scale [`SCALE`], 24 fps, a one-frame shutter centred on the frame), and the same
/// file loaded with the shutter closed (the still frame).
pub fn uniform_velocity_scenes(name: &str) -> (brume::scene::Scene, brume::scene::Scene) {
    let d = dir(name);
    write_medium(
        &d.join("m.vdb"),
        super::stress::blob_voxels(N),
        origin(),
        V,
        Vec::new(),
        GridClass::Unknown,
    );
    let extra = json!({"velocityGrid": "vel", "velocityScale": SCALE});
    let shutter = json!({"fps": 24, "shutter": {"open": -0.5, "close": 0.5}});
    let blurred = load(
        &d,
        "blurred.gltf",
        &scene("m.vdb", [0.0; 3], extra, shutter),
    );
    (blurred, closed(&d.join("blurred.gltf")))
}

/// The vortex fixture under `dir(name)`: the blob of [`NV`] voxels turned by [`vortex`]
/// (a staggered grid, velocities per frame, a one-frame shutter), and the still frame.
pub fn vortex_scenes(name: &str) -> (brume::scene::Scene, brume::scene::Scene) {
    let d = dir(name);
    write_medium(
        &d.join("vortex.vdb"),
        super::stress::blob_voxels(NV),
        [-(NV as f64) * VOXEL * 0.5 + 0.5 * VOXEL; 3],
        [0.0; 3],
        vortex(),
        GridClass::Staggered,
    );
    let extra = json!({"velocityGrid": "vel", "velocityUnit": "frame"});
    let shutter = json!({"shutter": {"open": -0.5, "close": 0.5}});
    let doc = scene("vortex.vdb", [0.0; 3], extra, shutter);
    let blurred = load(&d, "vortex.gltf", &doc);
    (blurred, closed(&d.join("vortex.gltf")))
}

/// The still blob of [`N`] voxels (`d/m.vdb`, written once) at the origin in [`scene`], at
/// frame 1 of 24 fps under a one-frame shutter centred on it.
fn still_blob_shot(d: &Path) -> Value {
    if !d.join("m.vdb").exists() {
        write_medium(
            &d.join("m.vdb"),
            super::stress::blob_voxels(N),
            origin(),
            [0.0; 3],
            Vec::new(),
            GridClass::Unknown,
        );
    }
    let render_obj = json!({"fps": 24, "frame": 1, "shutter": {"open": -0.5, "close": 0.5}});
    scene("m.vdb", [0.0; 3], json!({}), render_obj)
}

/// The blob still at the origin, with node `node` (0 the camera, 2 the medium) animated
/// linearly: at `at_frame` on frame 1 (time 1/24 s at 24 fps), moving by `per_frame` a frame,
/// under a one-frame shutter. Returns the fixture's folder and the scene.
pub fn animated(
    name: &str,
    node: usize,
    at_frame: [f32; 3],
    per_frame: [f32; 3],
    edit: &dyn Fn(&mut serde_json::Value),
) -> (std::path::PathBuf, brume::scene::Scene) {
    let d = dir(name);
    let mut doc = still_blob_shot(&d);
    edit(&mut doc);
    let key = |k: f32| [0, 1, 2].map(|a| at_frame[a] + k * per_frame[a]);
    animate_translation(
        &mut doc,
        &d,
        "keys.bin",
        node,
        key(-1.0),
        key(1.0),
        2.0 / 24.0,
    );
    let moving = load(&d, "moving.gltf", &doc);
    (d, moving)
}

/// The moving-camera fixture under `dir(name)`: the still blob of [`N`] voxels seen from a
/// camera sliding 0.8 units a frame along x (frame 1 at 24 fps, a one-frame shutter), and the
/// still frame.
pub fn moving_camera_scenes(name: &str) -> (brume::scene::Scene, brume::scene::Scene) {
    let (d, moving) = animated(name, 0, [0.0, 0.0, 2.2], [0.8, 0.0, 0.0], &|_| {});
    (moving, closed(&d.join("moving.gltf")))
}

/// The scene at `path` loaded with the shutter closed: the frame's instant.
pub fn closed(path: &Path) -> brume::scene::Scene {
    brume::scene::load_with(
        path,
        &brume::scene::LoadOptions {
            shutter: Some(brume::scene::Shutter::CLOSED),
            ..Default::default()
        },
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

/// Where the moving-mesh fixture's parent node is at time offset `dt` (frames) from frame 1:
/// translation and the angle (radians) of its turn about y.
pub fn mesh_pose(dt: f32) -> ([f32; 3], f32) {
    ([-0.1 + 0.5 * dt, 0.0, 0.7], 0.8 * dt)
}

fn turn(angle: f32) -> [f32; 4] {
    [0.0, (0.5 * angle).sin(), 0.0, (0.5 * angle).cos()]
}

/// The still blob behind a parent node carrying two boxes, seen under a one-frame shutter at
/// frame 1 (24 fps): an opaque diffuse box that glows (a moving emitter) and a box of
/// scattering homogeneous medium behind null interfaces. `dt` `Some`: the parent still at [`mesh_pose`]`(dt)`; `None`: the parent
/// animated through [`mesh_pose`] (LINEAR translation and rotation keys at frames 0 and 2).
pub fn moving_meshes_scene(d: &Path, dt: Option<f32>) -> brume::scene::Scene {
    let mut doc = still_blob_shot(d);
    let (t, a) = mesh_pose(dt.unwrap_or(0.0));
    doc["scenes"][0]["nodes"] = json!([0, 1, 2, 3]);
    let nodes = doc["nodes"].as_array_mut().unwrap();
    nodes.push(json!({"translation": t, "rotation": turn(a), "children": [4, 5]}));
    nodes.push(json!({"mesh": 0, "translation": [-0.2, 0.0, 0.0]}));
    nodes.push(json!({"mesh": 1, "translation": [0.2, 0.0, 0.0]}));
    let (lo, hi) = ([-0.13f32; 3], [0.13f32; 3]);
    for k in 0..2 {
        let b = super::boxes::box_mesh(d, &format!("box{k}.bin"), lo, hi);
        let off = b["pos_offset"].as_u64().unwrap();
        let buffer = push(
            &mut doc,
            "buffers",
            json!({"uri": b["uri"], "byteLength": b["byteLength"]}),
        );
        let iv = push(
            &mut doc,
            "bufferViews",
            json!({"buffer": buffer, "byteOffset": 0, "byteLength": 72}),
        );
        let pv = push(
            &mut doc,
            "bufferViews",
            json!({"buffer": buffer, "byteOffset": off, "byteLength": 96}),
        );
        let ia = push(
            &mut doc,
            "accessors",
            json!({"bufferView": iv, "componentType": 5123, "count": 36, "type": "SCALAR"}),
        );
        let pa = push(
            &mut doc,
            "accessors",
            json!({"bufferView": pv, "componentType": 5126, "count": 8, "type": "VEC3",
                   "min": lo, "max": hi}),
        );
        push(
            &mut doc,
            "meshes",
            json!({"primitives": [{"attributes": {"POSITION": pa}, "indices": ia, "material": k}]}),
        );
    }
    doc["materials"] = json!([
        {"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.4, 0.2, 1], "metallicFactor": 0,
                                  "roughnessFactor": 0.7},
         "emissiveFactor": [1.0, 0.6, 0.2],
         "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 2.0}}},
        {"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0},
         "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
                        "KHR_materials_ior": {"ior": 1.0},
                        "KHR_materials_volume": {"thicknessFactor": 1.0, "attenuationDistance": 0.25,
                                                 "attenuationColor": [0.37, 0.37, 0.37]},
                        "BRUME_materials_volume_scattering": {"albedo": [0.9, 0.9, 0.9],
                                                              "anisotropy": 0.3}}}
    ]);
    for e in [
        "KHR_materials_transmission",
        "KHR_materials_ior",
        "KHR_materials_volume",
        "BRUME_materials_volume_scattering",
        "KHR_materials_emissive_strength",
    ] {
        push(&mut doc, "extensionsUsed", json!(e));
    }
    let name = match dt {
        Some(dt) => format!("still_{dt}.gltf"),
        None => {
            let (t0, a0) = mesh_pose(-1.0);
            let (t1, a1) = mesh_pose(1.0);
            animate(
                &mut doc,
                d,
                "keys.bin",
                3,
                &[
                    ("translation", &t0, &t1),
                    ("rotation", &turn(a0), &turn(a1)),
                ],
                2.0 / 24.0,
            );
            "moving.gltf".into()
        }
    };
    load(d, &name, &doc)
}
