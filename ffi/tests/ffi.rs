//! The shim and its safe wrapper, on files this test writes through OpenVDB itself.
#[path = "../../tests/common/scratch.rs"]
mod scratch;

use brume_ffi::*;
use std::path::PathBuf;

/// A 40^3 block of constant density 0.5 (whose interior leaves prune into tiles) plus a ramp.
fn block_and_ramp() -> GridSpec {
    let mut g = GridSpec::fog("density", 0.1, [1.0, 2.0, 3.0]);
    for x in 0..40 {
        for y in 0..40 {
            for z in 0..40 {
                g.voxels.push(([x, y, z], 0.5));
            }
        }
    }
    for x in 50..60 {
        g.voxels.push(([x, 3, -5], x as f32 * 0.01));
    }
    g
}

#[test]
fn writes_and_reads_leaves_tiles_and_transform() {
    let dir = scratch::dir("roundtrip");
    let path = dir.join("g.vdb");
    write_float_grids(&path, &[block_and_ramp()]).unwrap();
    let file = VdbFile::open(&path).unwrap();
    assert_eq!(file.grids().len(), 1);
    let info = &file.grids()[0];
    assert_eq!(info.name, "density");
    assert_eq!(info.value_type, "float");
    assert_eq!(info.class, GridClass::FogVolume);
    assert!(info.is_affine);
    assert!(info.voxel_size.iter().all(|v| (v - 0.1).abs() < 1e-12));
    assert_eq!(info.world_from_index[0][3], 1.0);
    assert_eq!(info.world_from_index[2][3], 3.0);
    assert_eq!(info.active_voxel_count, 40 * 40 * 40 + 10);
    assert_eq!(info.active_bbox, Some(([0, 0, -5], [59, 39, 39])));
    assert_eq!(info.background, Some(0.0));
    assert!(file
        .metadata()
        .iter()
        .any(|(k, _, v)| k == "creator" && v == "brume"));

    let data = file
        .read_float_grid("density", ReadOptions::default())
        .unwrap();
    // 40 = 5 leaves per axis, all constant: pruning turns them into leaf-sized tiles.
    assert!(
        !data.tiles.is_empty(),
        "pruned constant leaves must come back as tiles"
    );
    let tile_voxels: u64 = data
        .tiles
        .iter()
        .filter(|t| t.active)
        .map(|t| (t.dim as u64).pow(3))
        .sum();
    let leaf_voxels: u64 = data
        .leaves
        .iter()
        .map(|l| l.active.iter().map(|w| w.count_ones() as u64).sum::<u64>())
        .sum();
    assert_eq!(tile_voxels + leaf_voxels, info.active_voxel_count);
}

#[test]
fn openvdb_samplers_run_through_the_shim() {
    let dir = scratch::dir("sample");
    let path = dir.join("g.vdb");
    write_float_grids(&path, &[block_and_ramp()]).unwrap();
    let file = VdbFile::open(&path).unwrap();
    let g = file
        .open_float_grid("density", ReadOptions::default())
        .unwrap();
    let v = g
        .sample(
            &[
                [10.0, 10.0, 10.0],
                [39.5, 10.0, 10.0],
                [100.0, 0.0, 0.0],
                [54.6, 3.0, -5.0],
            ],
            SampleOrder::Trilinear,
        )
        .unwrap();
    assert_eq!(v[0], 0.5);
    assert!((v[1] - 0.25).abs() < 1e-6);
    assert_eq!(v[2], 0.0);
    assert!((v[3] - 0.546).abs() < 1e-6);
    let n = g
        .sample(&[[54.6, 3.4, -5.4]], SampleOrder::Nearest)
        .unwrap();
    assert_eq!(n[0], 0.55);
}

#[test]
fn level_sets_convert_to_fog_on_request() {
    let dir = scratch::dir("ls");
    let path = dir.join("ls.vdb");
    let mut g = GridSpec::fog("surface", 0.1, [0.0; 3]);
    g.class = GridClass::LevelSet;
    g.background = 0.3;
    g.prune = false;
    for x in -10..10 {
        for y in -10..10 {
            for z in -10..10 {
                let d = ((x * x + y * y + z * z) as f32).sqrt() * 0.1 - 0.5;
                if d.abs() < 0.3 {
                    g.voxels.push(([x, y, z], d));
                }
            }
        }
    }
    write_float_grids(&path, &[g]).unwrap();
    let file = VdbFile::open(&path).unwrap();
    assert_eq!(file.grids()[0].class, GridClass::LevelSet);
    let fog = file
        .read_float_grid(
            "surface",
            ReadOptions {
                level_set_to_fog: true,
            },
        )
        .unwrap();
    assert_eq!(fog.info.class, GridClass::FogVolume);
    assert_eq!(fog.background, 0.0);
    for l in &fog.leaves {
        assert!(l.values.iter().all(|v| (0.0..=1.0).contains(v)));
    }
}

#[test]
fn bad_files_give_clear_errors() {
    let dir = scratch::dir("bad");
    let good = dir.join("good.vdb");
    write_float_grids(&good, &[block_and_ramp()]).unwrap();
    let bytes = std::fs::read(&good).unwrap();

    let cases: Vec<(PathBuf, &str)> = {
        let empty = dir.join("empty.vdb");
        std::fs::write(&empty, b"").unwrap();
        let random = dir.join("random.vdb");
        let mut x: u64 = 0x9e3779b97f4a7c15;
        let noise: Vec<u8> = (0..4096)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                x as u8
            })
            .collect();
        std::fs::write(&random, noise).unwrap();
        let truncated = dir.join("truncated.vdb");
        std::fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
        vec![
            (dir.join("missing.vdb"), "no such file"),
            (dir.clone(), "directory"),
            (empty, "empty"),
            (random, ""),
            (truncated, ""),
        ]
    };
    for (path, needle) in cases {
        let err = VdbFile::open(&path)
            .err()
            .unwrap_or_else(|| panic!("{} opened", path.display()));
        let msg = err.to_string();
        assert!(msg.contains(&path.display().to_string()), "{msg}");
        assert!(msg.contains(needle), "{msg}");
    }
    // Every truncation point, not just the middle: none may crash or hang.
    let cut = dir.join("cut.vdb");
    for len in (0..bytes.len()).step_by(bytes.len() / 97 + 1) {
        std::fs::write(&cut, &bytes[..len]).unwrap();
        assert!(
            VdbFile::open(&cut).is_err(),
            "a file cut at {len} bytes opened"
        );
    }

    let file = VdbFile::open(&good).unwrap();
    let err = file
        .read_float_grid("temperature", ReadOptions::default())
        .unwrap_err();
    assert_eq!(err.kind, VdbErrorKind::NotFound);
    assert!(
        err.to_string().contains("no grid named 'temperature'")
            && err.to_string().contains("'density'"),
        "{err}"
    );

    let vec = dir.join("vec3.vdb");
    let mut g = block_and_ramp();
    g.name = "vel".into();
    g.as_vec3 = true;
    write_float_grids(&vec, &[g]).unwrap();
    let err = VdbFile::open(&vec)
        .unwrap()
        .read_float_grid("vel", ReadOptions::default())
        .unwrap_err();
    assert_eq!(err.kind, VdbErrorKind::Type);
    assert!(err.to_string().contains("vec3s"), "{err}");
}

#[test]
fn half_float_grids_read() {
    let dir = scratch::dir("half");
    let path = dir.join("h.vdb");
    let mut g = block_and_ramp();
    g.save_as_half = true;
    write_float_grids(&path, &[g]).unwrap();
    let data = VdbFile::open(&path)
        .unwrap()
        .read_float_grid("density", ReadOptions::default())
        .unwrap();
    assert!(data.tiles.iter().any(|t| t.value == 0.5));
}
