//! Small glTF files written by the tests: each feature against the value the glTF spec (or
//! Brume's extension spec) gives, and each bad input against a clear error naming the file and
//! the JSON location. Nothing here may panic.
use crate::common::scratch;

mod animations;
mod bad_inputs;
mod instancing;

use std::path::{Path, PathBuf};

use brume::scene::{self, lights, CameraSource, LoadOptions, Scene, SceneError};
use brume::volume::phase::HenyeyGreenstein;
use brume::volume::phases::{Draine, Phase};
use glam::{Mat4, Quat, Vec3};
use serde_json::{json, Value};

fn f32_bytes(xs: &[f32]) -> Vec<u8> {
    xs.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// One triangle (0,0,0), (1,0,0), (0,1,0): 36 bytes of positions, then 3 u16 indices + 2 pad.
fn triangle_bin() -> Vec<u8> {
    let mut b = f32_bytes(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    for i in [0u16, 1, 2, 0] {
        b.extend(i.to_le_bytes());
    }
    b
}

/// A document with one triangle mesh (mesh 0) placed by node 0 in scene 0.
fn base() -> Value {
    json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}
        ],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
        "buffers": [{"byteLength": 44, "uri": "buf.bin"}]
    })
}

/// Writes `doc` as `<dir>/scene.gltf` next to `buf.bin` holding `bin`.
fn write(name: &str, doc: &Value, bin: &[u8]) -> PathBuf {
    let dir = scratch::dir(name);
    std::fs::write(dir.join("buf.bin"), bin).unwrap();
    let path = dir.join("scene.gltf");
    std::fs::write(&path, serde_json::to_vec_pretty(doc).unwrap()).unwrap();
    path
}

fn load_ok(path: &Path) -> Scene {
    let s = scene::load(path).unwrap_or_else(|e| panic!("{e}"));
    s.validate().unwrap();
    s
}

/// Loads, expecting an error whose message names the file and starts its location with `pointer`.
fn load_err(path: &Path, pointer: &str) -> SceneError {
    load_err_with(path, pointer, &LoadOptions::default())
}

fn load_err_with(path: &Path, pointer: &str, options: &LoadOptions) -> SceneError {
    let e = match scene::load_with(path, options) {
        Ok(_) => panic!("{} loaded but should fail at {pointer}", path.display()),
        Err(e) => e,
    };
    let msg = e.to_string();
    assert!(
        msg.contains(&path.display().to_string()),
        "message does not name the file: {msg}"
    );
    assert!(
        e.pointer().starts_with(pointer),
        "expected location {pointer}, got {:?}: {msg}",
        e.pointer()
    );
    assert!(
        msg.contains(pointer),
        "message does not show the location: {msg}"
    );
    e
}

fn positions(s: &Scene, instance: usize) -> Vec<Vec3> {
    let i = &s.instances[instance];
    s.triangles()[i.first_triangle as usize..][..i.triangle_count as usize]
        .iter()
        .flat_map(|t| {
            t.vertices
                .map(|v| Vec3::from(s.vertices()[v as usize].position))
        })
        .collect()
}

fn near(a: Vec3, b: Vec3) -> bool {
    a.abs_diff_eq(b, 1e-5)
}

// ---------------------------------------------------------------- transforms and hierarchy

#[test]
fn trs_and_matrix_give_the_same_world_transform() {
    let mut doc = base();
    let (s, c) = (
        std::f32::consts::FRAC_1_SQRT_2,
        std::f32::consts::FRAC_1_SQRT_2,
    );
    // T(1,2,3) * R(90 degrees about z) * S(2), written once as TRS and once as a column-major matrix.
    doc["nodes"] = json!([
        {"mesh": 0, "translation": [1, 2, 3], "rotation": [0, 0, s, c], "scale": [2, 2, 2]},
        {"mesh": 0, "matrix": [0, 2, 0, 0, -2, 0, 0, 0, 0, 0, 2, 0, 1, 2, 3, 1]}
    ]);
    doc["scenes"] = json!([{"nodes": [0, 1]}]);
    let s = load_ok(&write("trs", &doc, &triangle_bin()));
    // By hand: (1,0,0) -> (2,0,0) -> (0,2,0) -> (1,4,3); (0,1,0) -> (0,2,0) -> (-2,0,0) -> (-1,2,3).
    let expect = [
        Vec3::new(1.0, 2.0, 3.0),
        Vec3::new(1.0, 4.0, 3.0),
        Vec3::new(-1.0, 2.0, 3.0),
    ];
    for inst in 0..2 {
        let p = positions(&s, inst);
        assert!(
            p.iter().zip(&expect).all(|(a, b)| near(*a, *b)),
            "instance {inst}: {p:?}"
        );
    }
}

#[test]
fn nested_nodes_compose_parent_first() {
    let mut doc = base();
    doc["nodes"] = json!([
        {"children": [1], "translation": [0, 0, 5], "scale": [2, 2, 2]},
        {"children": [2], "rotation": [0, 1, 0, 0]},
        {"mesh": 0, "translation": [1, 0, 0]}
    ]);
    let s = load_ok(&write("nested", &doc, &triangle_bin()));
    // world = T(0,0,5) S(2) * R(180 about y) * T(1,0,0): x -> -2(x + 1), y -> 2y, z -> 5 - 2z.
    let m = Mat4::from_translation(Vec3::new(0.0, 0.0, 5.0))
        * Mat4::from_scale(Vec3::splat(2.0))
        * Mat4::from_quat(Quat::from_xyzw(0.0, 1.0, 0.0, 0.0))
        * Mat4::from_translation(Vec3::X);
    let p = positions(&s, 0);
    assert!(
        near(p[0], Vec3::new(-2.0, 0.0, 5.0))
            && near(p[1], Vec3::new(-4.0, 0.0, 5.0))
            && near(p[2], Vec3::new(-2.0, 2.0, 5.0)),
        "{p:?}"
    );
    assert!(near(p[1], m.transform_point3(Vec3::X)));
    assert_eq!(s.instances[0].node, 2);
}

#[test]
fn mirroring_transform_keeps_triangles_front_facing() {
    let mut doc = base();
    doc["nodes"][0]["scale"] = json!([-1, 1, 1]);
    let s = load_ok(&write("mirror", &doc, &triangle_bin()));
    let [a, b, c] = s.triangle_corners(0);
    // The triangle faced +z; mirrored in x its front (by the inverse transpose) still faces +z.
    assert!((b - a).cross(c - a).z > 0.0);
}

// ---------------------------------------------------------------- cameras

fn camera_doc() -> Value {
    let mut doc = base();
    let h = std::f32::consts::FRAC_1_SQRT_2;
    doc["cameras"] = json!([
        {"name": "main", "type": "perspective", "perspective": {"yfov": 0.5, "znear": 0.1, "zfar": 100, "aspectRatio": 2}},
        {"name": "side", "type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.01}},
        {"name": "ortho", "type": "orthographic", "orthographic": {"xmag": 1, "ymag": 1, "znear": 0.1, "zfar": 10}}
    ]);
    doc["nodes"] = json!([
        {"mesh": 0},
        {"camera": 2},
        {"camera": 0, "translation": [0, 1, 10], "scale": [3, 3, 3]},
        {"name": "side_node", "camera": 1, "translation": [10, 0, 0], "rotation": [0, h, 0, h]}
    ]);
    doc["scenes"] = json!([{"nodes": [0, 1, 2, 3]}]);
    doc
}

#[test]
fn first_perspective_camera_is_chosen_and_orthographic_skipped() {
    let s = load_ok(&write("cam_first", &camera_doc(), &triangle_bin()));
    let c = &s.camera;
    assert_eq!(c.source, CameraSource::Node { node: 2, camera: 0 });
    assert_eq!(
        (c.yfov, c.znear, c.zfar, c.file_aspect_ratio),
        (0.5, 0.1, Some(100.0), Some(2.0))
    );
    // The node's scale is dropped: the camera frame is rigid.
    assert!(
        near(c.position(), Vec3::new(0.0, 1.0, 10.0))
            && near(c.forward(), Vec3::NEG_Z)
            && near(c.up(), Vec3::Y)
    );
    assert!(
        s.warnings
            .iter()
            .any(|w| w.starts_with("/cameras/2/orthographic")),
        "{:?}",
        s.warnings
    );
    // Film centre looks straight ahead; the right edge is tan(yfov/2) * aspect to the side.
    assert!(near(c.generate_ray(0.5, 0.5, 2.0).d, Vec3::NEG_Z));
    let d = c.generate_ray(1.0, 0.5, 2.0).d;
    assert!((d.x / -d.z - (0.25f32).tan() * 2.0).abs() < 1e-5);
    let d = c.generate_ray(0.5, 0.0, 2.0).d;
    assert!(
        (d.y / -d.z - (0.25f32).tan()).abs() < 1e-5,
        "top edge looks up"
    );
}

#[test]
fn camera_chosen_by_name() {
    let path = write("cam_named", &camera_doc(), &triangle_bin());
    for name in ["side", "side_node"] {
        let s = scene::load_with(
            &path,
            &LoadOptions {
                camera: Some(name.into()),
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(s.camera.yfov, 0.8);
        // Rotated 90 degrees about +y, the camera looks along -x.
        assert!(
            near(s.camera.forward(), Vec3::NEG_X),
            "{}",
            s.camera.forward()
        );
    }
    load_err_with(
        &path,
        "/cameras/2/orthographic",
        &LoadOptions {
            camera: Some("ortho".into()),
            ..Default::default()
        },
    );
    load_err_with(
        &path,
        "/cameras",
        &LoadOptions {
            camera: Some("nope".into()),
            ..Default::default()
        },
    );
}

#[test]
fn default_camera_frames_the_scene() {
    let s = load_ok(&write("cam_default", &base(), &triangle_bin()));
    let c = &s.camera;
    assert_eq!(c.source, CameraSource::Default);
    for corner in [
        s.bounds.min,
        s.bounds.max,
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ] {
        let to = (corner - c.position()).normalize();
        let angle = to.dot(c.forward()).acos();
        assert!(angle < 0.5 * c.yfov, "corner {corner} is outside the view");
    }
    assert!(!s.bounds.is_empty() && near(s.bounds.max, Vec3::new(1.0, 1.0, 0.0)));
}

// ---------------------------------------------------------------- lights and environment

#[test]
fn punctual_lights_of_all_three_types() {
    let mut doc = base();
    let h = std::f32::consts::FRAC_1_SQRT_2;
    doc["extensionsUsed"] = json!(["KHR_lights_punctual", "BRUME_environment"]);
    doc["extensions"] = json!({
        "KHR_lights_punctual": {"lights": [
            {"type": "point", "color": [1, 0.5, 0.25], "intensity": 10, "range": 5},
            {"type": "spot", "intensity": 3, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.4}},
            {"type": "directional", "intensity": 2}
        ]},
        "BRUME_environment": {"color": [0.5, 1, 0.25], "strength": 2}
    });
    doc["nodes"] = json!([
        {"mesh": 0},
        {"translation": [1, 2, 3], "extensions": {"KHR_lights_punctual": {"light": 0}}},
        {"translation": [1, 2, 3], "extensions": {"KHR_lights_punctual": {"light": 1}}},
        {"rotation": [h, 0, 0, h], "extensions": {"KHR_lights_punctual": {"light": 2}}}
    ]);
    doc["scenes"] = json!([{"nodes": [0, 1, 2, 3]}]);
    let s = load_ok(&write("lights", &doc, &triangle_bin()));
    let [p, sp, d] = [&s.lights[0], &s.lights[1], &s.lights[2]];
    // Factor 1: candela -> W/sr and lux -> W/m^2.
    assert_eq!(scene::RADIOMETRIC_PER_PHOTOMETRIC, 1.0);
    assert_eq!(
        (p.kind, p.intensity, p.position, p.range),
        (lights::LIGHT_POINT, [10.0, 5.0, 2.5], [1.0, 2.0, 3.0], 5.0)
    );
    assert_eq!(
        (sp.kind, sp.intensity, sp.range),
        (lights::LIGHT_SPOT, [3.0; 3], f32::INFINITY)
    );
    assert!(
        (sp.cos_inner - 0.2f32.cos()).abs() < 1e-7 && (sp.cos_outer - 0.4f32.cos()).abs() < 1e-7
    );
    assert!(near(Vec3::from(sp.direction), Vec3::NEG_Z));
    // 90 degrees about +x turns the light's -z into +y.
    assert_eq!((d.kind, d.intensity), (lights::LIGHT_DIRECTIONAL, [2.0; 3]));
    assert!(near(Vec3::from(d.direction), Vec3::Y), "{:?}", d.direction);
    assert_eq!(s.environment.radiance, [1.0, 2.0, 0.5]);
    let e = s.effects();
    assert!(e.punctual_lights && e.environment_light && !e.media && !e.lights_inside_media);
}

// ---------------------------------------------------------------- KHR_materials_volume

#[test]
fn khr_materials_volume_follows_the_spec() {
    let mut doc = base();
    let vol = |extra: Value| {
        let mut e = json!({"KHR_materials_transmission": {"transmissionFactor": 1}});
        for (k, v) in extra.as_object().unwrap() {
            e[k] = v.clone();
        }
        json!({"extensions": e})
    };
    doc["materials"] = json!([
        vol(json!({"KHR_materials_volume": {"thicknessFactor": 1, "attenuationColor": [0.5, 0.25, 1.0], "attenuationDistance": 2}})),
        vol(json!({"KHR_materials_volume": {"attenuationColor": [0.5, 0.5, 0.5], "attenuationDistance": 1}})),
        {"extensions": {"KHR_materials_volume": {"thicknessFactor": 1, "attenuationColor": [0.5, 0.5, 0.5], "attenuationDistance": 1}}},
        vol(json!({"KHR_materials_volume": {"thicknessFactor": 1}})),
        vol(json!({"KHR_materials_volume": {"thicknessFactor": 0.1, "attenuationColor": [0.1, 0.1, 0.1], "attenuationDistance": 1},
                   "BRUME_materials_volume_scattering": {"albedo": [0.5, 1, 0], "anisotropy": -0.3}}))
    ]);
    doc["meshes"][0]["primitives"][0]["material"] = json!(0);
    let s = load_ok(&write("volume", &doc, &triangle_bin()));
    let media = &s.homogeneous_media;
    assert_eq!(
        media.iter().map(|m| m.material).collect::<Vec<_>>(),
        [0, 3, 4]
    );
    // sigma_t = -ln(attenuationColor) / attenuationDistance; no scattering extension: absorbing.
    let ln2 = std::f32::consts::LN_2;
    assert!(
        near(Vec3::from(media[0].sigma_a), Vec3::new(ln2 / 2.0, ln2, 0.0))
            && media[0].sigma_s == [0.0; 3]
    );
    assert_eq!(s.materials[0].interior_medium, 0);
    // A single triangle cannot enclose the medium it bounds.
    assert!(
        s.warnings
            .iter()
            .any(|w| w.starts_with("/meshes/0/primitives/0") && w.contains("not closed")),
        "{:?}",
        s.warnings
    );
    // Thickness 0 is thin-walled and no transmission means no visible volume: no medium.
    assert_eq!(s.materials[1].interior_medium, scene::NO_INDEX);
    assert_eq!(s.materials[2].interior_medium, scene::NO_INDEX);
    assert!(s
        .warnings
        .iter()
        .any(|w| w.starts_with("/materials/1/extensions/KHR_materials_volume/thicknessFactor")));
    assert!(s
        .warnings
        .iter()
        .any(|w| w.starts_with("/materials/2/extensions/KHR_materials_volume")));
    // Default attenuationDistance is +inf: no attenuation.
    assert_eq!(media[1].sigma_t(), [0.0; 3]);
    // Albedo splits sigma_t = ln 10 into scattering and absorption.
    let ln10 = std::f32::consts::LN_10;
    assert!(near(
        Vec3::from(media[2].sigma_s),
        Vec3::new(0.5 * ln10, ln10, 0.0)
    ));
    assert!(near(
        Vec3::from(media[2].sigma_a),
        Vec3::new(0.5 * ln10, 0.0, ln10)
    ));
    assert_eq!(media[2].phase, Phase::hg(-0.3));
}

#[test]
fn volume_scattering_phase_replaces_anisotropy() {
    let mut doc = base();
    let phase = |phase: Value| {
        json!({"extensions": {
            "KHR_materials_transmission": {"transmissionFactor": 1},
            "KHR_materials_volume": {"thicknessFactor": 1, "attenuationColor": [0.5, 0.5, 0.5], "attenuationDistance": 1},
            "BRUME_materials_volume_scattering": {"albedo": [0.9, 0.9, 0.9], "anisotropy": 0.4, "phase": phase}
        }})
    };
    doc["materials"] = json!([
        phase(json!({"type": "henyey-greenstein", "g": -0.2})),
        phase(json!({"type": "two-lobe", "g1": 0.8, "g2": -0.3, "weight": 0.7})),
        phase(json!({"type": "draine", "g": 0.5, "alpha": 2.0})),
        phase(json!({"type": "mie", "diameter": 20.0})),
        phase(json!({"type": "rayleigh", "g": 0.3})),
    ]);
    // The triangle bounds the Rayleigh medium: a phase that is not isotropic.
    doc["meshes"][0]["primitives"][0]["material"] = json!(4);
    let s = load_ok(&write("volume_phase", &doc, &triangle_bin()));
    let two_lobe = Phase::TwoLobe {
        a: HenyeyGreenstein::new(0.8),
        b: HenyeyGreenstein::new(-0.3),
        w: 0.7,
    };
    let want = [
        Phase::hg(-0.2),
        two_lobe,
        Phase::Draine(Draine::new(0.5, 2.0)),
        Phase::mie(20.0).unwrap(),
        Phase::Rayleigh,
    ];
    let got: Vec<Phase> = s.homogeneous_media.iter().map(|m| m.phase).collect();
    assert_eq!(got, want);
    // The phase object replaces `anisotropy`, with a warning on every material that gives
    // both; a parameter its type does not take is reported.
    let ext = "extensions/BRUME_materials_volume_scattering";
    for k in 0..5 {
        let at = format!("/materials/{k}/{ext}/anisotropy");
        assert!(
            s.warnings.iter().any(|w| w.starts_with(&at)),
            "{at}: {:?}",
            s.warnings
        );
    }
    let at = format!("/materials/4/{ext}/phase/g");
    assert!(
        s.warnings.iter().any(|w| w.starts_with(&at)),
        "{at}: {:?}",
        s.warnings
    );
    assert!(s.effects().anisotropic_phase);
}

/// A closed cube [-1, 1]^3 (8 vertices, 12 outward triangles) as positions + u16 indices.
fn cube_bin() -> (Vec<u8>, usize) {
    let mut pos = Vec::new();
    for k in 0..8 {
        pos.extend([
            if k & 1 == 0 { -1.0 } else { 1.0 },
            if k & 2 == 0 { -1.0 } else { 1.0 },
            if k & 4 == 0 { -1.0 } else { 1.0 },
        ]);
    }
    let idx: [u16; 36] = [
        0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6,
        1, 3, 5, 3, 7, 5,
    ];
    let mut b = f32_bytes(&pos);
    for i in idx {
        b.extend(i.to_le_bytes());
    }
    (b, 96)
}

fn cube_doc(light_at: [f32; 3], camera_at: [f32; 3]) -> Value {
    json!({
        "asset": {"version": "2.0"},
        "scenes": [{"nodes": [0, 1, 2]}],
        "nodes": [
            {"mesh": 0},
            {"translation": light_at, "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"camera": 0, "translation": camera_at}
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 1, "znear": 0.01}}],
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point"}]}},
        "materials": [{"extensions": {
            "KHR_materials_transmission": {"transmissionFactor": 1},
            "KHR_materials_volume": {"thicknessFactor": 1, "attenuationColor": [0.5, 0.5, 0.5], "attenuationDistance": 1}
        }}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3", "min": [-1, -1, -1], "max": [1, 1, 1]},
            {"bufferView": 1, "componentType": 5123, "count": 36, "type": "SCALAR"}
        ],
        "bufferViews": [{"buffer": 0, "byteLength": 96}, {"buffer": 0, "byteOffset": 96, "byteLength": 72}],
        "buffers": [{"byteLength": 168, "uri": "buf.bin"}]
    })
}

#[test]
fn lights_and_camera_inside_a_closed_medium_mesh() {
    let (bin, _) = cube_bin();
    let s = load_ok(&write(
        "inside",
        &cube_doc([0.2, 0.1, -0.3], [0.0, 0.0, 0.5]),
        &bin,
    ));
    let e = s.effects();
    assert!(
        e.lights_inside_media
            && e.camera_inside_medium
            && e.homogeneous_media
            && e.absorption
            && !e.scattering
            && !e.chromatic_extinction
    );
    let s = load_ok(&write(
        "outside",
        &cube_doc([3.0, 0.0, 0.0], [0.0, 0.0, 5.0]),
        &bin,
    ));
    let e = s.effects();
    assert!(!e.lights_inside_media && !e.camera_inside_medium && e.homogeneous_media);
}

// ---------------------------------------------------------------- BRUME_medium_vdb

fn vdb_doc(medium: Value) -> Value {
    let mut doc = base();
    doc["nodes"] = json!([
        {"mesh": 0},
        {"matrix": [2, 0, 0, 0, 0, 3, 0, 0, 0, 0, 4, 0, 1, 1, 1, 1], "extensions": {"BRUME_medium_vdb": medium}}
    ]);
    doc["scenes"] = json!([{"nodes": [0, 1]}]);
    doc["extensionsUsed"] = json!(["BRUME_medium_vdb"]);
    doc
}

fn write_with_vdb(name: &str, doc: &Value) -> PathBuf {
    let path = write(name, doc, &triangle_bin());
    std::fs::create_dir_all(path.parent().unwrap().join("grids")).unwrap();
    // A small real file with the grids the tests name: density, flame, temperature.
    let grids: Vec<brume_ffi::GridSpec> = ["density", "flame", "temperature"]
        .iter()
        .map(|name| {
            let mut g = brume_ffi::GridSpec::fog(name, 0.1, [-0.4; 3]);
            for x in 0..8 {
                for y in 0..8 {
                    g.voxels.push(([x, y, 3], 0.5));
                }
            }
            g
        })
        .collect();
    brume_ffi::write_float_grids(path.parent().unwrap().join("grids/x.vdb"), &grids).unwrap();
    path
}

#[test]
fn vdb_medium_maps_principled_volume() {
    let doc = vdb_doc(
        json!({"uri": "grids/x.vdb", "densityScale": 2, "absorptionColor": [0.25, 0.25, 0.25], "anisotropy": 0.5, "colour": 1}),
    );
    let s = load_ok(&write_with_vdb("vdb", &doc));
    let m = &s.vdb_media[0];
    // Defaults: densityGrid "density", Blender's grey colour 0.5, no emission.
    assert_eq!(
        (
            m.density_grid.as_str(),
            m.color,
            m.emission_strength,
            m.node
        ),
        ("density", [0.5; 3], 0.0, 1)
    );
    // sigma_s = 0.5 * 2; sigma_a = (1 - 0.5) * (1 - sqrt(0.25)) * 2.
    assert_eq!(m.sigma_s_per_density(), [1.0; 3]);
    assert_eq!(m.sigma_a_per_density(), [0.5; 3]);
    let node = Mat4::from_cols_array(&[
        2.0, 0.0, 0.0, 0.0, 0.0, 3.0, 0.0, 0.0, 0.0, 0.0, 4.0, 0.0, 1.0, 1.0, 1.0, 1.0,
    ]);
    assert_eq!(m.world_from_medium, node * m.grids[0].vdb_world_from_index);
    assert!(m.vdb_path.is_absolute() && m.vdb_path.ends_with("grids/x.vdb"));
    // A misspelt field is reported, not silently defaulted.
    assert!(s
        .warnings
        .iter()
        .any(|w| w.starts_with("/nodes/1/extensions/BRUME_medium_vdb/colour")));
    let e = s.effects();
    assert!(
        e.heterogeneous_media
            && e.scattering
            && e.absorption
            && e.anisotropic_phase
            && !e.media_emission
            && !e.chromatic_extinction
    );

    // Emission needs a non-zero strength, or a temperature grid with blackbody intensity.
    let doc = vdb_doc(
        json!({"uri": "grids/x.vdb", "emissionGrid": "flame", "emissionStrength": 0, "temperatureGrid": "temperature"}),
    );
    assert!(
        !load_ok(&write_with_vdb("vdb_dark", &doc))
            .effects()
            .media_emission
    );
    let doc = vdb_doc(
        json!({"uri": "grids/x.vdb", "temperatureGrid": "temperature", "blackbodyIntensity": 1}),
    );
    assert!(
        load_ok(&write_with_vdb("vdb_hot", &doc))
            .effects()
            .media_emission
    );
    // Colour-dependent absorption makes extinction chromatic.
    let doc = vdb_doc(
        json!({"uri": "grids/x.vdb", "color": [0.2, 0.2, 0.2], "absorptionColor": [1, 0.5, 0]}),
    );
    assert!(
        load_ok(&write_with_vdb("vdb_chroma", &doc))
            .effects()
            .chromatic_extinction
    );
}

// ---------------------------------------------------------------- containers and primitives

/// Wraps `doc` and `bin` in a GLB container (glTF spec section 4.4).
fn glb(doc: &Value, bin: &[u8]) -> Vec<u8> {
    let mut json = serde_json::to_vec(doc).unwrap();
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let mut bin = bin.to_vec();
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::new();
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((json.len() as u32).to_le_bytes());
    out.extend(0x4E4F_534Au32.to_le_bytes());
    out.extend(json);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(0x004E_4942u32.to_le_bytes());
    out.extend(bin);
    out
}

#[test]
fn glb_files_load() {
    let mut doc = base();
    doc["buffers"] = json!([{"byteLength": 44}]);
    let dir = scratch::dir("glb");
    let path = dir.join("scene.glb");
    std::fs::write(&path, glb(&doc, &triangle_bin())).unwrap();
    let s = load_ok(&path);
    assert_eq!(s.triangle_count(), 1);

    // A binary chunk shorter than the buffer's byteLength.
    doc["buffers"] = json!([{"byteLength": 80}]);
    std::fs::write(&path, glb(&doc, &triangle_bin())).unwrap();
    load_err(&path, "/buffers/0/byteLength");
}

#[test]
fn strips_and_fans_unroll_and_lines_are_skipped() {
    let bin = f32_bytes(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0]);
    let mut doc = base();
    doc["accessors"] = json!([{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}]);
    doc["bufferViews"] = json!([{"buffer": 0, "byteLength": 48}]);
    doc["buffers"] = json!([{"byteLength": 48, "uri": "buf.bin"}]);
    doc["meshes"] = json!([{"primitives": [
        {"attributes": {"POSITION": 0}, "mode": 5},
        {"attributes": {"POSITION": 0}, "mode": 6},
        {"attributes": {"POSITION": 0}, "mode": 1}
    ]}]);
    let s = load_ok(&write("modes", &doc, &bin));
    assert_eq!(s.instances.len(), 2);
    assert_eq!(
        (s.instances[0].triangle_count, s.instances[1].triangle_count),
        (2, 2)
    );
    // Strip triangles alternate order so both face +z like the first.
    for k in 0..2 {
        let [a, b, c] = s.triangle_corners(k);
        assert!((b - a).cross(c - a).z > 0.0, "strip triangle {k}");
    }
    assert!(
        s.warnings
            .iter()
            .any(|w| w.starts_with("/meshes/0/primitives/2/mode")),
        "{:?}",
        s.warnings
    );
    assert!(!s.effects().names().is_empty());
}
