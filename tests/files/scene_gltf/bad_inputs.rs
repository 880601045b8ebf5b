//! Bad glTF inputs: missing or short buffers, indices out of range, a missing VDB file,
//! required extensions, singular transforms, out-of-range parameters and broken files. Each
//! must give a clear error naming the file and the JSON location, never a panic.
use super::*;

#[test]
fn missing_or_short_buffers() {
    let mut doc = base();
    doc["buffers"][0]["uri"] = json!("nope.bin");
    let e = load_err(&write("no_buffer", &doc, &triangle_bin()), "/buffers/0/uri");
    assert!(e.to_string().contains("nope.bin"));

    let mut doc = base();
    doc["buffers"][0]["byteLength"] = json!(100);
    load_err(
        &write("short_buffer", &doc, &triangle_bin()),
        "/buffers/0/byteLength",
    );

    let mut doc = base();
    doc["buffers"][0]["uri"] = json!("data:application/octet-stream;base64,AAAA");
    load_err(
        &write("short_data_uri", &doc, &triangle_bin()),
        "/buffers/0/byteLength",
    );

    // The accessor claims more vertices than its view holds.
    let mut doc = base();
    doc["accessors"][0]["count"] = json!(4);
    load_err(
        &write("long_accessor", &doc, &triangle_bin()),
        "/accessors/0",
    );

    // A view past the end of its buffer.
    let mut doc = base();
    doc["bufferViews"][1]["byteOffset"] = json!(40);
    load_err(&write("long_view", &doc, &triangle_bin()), "/bufferViews/1");
}

#[test]
fn index_out_of_range() {
    let mut bin = triangle_bin();
    bin[40] = 7; // third index
    load_err(
        &write("bad_index", &base(), &bin),
        "/meshes/0/primitives/0/indices",
    );
}

#[test]
fn missing_vdb_names_the_extension_uri() {
    let doc = vdb_doc(json!({"uri": "grids/missing.vdb"}));
    let e = load_err(
        &write("no_vdb", &doc, &triangle_bin()),
        "/nodes/1/extensions/BRUME_medium_vdb/uri",
    );
    assert!(e.to_string().contains("missing.vdb"), "{e}");
    let doc = vdb_doc(json!({"densityScale": 1}));
    load_err(
        &write("no_vdb_uri", &doc, &triangle_bin()),
        "/nodes/1/extensions/BRUME_medium_vdb/uri",
    );
}

#[test]
fn required_extensions() {
    let mut doc = base();
    doc["extensionsUsed"] = json!(["BRUME_medium_vdb", "KHR_draco_mesh_compression"]);
    doc["extensionsRequired"] = json!(["BRUME_medium_vdb", "KHR_draco_mesh_compression"]);
    let e = load_err(
        &write("required_unknown", &doc, &triangle_bin()),
        "/extensionsRequired/1",
    );
    assert!(e.to_string().contains("KHR_draco_mesh_compression"));
    doc["extensionsRequired"] = json!(["BRUME_medium_vdb", "KHR_materials_volume"]);
    load_ok(&write("required_known", &doc, &triangle_bin()));
}

#[test]
fn singular_and_invalid_transforms() {
    let cases = [
        (json!({"mesh": 0, "scale": [1, 0, 1]}), "/nodes/0/scale"),
        (
            json!({"mesh": 0, "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1]}),
            "/nodes/0/matrix",
        ),
        (
            json!({"mesh": 0, "rotation": [0, 0, 0, 0]}),
            "/nodes/0/rotation",
        ),
        (
            json!({"mesh": 0, "rotation": [0, 0, 0, 2]}),
            "/nodes/0/rotation",
        ),
        (
            json!({"mesh": 0, "translation": [1e300, 0, 0]}),
            "/nodes/0/translation/0",
        ),
    ];
    for (k, (node, pointer)) in cases.into_iter().enumerate() {
        let mut doc = base();
        doc["nodes"] = json!([node]);
        load_err(
            &write(&format!("transform{k}"), &doc, &triangle_bin()),
            pointer,
        );
    }
}

#[test]
fn out_of_range_medium_parameters() {
    let ext = "/nodes/1/extensions/BRUME_medium_vdb";
    let cases = [
        (
            json!({"uri": "grids/x.vdb", "densityScale": -1}),
            format!("{ext}/densityScale"),
        ),
        (
            json!({"uri": "grids/x.vdb", "densityScale": 1e300}),
            format!("{ext}/densityScale"),
        ),
        (
            json!({"uri": "grids/x.vdb", "anisotropy": 1.0}),
            format!("{ext}/anisotropy"),
        ),
        (
            json!({"uri": "grids/x.vdb", "anisotropy": -1.5}),
            format!("{ext}/anisotropy"),
        ),
        (
            json!({"uri": "grids/x.vdb", "color": [2, 0, 0]}),
            format!("{ext}/color/0"),
        ),
        (
            json!({"uri": "grids/x.vdb", "absorptionColor": [0, 0]}),
            format!("{ext}/absorptionColor"),
        ),
        (
            json!({"uri": "grids/x.vdb", "emissionColor": [0, -0.5, 0]}),
            format!("{ext}/emissionColor/1"),
        ),
        (
            json!({"uri": "grids/x.vdb", "densityGrid": 3}),
            format!("{ext}/densityGrid"),
        ),
        (
            json!({"uri": "grids/x.vdb", "mesh": 9}),
            format!("{ext}/mesh"),
        ),
        // Fuzz findings (tests/files/fuzz_inputs/, seed 2000): a u64::MAX densityScale stalled
        // free flights (steps below the float spacing), emissionStrength 3.4e38 rendered inf.
        (
            json!({"uri": "grids/x.vdb", "densityScale": 18446744073709551615u64}),
            format!("{ext}/densityScale"),
        ),
        (
            json!({"uri": "grids/x.vdb", "densityScale": 1e8}),
            format!("{ext}/densityScale"),
        ),
        (
            json!({"uri": "grids/x.vdb", "emissionStrength": 3.4028235e38}),
            format!("{ext}/emissionStrength"),
        ),
        (
            json!({"uri": "grids/x.vdb", "emissionGrid": "flame", "emissionStrength": 1e21, "emissionColor": [1, 1, 1]}),
            format!("{ext}/emissionStrength"),
        ),
        (json!("not an object"), ext.to_string()),
        (
            json!({"uri": "grids/x.vdb", "phase": {"type": "cornette-shanks"}}),
            format!("{ext}/phase/type"),
        ),
        (
            json!({"uri": "grids/x.vdb", "phase": {"g": 0.3}}),
            format!("{ext}/phase/type"),
        ),
        (
            json!({"uri": "grids/x.vdb", "phase": {"type": "mie"}}),
            format!("{ext}/phase/diameter"),
        ),
        (
            json!({"uri": "grids/x.vdb", "phase": {"type": "mie", "diameter": 80}}),
            format!("{ext}/phase/diameter"),
        ),
        (
            json!({"uri": "grids/x.vdb", "phase": {"type": "two-lobe", "g1": 1.0}}),
            format!("{ext}/phase/g1"),
        ),
        (
            json!({"uri": "grids/x.vdb", "phase": {"type": "draine", "alpha": -2}}),
            format!("{ext}/phase/alpha"),
        ),
        (
            json!({"uri": "grids/x.vdb", "phase": [0.3]}),
            format!("{ext}/phase"),
        ),
    ];
    for (k, (medium, pointer)) in cases.into_iter().enumerate() {
        load_err(
            &write_with_vdb(&format!("medium{k}"), &vdb_doc(medium)),
            &pointer,
        );
    }
}

#[test]
fn out_of_range_material_and_light_parameters() {
    let scattering = |albedo: Value, g: Value| {
        let mut doc = base();
        doc["materials"] = json!([{"extensions": {
            "KHR_materials_transmission": {"transmissionFactor": 1},
            "KHR_materials_volume": {"thicknessFactor": 1},
            "BRUME_materials_volume_scattering": {"albedo": albedo, "anisotropy": g}
        }}]);
        doc
    };
    let ext = "/materials/0/extensions/BRUME_materials_volume_scattering";
    load_err(
        &write(
            "albedo",
            &scattering(json!([0.5, 1.5, 0]), json!(0)),
            &triangle_bin(),
        ),
        &format!("{ext}/albedo/1"),
    );
    load_err(
        &write(
            "g",
            &scattering(json!([0.5, 0.5, 0.5]), json!(-1)),
            &triangle_bin(),
        ),
        &format!("{ext}/anisotropy"),
    );
    // The phase object is checked as BRUME_medium_vdb's is.
    for (k, (phase, pointer)) in [
        (json!({"type": "cornette-shanks"}), "phase/type"),
        (json!({"type": "mie", "diameter": 80}), "phase/diameter"),
        (json!({"type": "draine", "g": 1.0}), "phase/g"),
        (json!("rayleigh"), "phase"),
    ]
    .into_iter()
    .enumerate()
    {
        let mut doc = scattering(json!([0.5, 0.5, 0.5]), json!(0));
        doc["materials"][0]["extensions"]["BRUME_materials_volume_scattering"]["phase"] = phase;
        load_err(
            &write(&format!("phase{k}"), &doc, &triangle_bin()),
            &format!("{ext}/{pointer}"),
        );
    }

    let mut doc = base();
    doc["materials"] = json!([{"pbrMetallicRoughness": {"baseColorFactor": [1.2, 0, 0, 1]}}]);
    load_err(
        &write("base_color", &doc, &triangle_bin()),
        "/materials/0/pbrMetallicRoughness/baseColorFactor",
    );

    let mut doc = base();
    doc["materials"] = json!([{"emissiveFactor": [1, 1, 1], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 1e300}}}]);
    load_err(
        &write("emissive", &doc, &triangle_bin()),
        "/materials/0/extensions/KHR_materials_emissive_strength",
    );

    let light = |l: Value| {
        let mut doc = base();
        doc["extensions"] = json!({"KHR_lights_punctual": {"lights": [l]}});
        doc["nodes"] = json!([{"mesh": 0}, {"extensions": {"KHR_lights_punctual": {"light": 0}}}]);
        doc["scenes"] = json!([{"nodes": [0, 1]}]);
        doc
    };
    let lp = "/extensions/KHR_lights_punctual/lights/0";
    load_err(
        &write(
            "light_inf",
            &light(json!({"type": "point", "intensity": 1e300})),
            &triangle_bin(),
        ),
        &format!("{lp}/intensity"),
    );
    load_err(
        &write(
            "spot_cone",
            &light(json!({"type": "spot", "spot": {"innerConeAngle": 0.5, "outerConeAngle": 0.4}})),
            &triangle_bin(),
        ),
        lp,
    );
    load_err(
        &write(
            "light_color",
            &light(json!({"type": "point", "color": [1, 1, 3]})),
            &triangle_bin(),
        ),
        &format!("{lp}/color/2"),
    );

    let mut doc = base();
    doc["extensions"] = json!({"BRUME_environment": {"color": [1, 1, 1], "uri": "sky.exr"}});
    load_err(
        &write("no_sky", &doc, &triangle_bin()),
        "/extensions/BRUME_environment/uri",
    );
    doc["extensions"] = json!({"BRUME_environment": {"strength": -1}});
    load_err(
        &write("dark_sky", &doc, &triangle_bin()),
        "/extensions/BRUME_environment/strength",
    );
}

#[test]
fn unparsable_and_structurally_broken_files() {
    let dir = scratch::dir("broken");
    let path = dir.join("scene.gltf");
    // 1e400 does not fit a double; serde_json refuses it with a line and column.
    std::fs::write(
        &path,
        br#"{"asset": {"version": "2.0"}, "nodes": [{"translation": [1e400, 0, 0]}]}"#,
    )
    .unwrap();
    let e = load_err(&path, "");
    assert!(matches!(e, SceneError::Parse { .. }), "{e}");
    std::fs::write(&path, b"{ not json").unwrap();
    load_err(&path, "");
    std::fs::write(&path, b"glTF\x02\x00\x00\x00\x10\x00\x00\x00").unwrap();
    load_err(&path, "");
    std::fs::write(&path, b"").unwrap();
    load_err(&path, "");
    let e = load_err(&dir.join("absent.gltf"), "");
    assert!(matches!(e, SceneError::Io { .. }));

    // No scene to render.
    let mut doc = base();
    doc.as_object_mut().unwrap().remove("scenes");
    doc.as_object_mut().unwrap().remove("scene");
    load_err(&write("no_scene", &doc, &triangle_bin()), "/scenes");

    // A node reached twice, and a cycle: errors, not hangs.
    let mut doc = base();
    doc["scenes"] = json!([{"nodes": [0, 0]}]);
    load_err(&write("twice", &doc, &triangle_bin()), "/");
    let mut doc = base();
    doc["nodes"] = json!([{"mesh": 0, "children": [1]}, {"children": [0]}]);
    load_err(&write("cycle", &doc, &triangle_bin()), "/");

    // An index past the end of an array (gltf-json's validation, converted to a pointer).
    let mut doc = base();
    doc["nodes"][0]["mesh"] = json!(5);
    load_err(
        &write("bad_mesh_index", &doc, &triangle_bin()),
        "/nodes/0/mesh",
    );

    // A light index past the end of the light list.
    let mut doc = base();
    doc["extensions"] = json!({"KHR_lights_punctual": {"lights": [{"type": "point"}]}});
    doc["nodes"][0]["extensions"] = json!({"KHR_lights_punctual": {"light": 3}});
    load_err(&write("bad_light_index", &doc, &triangle_bin()), "/nodes/0");

    // A vertex count so large that its byte size overflows.
    let mut doc = base();
    doc["accessors"][0]["count"] = json!(4_611_686_018_427_387_904u64);
    load_err(&write("huge_count", &doc, &triangle_bin()), "/");

    // Sparse accessors are rejected rather than half-read.
    let mut doc = base();
    doc["accessors"][0]["sparse"] = json!({"count": 1, "indices": {"bufferView": 1, "componentType": 5123}, "values": {"bufferView": 0}});
    load_err(&write("sparse", &doc, &triangle_bin()), "/accessors/0");
}
