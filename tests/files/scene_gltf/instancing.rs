//! Meshes placed many times: `EXT_mesh_gpu_instancing` rows against transforms worked by hand,
//! the example groves (one instancing node per mesh, one node per instance) against each
//! other, the heavy-scene generator against its own counts, and bad instancing and geometry
//! inputs against clear errors naming the file, the node and the primitive.
use super::*;

#[allow(dead_code)]
#[path = "../../../scenes/make_heavy.rs"]
mod make_heavy;

/// `triangle_bin` followed by two instances' rows: TRANSLATION at byte 44, ROTATION at 68,
/// SCALE at 100 (124 bytes).
fn instanced_bin(rows: [[f32; 10]; 2]) -> Vec<u8> {
    let mut b = triangle_bin();
    for range in [0..3, 3..7, 7..10] {
        for r in &rows {
            b.extend(f32_bytes(&r[range.clone()]));
        }
    }
    b
}

/// `base()` with node 0 (translated to z = 1) instancing mesh 0 twice through accessors 2-4.
fn instanced_doc() -> Value {
    let mut doc = base();
    doc["nodes"] = json!([{"name": "grove", "mesh": 0, "translation": [0, 0, 1],
        "extensions": {"EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": 2, "ROTATION": 3, "SCALE": 4}}}}]);
    let views = doc["bufferViews"].as_array_mut().unwrap();
    views.push(json!({"buffer": 0, "byteOffset": 44, "byteLength": 24}));
    views.push(json!({"buffer": 0, "byteOffset": 68, "byteLength": 32}));
    views.push(json!({"buffer": 0, "byteOffset": 100, "byteLength": 24}));
    let accessors = doc["accessors"].as_array_mut().unwrap();
    accessors.push(json!({"bufferView": 2, "componentType": 5126, "count": 2, "type": "VEC3"}));
    accessors.push(json!({"bufferView": 3, "componentType": 5126, "count": 2, "type": "VEC4"}));
    accessors.push(json!({"bufferView": 4, "componentType": 5126, "count": 2, "type": "VEC3"}));
    doc["buffers"][0]["byteLength"] = json!(124);
    doc["extensionsUsed"] = json!(["EXT_mesh_gpu_instancing"]);
    doc["extensionsRequired"] = json!(["EXT_mesh_gpu_instancing"]);
    doc
}

/// Instance 0 as the identity; instance 1 translated by (5, 0, 0), turned 90 degrees about z
/// and scaled by 2. Each row: translation, rotation (x, y, z, w), scale.
fn two_rows() -> [[f32; 10]; 2] {
    let h = std::f32::consts::FRAC_1_SQRT_2;
    [
        [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0],
        [5.0, 0.0, 0.0, 0.0, 0.0, h, h, 2.0, 2.0, 2.0],
    ]
}

#[test]
fn gpu_instancing_rows_place_the_mesh_under_the_node() {
    let s = load_ok(&write(
        "gpu_instancing",
        &instanced_doc(),
        &instanced_bin(two_rows()),
    ));
    assert_eq!((s.instances.len(), s.triangle_count()), (2, 2));
    assert!(s.instances.iter().all(|i| i.node == 0 && i.mesh == 0));
    // By hand, node T(0,0,1) * T(5,0,0) R(90 about z) S(2): (0,0,0) -> (5,0,1);
    // (1,0,0) -> (2,0,0) -> (0,2,0) -> (5,2,1); (0,1,0) -> (0,2,0) -> (-2,0,0) -> (3,0,1).
    let expect = [
        [
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(0.0, 1.0, 1.0),
        ],
        [
            Vec3::new(5.0, 0.0, 1.0),
            Vec3::new(5.0, 2.0, 1.0),
            Vec3::new(3.0, 0.0, 1.0),
        ],
    ];
    for (inst, want) in expect.iter().enumerate() {
        let p = positions(&s, inst);
        assert!(
            p.iter().zip(want).all(|(a, b)| near(*a, *b)),
            "instance {inst}: {p:?}"
        );
    }
}

#[test]
fn triangles_placed_on_demand_are_the_world_arrays_bit_for_bit() {
    // Two placements of one mesh (the second mirrored in x, turned and scaled): the two-level
    // BVH answers, so the world arrays wait; single triangles placed from the stored
    // primitive must be what the arrays hold, winding included.
    let h = std::f32::consts::FRAC_1_SQRT_2;
    let rows = [
        [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0],
        [5.0, 0.0, 0.0, 0.0, 0.0, h, h, -2.0, 2.0, 0.5],
    ];
    let mirrored = load_ok(&write(
        "placed_on_demand",
        &instanced_doc(),
        &instanced_bin(rows),
    ));
    // The grove's rocks and trees carry normals.
    let grove = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/instancing/grove_ext.gltf");
    for s in [mirrored, load_ok(&grove)] {
        assert!(s.instanced.is_some() && !s.world_arrays_built());
        let placed: Vec<(u32, [brume::scene::Vertex; 3], [Vec3; 3])> = (0..s.triangle_count())
            .map(|t| {
                (
                    s.triangle_instance(t),
                    s.triangle_vertices(t),
                    s.triangle_corners(t),
                )
            })
            .collect();
        assert!(
            !s.world_arrays_built(),
            "placing single triangles built the arrays"
        );
        let (vertices, triangles) = (s.vertices(), s.triangles());
        assert_eq!(placed.len(), triangles.len());
        for (t, (instance, corners, positions)) in placed.iter().enumerate() {
            let held = triangles[t].vertices.map(|i| vertices[i as usize]);
            assert_eq!(
                positions.map(|p| p.to_array().map(f32::to_bits)),
                held.map(|v| v.position.map(f32::to_bits)),
                "triangle {t}: corner positions"
            );
            assert_eq!(*instance, triangles[t].instance, "triangle {t}");
            assert_eq!(
                bytemuck::bytes_of(corners),
                bytemuck::bytes_of(&held),
                "triangle {t}: {corners:?} placed, {held:?} held"
            );
        }
    }
}

/// The world-space corners of every triangle, instance by instance.
fn world_triangles(s: &Scene) -> Vec<Vec3> {
    (0..s.instances.len())
        .flat_map(|k| positions(s, k))
        .collect()
}

/// Both scenes place the same triangles in the same order, to f32 rounding.
fn assert_same_world(a: &Scene, b: &Scene) {
    assert_eq!(a.instances.len(), b.instances.len());
    assert_eq!(a.triangle_count(), b.triangle_count());
    let (pa, pb) = (world_triangles(a), world_triangles(b));
    let worst = pa
        .iter()
        .zip(&pb)
        .map(|(x, y)| (*x - *y).abs().max_element())
        .fold(0.0f32, f32::max);
    assert!(worst < 1e-4, "largest corner difference {worst} m");
}

#[test]
fn the_example_groves_place_the_same_triangles() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/instancing");
    let ext = load_ok(&dir.join("grove_ext.gltf"));
    let nodes = load_ok(&dir.join("grove_nodes.gltf"));
    // The terrain and 40 instances of 4 meshes.
    assert_eq!(ext.instances.len(), 41);
    assert_same_world(&ext, &nodes);
    assert!(ext.warnings.is_empty(), "{:?}", ext.warnings);
    assert_eq!(ext.vdb_media.len(), 1);
    // What `brume info` reports: the 5 primitives' triangles once, and every placement's. As
    // loaded: the comparison above built both scenes' world arrays.
    for name in ["grove_ext.gltf", "grove_nodes.gltf"] {
        let s = load_ok(&dir.join(name));
        let g = s.geometry_stats();
        assert_eq!((g.primitives, g.placements), (5, 41));
        assert_eq!((g.stored_triangles, g.instanced_triangles), (1536, 8976));
        assert_eq!(g.vertices, s.vertex_count());
        // The two-level BVH holds each primitive's corners once; the world arrays and the flat
        // BVH wait for first use and then hold every placement's.
        let two_level = g.two_level_bytes.expect("a two-level BVH");
        assert!(
            g.bvh_bytes == 0
                && (48 * 1536..48 * 8976).contains(&two_level)
                && g.array_bytes == 32 * 41
                && (12 * 1536..16 * 8976).contains(&g.stored_bytes)
                && !s.world_arrays_built(),
            "{g:?}"
        );
        assert_eq!(s.vertices().len(), g.vertices);
        s.bvh();
        let built = s.geometry_stats();
        assert!(
            built.bvh_bytes >= 48 * 8976 && built.array_bytes >= 16 * 8976,
            "{built:?}"
        );
    }
}

#[test]
fn the_heavy_generator_writes_what_it_counts() {
    let dir = scratch::dir("make_heavy");
    let mut scenes = Vec::new();
    for nodes in [false, true] {
        let params = make_heavy::Params {
            terrain_triangles: 200,
            instances: 24,
            nodes,
            detail: 1,
        };
        let path = dir.join(format!("heavy_{nodes}.gltf"));
        let w = make_heavy::write_scene(&path, &params).unwrap();
        let s = load_ok(&path);
        assert_eq!(s.triangle_count(), w.placed_triangles);
        assert_eq!(s.instances.len(), w.placements);
        assert_eq!(s.geometry_stats().stored_triangles, w.stored_triangles);
        assert!(w.placed_triangles > 4 * w.stored_triangles, "{w:?}");
        println!("nodes {nodes}: {w:?}");
        scenes.push(s);
    }
    assert_same_world(&scenes[0], &scenes[1]);
}

// ---------------------------------------------------------------- bad instancing

/// An edit of `instanced_doc` and the pointer suffix (after the attributes) its error names.
type Edit = (&'static str, fn(&mut Value));

#[test]
fn bad_instancing_attributes_are_refused() {
    let at = "/nodes/0/extensions/EXT_mesh_gpu_instancing/attributes";
    let edits: [Edit; 4] = [
        ("/TRANSLATION", |d| {
            d["nodes"][0]["extensions"]["EXT_mesh_gpu_instancing"]["attributes"]["TRANSLATION"] =
                json!(99)
        }),
        ("/SCALE", |d| d["accessors"][4]["count"] = json!(1)),
        ("", |d| {
            d["nodes"][0]["extensions"]["EXT_mesh_gpu_instancing"]["attributes"] = json!({})
        }),
        ("", |d| {
            d["nodes"][0]["extensions"]["EXT_mesh_gpu_instancing"] = json!({"attributes": 3})
        }),
    ];
    for (k, (suffix, edit)) in edits.into_iter().enumerate() {
        let mut doc = instanced_doc();
        edit(&mut doc);
        let path = write(
            &format!("bad_instancing{k}"),
            &doc,
            &instanced_bin(two_rows()),
        );
        let e = load_err(&path, &format!("{at}{suffix}"));
        println!("{e}");
    }
    // A wrong type is reported at the accessor, naming the attribute that uses it.
    let mut doc = instanced_doc();
    doc["accessors"][3]["type"] = json!("VEC3");
    let path = write("bad_rotation_type", &doc, &instanced_bin(two_rows()));
    let e = load_err(&path, "/accessors/3");
    assert!(e.to_string().contains(&format!("{at}/ROTATION")), "{e}");
    let mut rows = two_rows();
    rows[1][3] = 0.5;
    let path = write("bad_rotation", &instanced_doc(), &instanced_bin(rows));
    let e = load_err(&path, &format!("{at}/ROTATION"));
    assert!(e.to_string().contains("instance 1"), "{e}");
    let mut rows = two_rows();
    rows[0][8] = 0.0;
    let path = write("bad_scale", &instanced_doc(), &instanced_bin(rows));
    load_err(&path, &format!("{at}/SCALE"));
    let mut rows = two_rows();
    rows[1][1] = f32::NAN;
    let path = write("nan_translation", &instanced_doc(), &instanced_bin(rows));
    let e = load_err(&path, &format!("{at}/TRANSLATION"));
    assert!(e.to_string().contains("non-finite"), "{e}");
    // On a node without a mesh the extension has nothing to place: a warning, not an error.
    let mut doc = instanced_doc();
    doc["nodes"][0].as_object_mut().unwrap().remove("mesh");
    let s = load_ok(&write("no_mesh", &doc, &instanced_bin(two_rows())));
    assert!(
        s.warnings
            .iter()
            .any(|w| w.starts_with("/nodes/0/extensions/EXT_mesh_gpu_instancing")),
        "{:?}",
        s.warnings
    );
}

// ---------------------------------------------------------------- bad geometry

#[test]
fn an_out_of_range_mesh_index_names_the_node() {
    let mut doc = base();
    doc["nodes"][0]["mesh"] = json!(7);
    let e = load_err(&write("mesh_index", &doc, &triangle_bin()), "/nodes/0/mesh");
    assert!(e.to_string().contains("index 7"), "{e}");
    assert!(e.to_string().contains("1 meshes"), "{e}");
}

#[test]
fn a_nan_vertex_names_the_node_and_the_primitive() {
    let mut doc = base();
    doc["nodes"][0]["name"] = json!("boulder");
    let mut bin = triangle_bin();
    bin[12..16].copy_from_slice(&f32::NAN.to_le_bytes());
    let e = load_err(
        &write("nan_vertex", &doc, &bin),
        "/meshes/0/primitives/0/attributes/POSITION",
    );
    let msg = e.to_string();
    assert!(
        msg.contains("vertex 1") && msg.contains("node 0 \"boulder\""),
        "{msg}"
    );
}

#[test]
fn degenerate_triangles_are_skipped_with_one_warning_per_primitive() {
    let mut doc = base();
    // Two nodes place the same primitive, whose only triangle has collinear corners.
    doc["nodes"] = json!([{"mesh": 0}, {"mesh": 0, "translation": [0, 0, 2]}]);
    doc["scenes"] = json!([{"nodes": [0, 1]}]);
    let mut bin = triangle_bin();
    bin[24..36].copy_from_slice(&f32_bytes(&[2.0, 0.0, 0.0]));
    let s = load_ok(&write("degenerate", &doc, &bin));
    assert_eq!(s.triangle_count(), 0);
    let warned: Vec<_> = s
        .warnings
        .iter()
        .filter(|w| w.contains("degenerate"))
        .collect();
    assert_eq!(warned.len(), 1, "{:?}", s.warnings);
    assert!(
        warned[0].starts_with("/meshes/0/primitives/0") && warned[0].contains("1 of 1"),
        "{warned:?}"
    );
}

#[test]
fn counts_beyond_32_bit_indices_are_refused_before_reading() {
    let mut doc = base();
    doc["accessors"][0]["count"] = json!(5_000_000_000u64);
    let e = load_err(
        &write("u32_vertices", &doc, &triangle_bin()),
        "/meshes/0/primitives/0/attributes/POSITION",
    );
    assert!(e.to_string().contains("32-bit"), "{e}");
    assert!(e.to_string().contains("node 0"), "{e}");
    let mut doc = base();
    doc["accessors"][1]["count"] = json!(4_294_967_296u64);
    load_err(
        &write("u32_indices", &doc, &triangle_bin()),
        "/meshes/0/primitives/0/indices",
    );
}
