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

/// A velocity-like field with distinct, float-exact components at every voxel.
fn velocity(ijk: [i32; 3]) -> [f32; 3] {
    let [i, j, k] = ijk.map(|c| c as f32);
    [0.25 * i - 1.0, 0.5 * j - 0.125 * k, -0.75 * k + 0.0625 * i]
}

/// A 20^3 block of `velocity` (spanning several leaves) plus a constant leaf far away, which
/// pruning turns into a tile.
fn velocity_grid(name: &str, class: GridClass, double: bool) -> GridSpec {
    let mut g = GridSpec::vec3(name, class, 0.2, [0.5, -1.0, 2.0]);
    g.prune = true;
    let v = g.vectors.as_mut().unwrap();
    v.double = double;
    v.background = [0.0, 0.0, 0.0];
    for i in -4..16 {
        for j in 0..20 {
            for k in -9..11 {
                v.voxels.push(([i, j, k], velocity([i, j, k])));
            }
        }
    }
    for i in 64..72 {
        for j in 0..8 {
            for k in 0..8 {
                v.voxels.push(([i, j, k], [1.5, -2.0, 0.25]));
            }
        }
    }
    g
}

/// The value at voxel `ijk` of a read grid (leaves only).
fn leaf_value(data: &Vec3GridData, ijk: [i32; 3]) -> Option<[f32; 3]> {
    let origin = ijk.map(|c| c & !7);
    let leaf = data.leaves.iter().find(|l| l.origin == origin)?;
    let l = ijk.map(|c| (c & 7) as usize);
    Some(leaf.values[Leaf::offset(l[0], l[1], l[2])])
}

#[test]
fn vec3_grids_read_with_class_leaves_and_tiles() {
    let dir = scratch::dir("vec3");
    let path = dir.join("vel.vdb");
    write_float_grids(
        &path,
        &[
            velocity_grid("vel", GridClass::Staggered, false),
            velocity_grid("vel_centred", GridClass::Unknown, false),
            velocity_grid("vel_double", GridClass::Staggered, true),
        ],
    )
    .unwrap();
    let file = VdbFile::open(&path).unwrap();
    for (name, class, value_type) in [
        ("vel", GridClass::Staggered, "vec3s"),
        ("vel_centred", GridClass::Unknown, "vec3s"),
        ("vel_double", GridClass::Staggered, "vec3d"),
    ] {
        let data = file.read_vec3_grid(name).unwrap();
        assert_eq!(data.info.class, class, "{name}");
        assert_eq!(data.info.value_type, value_type, "{name}");
        assert_eq!(data.background, [0.0; 3]);
        for ijk in [[-4, 0, -9], [0, 0, 0], [15, 19, 10], [7, 8, 9]] {
            assert_eq!(
                leaf_value(&data, ijk),
                Some(velocity(ijk)),
                "{name} {ijk:?}"
            );
        }
        // The pruned leaf: one active 8^3 tile, as the file info counts it.
        assert_eq!(data.tiles.len(), 1, "{name}");
        assert_eq!(data.tiles[0].value, [1.5, -2.0, 0.25]);
        assert_eq!((data.tiles[0].dim, data.tiles[0].active), (8, true));
        assert_eq!(data.info.tile_count, 1);
        assert_eq!(data.leaves.len() as u64, data.info.leaf_count);
    }
}

#[test]
fn vec3_samplers_are_openvdb_own() {
    let dir = scratch::dir("vec3-samplers");
    let path = dir.join("vel.vdb");
    write_float_grids(&path, &[velocity_grid("vel", GridClass::Staggered, false)]).unwrap();
    let grid = VdbFile::open(&path).unwrap().open_vec3_grid("vel").unwrap();
    assert_eq!(
        Vec3Sampler::trilinear_for(GridClass::Staggered),
        Vec3Sampler::StaggeredBox
    );
    // At voxel centres the box and point samplers return the voxel; the staggered box sampler
    // reads component a at p + 0.5 e_a, so at p = ijk - 0.5 e_a its component a is voxel ijk's.
    let ijk = [3, 5, -2];
    let p = ijk.map(|c| c as f64);
    let v = velocity(ijk);
    let centred = grid.sample(&[p], Vec3Sampler::Box).unwrap()[0];
    assert_eq!(centred, v);
    assert_eq!(grid.sample(&[p], Vec3Sampler::Point).unwrap()[0], v);
    for a in 0..3 {
        let mut q = p;
        q[a] -= 0.5;
        let s = grid.sample(&[q], Vec3Sampler::StaggeredBox).unwrap()[0];
        assert_eq!(s[a], v[a], "component {a}");
    }
    // Halfway between voxel centres along x, the x component of the staggered sampler is a
    // voxel value and the cell-centred one is the mean of two.
    let q = [3.5, 5.0, -2.0];
    let s = grid.sample(&[q], Vec3Sampler::StaggeredBox).unwrap()[0];
    assert_eq!(s[0], velocity([4, 5, -2])[0]);
    let b = grid.sample(&[q], Vec3Sampler::Box).unwrap()[0];
    assert_eq!(
        b[0],
        0.5 * (velocity([3, 5, -2])[0] + velocity([4, 5, -2])[0])
    );
}

#[test]
fn vec3_half_storage_rounds_to_half() {
    let dir = scratch::dir("vec3-half");
    let path = dir.join("vel.vdb");
    let mut g = velocity_grid("vel", GridClass::Unknown, false);
    g.save_as_half = true;
    g.vectors.as_mut().unwrap().voxels[0].1 = [1.0 / 3.0, 1e-3, 1000.1];
    write_float_grids(&path, &[g]).unwrap();
    let data = VdbFile::open(&path).unwrap().read_vec3_grid("vel").unwrap();
    // The nearest halves (10-bit mantissas): 1365 / 2^12, 1049 / 2^20 and 1000.
    assert_eq!(
        leaf_value(&data, [-4, 0, -9]),
        Some([1365.0 / 4096.0, 1049.0 / 1048576.0, 1000.0])
    );
    assert_eq!(leaf_value(&data, [0, 0, 0]), Some(velocity([0, 0, 0])));
}

#[test]
fn vec3_open_names_what_is_wrong() {
    let dir = scratch::dir("vec3-errors");
    let path = dir.join("mixed.vdb");
    write_float_grids(
        &path,
        &[
            block_and_ramp(),
            velocity_grid("vel", GridClass::Staggered, false),
        ],
    )
    .unwrap();
    let file = VdbFile::open(&path).unwrap();
    let err = file.open_vec3_grid("density").err().unwrap();
    assert_eq!(err.kind, VdbErrorKind::Type);
    let msg = err.to_string();
    assert!(
        msg.contains(&path.display().to_string())
            && msg.contains("'density' is a float grid")
            && msg.contains("'density' (float), 'vel' (vec3s)"),
        "{msg}"
    );
    let err = file.open_vec3_grid("velocity").err().unwrap();
    assert_eq!(err.kind, VdbErrorKind::NotFound);
    let msg = err.to_string();
    assert!(
        msg.contains("no grid named 'velocity'")
            && msg.contains("'density' (float), 'vel' (vec3s)"),
        "{msg}"
    );
}
