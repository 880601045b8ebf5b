//! Scenes of nested closed boxes of homogeneous media (and optionally a VDB grid inside),
//! written as glTF with their buffers: the nested-media tests (`tests/physics/media_overlap.rs`, and
//! the GPU's medium stack in `tests/gpu/render.rs`).
use std::path::{Path, PathBuf};

use serde_json::{json, Value};

/// A closed box `[lo, hi]` (12 triangles, counter-clockwise from outside) as a glTF buffer file.
pub fn box_mesh(d: &Path, name: &str, lo: [f32; 3], hi: [f32; 3]) -> Value {
    let p: Vec<[f32; 3]> = (0..8)
        .map(|k| {
            [
                if k & 1 == 0 { lo[0] } else { hi[0] },
                if k & 2 == 0 { lo[1] } else { hi[1] },
                if k & 4 == 0 { lo[2] } else { hi[2] },
            ]
        })
        .collect();
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let mut idx: Vec<u16> = Vec::new();
    for [a, b, c, e] in quads {
        idx.extend([a, b, c, a, c, e]);
    }
    let mut bytes: Vec<u8> = idx.iter().flat_map(|i| i.to_le_bytes()).collect();
    let pos_offset = bytes.len();
    bytes.extend(p.iter().flatten().flat_map(|f| f.to_le_bytes()));
    super::write_whole(&d.join(name), &bytes);
    json!({"uri": name, "byteLength": bytes.len(), "pos_offset": pos_offset, "lo": lo, "hi": hi})
}

/// A scene seen from `(0, 0, 3)` along -Z (vertical field of view `yfov`) under a white sky:
/// nested boxes `(lo, hi, sigma_t, albedo)` (outermost first) of homogeneous media behind null
/// interfaces (HG g 0.3 where they scatter), and optionally the absorbing blob grid `grid.vdb`
/// inside them.
pub fn boxes_scene(
    d: &Path,
    boxes: &[([f32; 3], [f32; 3], f32, f32)],
    vdb: bool,
    yfov: f32,
) -> PathBuf {
    let mut nodes = vec![json!({"camera": 0, "translation": [0.0, 0.0, 3.0]})];
    let (mut buffers, mut views, mut accessors, mut meshes, mut materials) =
        (vec![], vec![], vec![], vec![], vec![]);
    for (k, &(lo, hi, sigma, albedo)) in boxes.iter().enumerate() {
        let b = box_mesh(d, &format!("box{k}.bin"), lo, hi);
        let off = b["pos_offset"].as_u64().unwrap();
        buffers.push(json!({"uri": b["uri"], "byteLength": b["byteLength"]}));
        views.push(json!({"buffer": k, "byteOffset": 0, "byteLength": 72}));
        views.push(json!({"buffer": k, "byteOffset": off, "byteLength": 96}));
        accessors.push(
            json!({"bufferView": 2 * k, "componentType": 5123, "count": 36, "type": "SCALAR"}),
        );
        accessors.push(json!({"bufferView": 2 * k + 1, "componentType": 5126, "count": 8, "type": "VEC3", "min": lo, "max": hi}));
        meshes.push(json!({"primitives": [{"attributes": {"POSITION": 2 * k + 1}, "indices": 2 * k, "material": k}]}));
        // Attenuation colour exp(-sigma) at distance 1: sigma_t = sigma, split by the albedo.
        let att = (-sigma).exp();
        materials.push(json!({"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0},
            "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
                           "KHR_materials_ior": {"ior": 1.0},
                           "KHR_materials_volume": {"thicknessFactor": 1.0, "attenuationDistance": 1.0,
                                                    "attenuationColor": [att, att, att]},
                           "BRUME_materials_volume_scattering": {"albedo": [albedo, albedo, albedo],
                                                                 "anisotropy": 0.3}}}));
        nodes.push(json!({"mesh": k}));
    }
    let mut used = vec![
        "KHR_materials_transmission",
        "KHR_materials_ior",
        "KHR_materials_volume",
        "BRUME_environment",
    ];
    if vdb {
        nodes.push(
            json!({"extensions": {"BRUME_medium_vdb": {"uri": "grid.vdb", "densityScale": 3.0,
            "color": [0.0, 0.0, 0.0], "absorptionColor": [0.0, 0.0, 0.0]}}}),
        );
        used.push("BRUME_medium_vdb");
    }
    let doc = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "cameras": [{"type": "perspective", "perspective": {"yfov": yfov, "znear": 0.01}}],
        "buffers": buffers, "bufferViews": views, "accessors": accessors,
        "meshes": meshes, "materials": materials,
        "extensions": {"BRUME_environment": {"color": [1, 1, 1], "strength": 1.0}},
        "extensionsUsed": used,
    });
    let p = d.join("scene.gltf");
    super::write_whole(&p, doc.to_string().as_bytes());
    p
}

/// A homogeneous slab from `lo` to `hi` (`boxes_scene`: sigma_t 1.5, albedo 0.8, HG g 0.3) in
/// the dark, lit by a point light at `light`, written to the scratch folder `name`.
pub fn lit_slab_scene(
    name: &str,
    lo: [f32; 3],
    hi: [f32; 3],
    light: [f32; 3],
) -> brume::scene::Scene {
    let d = super::scratch::dir(name);
    let path = boxes_scene(&d, &[(lo, hi, 1.5, 0.8)], false, 0.3);
    let mut doc: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    doc["extensions"] = json!({"KHR_lights_punctual": {"lights": [
        {"type": "point", "color": [1.0, 0.8, 0.6], "intensity": 3.0}]}});
    doc["extensionsUsed"] = json!([
        "KHR_materials_transmission",
        "KHR_materials_ior",
        "KHR_materials_volume",
        "KHR_lights_punctual"
    ]);
    let n = doc["nodes"].as_array().unwrap().len();
    doc["nodes"]
        .as_array_mut()
        .unwrap()
        .push(json!({"translation": light, "extensions": {"KHR_lights_punctual": {"light": 0}}}));
    doc["scenes"][0]["nodes"]
        .as_array_mut()
        .unwrap()
        .push(json!(n));
    let p = super::overlap::write_scene(&d, "lit_slab.gltf", &doc);
    brume::scene::load(&p).unwrap_or_else(|e| panic!("{e}"))
}
