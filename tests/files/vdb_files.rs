//! Brume's layout against OpenVDB itself, on every example grid and on bad files.
use crate::common::scratch;

use std::path::{Path, PathBuf};
use std::process::Command;

use brume::volume::check::{check_ray_bounds, SplitMix64};
use brume::volume::{load_grid, ConversionPolicy, LoadError, LoadedGrid};
use brume_ffi::{write_float_grids, GridClass, GridSpec, ReadOptions, SampleOrder, VdbFile};
use glam::DVec3;

const EXAMPLE_GRIDS: [&str; 8] = [
    "cloud",
    "smoke",
    "fire",
    "sphere_fog",
    "dodeca_fog",
    "tiles",
    "plume",
    "icosa_fog",
];

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes/vdb")
        .join(format!("{name}.vdb"))
}

fn load(path: &Path, grid: &str) -> LoadedGrid {
    load_grid(path, grid, ConversionPolicy::default()).unwrap_or_else(|e| panic!("{e}"))
}

/// Points spread over the active box and a margin outside it, plus points inside every tile
/// and on voxel centres, where the two samplers are most likely to disagree.
fn probe_points(
    loaded: &LoadedGrid,
    tiles: &[brume_ffi::Tile],
    n: usize,
    seed: u64,
) -> Vec<[f64; 3]> {
    let mut rng = SplitMix64(seed);
    let b = loaded.grid.index_bounds();
    let (lo, hi) = (b.min.as_dvec3() - 20.0, b.max.as_dvec3() + 20.0);
    let mut pts = Vec::with_capacity(n);
    while pts.len() < n {
        let k = pts.len() % 4;
        let p = if k == 3 && !tiles.is_empty() {
            let t = tiles[rng.below(tiles.len() as u64) as usize];
            let o = DVec3::from(t.origin.map(f64::from));
            o + DVec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * (t.dim as f64 + 2.0) - 1.0
        } else {
            DVec3::new(
                rng.range(lo.x, hi.x),
                rng.range(lo.y, hi.y),
                rng.range(lo.z, hi.z),
            )
        };
        // Every other point on a voxel centre or half-way between centres.
        let p = if k == 1 { (p * 2.0).round() * 0.5 } else { p };
        pts.push(p.to_array());
    }
    pts
}

#[test]
fn lookups_match_openvdb_samplers_on_every_example_grid() {
    for name in EXAMPLE_GRIDS {
        let path = example(name);
        let loaded = load(&path, "density");
        let file = VdbFile::open(&path).unwrap();
        let vdb = file
            .open_float_grid(
                "density",
                ReadOptions {
                    level_set_to_fog: true,
                },
            )
            .unwrap();
        let tiles = vdb.read().unwrap().tiles;
        let pts = probe_points(&loaded, &tiles, 200_000, 11);
        for order in [SampleOrder::Nearest, SampleOrder::Trilinear] {
            let expected = vdb.sample(&pts, order).unwrap();
            let mut got = vec![0f32; pts.len()];
            match order {
                SampleOrder::Nearest => loaded.grid.sample_nearest_batch(&pts, &mut got),
                SampleOrder::Trilinear => loaded.grid.sample_trilinear_batch(&pts, &mut got),
            }
            let mut worst = 0f64;
            for (i, (g, e)) in got.iter().zip(&expected).enumerate() {
                let rel = ((g - e).abs() / e.abs().max(f32::MIN_POSITIVE)) as f64;
                assert!(
                    g == e || rel <= 1e-6,
                    "{name} {order:?} at {:?}: brume {g}, OpenVDB {e}",
                    pts[i]
                );
                worst = worst.max(if g == e { 0.0 } else { rel });
            }
            println!(
                "{name:<12} {order:?}: {} points, worst relative difference {worst:e}",
                pts.len()
            );
        }
    }
}

#[test]
fn bounds_hold_along_a_hundred_thousand_rays_per_example_grid() {
    for (i, name) in EXAMPLE_GRIDS.iter().enumerate() {
        let loaded = load(&example(name), "density");
        loaded
            .bounds
            .validate(&loaded.grid, 1 << 16)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let stats = check_ray_bounds(&loaded.grid, &loaded.bounds, 100_000, 1000 + i as u64)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(stats.rays, 100_000);
        // The culled walk's cell bounds were checked wherever culling is sound for the grid.
        let culls = brume::volume::LeafCulling::new(&loaded.bounds).is_some();
        assert_eq!(stats.culled_samples > 0, culls, "{name}: {stats:?}");
        // So were the per-voxel bounds, wherever they are sound and built (a grid of bricks).
        let voxels =
            brume::volume::VoxelCulling::new(&loaded.bounds, &loaded.grid.cells, 1.0).is_some();
        assert_eq!(stats.voxel_samples > 0, voxels, "{name}: {stats:?}");
        println!(
            "{name:<12} {} rays, {} hit, {} segments, {} samples, {} culled-walk samples, {} voxel-culling samples",
            stats.rays,
            stats.rays_hit,
            stats.segments,
            stats.samples,
            stats.culled_samples,
            stats.voxel_samples
        );
    }
}

#[test]
fn a_grid_of_tiles_does_not_read_as_empty() {
    let path = example("tiles");
    let data = VdbFile::open(&path)
        .unwrap()
        .read_float_grid("density", ReadOptions::default())
        .unwrap();
    let big: Vec<_> = data
        .tiles
        .iter()
        .filter(|t| t.active && t.dim >= 128)
        .collect();
    assert_eq!(
        big.len(),
        1,
        "tiles.vdb keeps its 128^3 block as one upper-level tile"
    );
    let loaded = load(&path, "density");
    assert_eq!(
        loaded.grid.sample_trilinear(DVec3::new(64.3, 10.5, 99.9)),
        0.3
    );
    // The vdb_tool fog volumes keep their interior in tiles too.
    let sphere = VdbFile::open(example("sphere_fog"))
        .unwrap()
        .read_float_grid("density", ReadOptions::default())
        .unwrap();
    assert!(
        sphere.tiles.iter().any(|t| t.active && t.value == 1.0),
        "sphere_fog interior tiles"
    );
    let loaded = load(&example("sphere_fog"), "density");
    assert_eq!(loaded.grid.sample_trilinear(DVec3::ZERO), 1.0);
}

fn one_leaf(values: &[f32]) -> GridSpec {
    let mut g = GridSpec::fog("density", 0.1, [0.0; 3]);
    g.prune = false;
    for (i, v) in values.iter().enumerate() {
        g.voxels.push(([i as i32, 0, 0], *v));
    }
    g
}

/// Writers of one path at the same moment (threads here; processes name their temporary files
/// the same way) each put a whole file in place: the file reads back as one of them, and no
/// temporary file is left.
#[test]
fn concurrent_writers_of_one_vdb_path_each_leave_a_whole_file() {
    let dir = scratch::dir("vdb_concurrent_writers");
    let path = dir.join("shared.vdb");
    let values: Vec<Vec<f32>> = (0..8).map(|k| vec![1.0 + k as f32; 8]).collect();
    std::thread::scope(|s| {
        for v in &values {
            let path = &path;
            s.spawn(move || {
                for _ in 0..5 {
                    write_float_grids(path, &[one_leaf(v)]).unwrap_or_else(|e| panic!("{e}"));
                }
            });
        }
    });
    let grid = load(&path, "density");
    let first = grid.grid.voxel(0, 0, 0);
    assert!(
        values.iter().any(|v| v[0] == first),
        "read back {first}, which no writer wrote"
    );
    let left: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n != "shared.vdb")
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

#[test]
fn bad_values_follow_the_load_policy() {
    for (bad, what) in [
        (f32::NAN, "NaN"),
        (f32::INFINITY, "inf"),
        (f32::NEG_INFINITY, "-inf"),
    ] {
        let path = scratch::file(&format!("bad-{what}.vdb"));
        write_float_grids(&path, &[one_leaf(&[0.5, bad, 0.25])]).unwrap();
        let err = load_grid(&path, "density", ConversionPolicy::default())
            .err()
            .expect("non-finite values must be refused");
        let msg = err.to_string();
        assert!(
            msg.contains(&path.display().to_string()) && msg.contains("non-finite"),
            "{msg}"
        );
        assert!(
            msg.contains("[1, 0, 0]"),
            "names the first offending voxel: {msg}"
        );
    }
    let path = scratch::file("negative.vdb");
    write_float_grids(&path, &[one_leaf(&[0.5, -2.0, 0.25])]).unwrap();
    let loaded = load(&path, "density");
    assert_eq!(
        loaded.grid.voxel(1, 0, 0),
        0.0,
        "negative densities clamp to 0"
    );
    assert!(
        loaded
            .warnings
            .iter()
            .any(|w| w.contains("negative") && w.contains(&path.display().to_string())),
        "{:?}",
        loaded.warnings
    );
}

#[test]
fn level_sets_are_converted_with_a_warning() {
    let loaded = load(&example("sphere_ls"), "surface");
    assert_eq!(loaded.info.class, GridClass::LevelSet);
    assert!(
        loaded.warnings.iter().any(|w| w.contains("level set")),
        "{:?}",
        loaded.warnings
    );
    assert_eq!(
        loaded.grid.sample_trilinear(DVec3::ZERO),
        1.0,
        "inside reads as full density"
    );
    assert_eq!(loaded.grid.sample_trilinear(DVec3::splat(200.0)), 0.0);
}

#[test]
fn wrong_grids_give_clear_errors() {
    let path = scratch::file("vec.vdb");
    let mut g = one_leaf(&[1.0, 2.0]);
    g.name = "velocity".into();
    g.as_vec3 = true;
    write_float_grids(&path, &[g]).unwrap();
    let err = load_grid(&path, "velocity", ConversionPolicy::default())
        .err()
        .unwrap();
    assert!(matches!(err, LoadError::Vdb(_)));
    let msg = err.to_string();
    assert!(
        msg.contains(&path.display().to_string())
            && msg.contains("vec3s")
            && msg.contains("not float"),
        "{msg}"
    );
    let msg = load_grid(&path, "density", ConversionPolicy::default())
        .err()
        .unwrap()
        .to_string();
    assert!(
        msg.contains("no grid named 'density'") && msg.contains("'velocity'"),
        "{msg}"
    );
}

/// The CLI on bad input: an error line naming the file, exit status 1, never a panic or abort.
#[test]
fn brume_info_on_bad_files_fails_cleanly() {
    let dir = scratch::file("dir.vdb");
    std::fs::create_dir_all(&dir).unwrap();
    let empty = scratch::file("empty.vdb");
    std::fs::write(&empty, b"").unwrap();
    let garbage = scratch::file("garbage.vdb");
    std::fs::write(
        &garbage,
        (0..10_000u32)
            .map(|i| (i.wrapping_mul(2654435761) >> 13) as u8)
            .collect::<Vec<_>>(),
    )
    .unwrap();
    let truncated = scratch::file("truncated.vdb");
    let bytes = std::fs::read(example("smoke")).unwrap();
    std::fs::write(&truncated, &bytes[..bytes.len() * 2 / 3]).unwrap();
    let missing = scratch::file("missing.vdb");
    for (path, needle) in [
        (missing, "no such file"),
        (dir, "directory"),
        (empty, "empty file"),
        (garbage, ""),
        (truncated, ""),
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_brume"))
            .arg("info")
            .arg(&path)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{}: {stderr}", path.display());
        assert!(
            stderr.starts_with("error: ")
                && stderr.contains(&path.display().to_string())
                && stderr.contains(needle),
            "{stderr}"
        );
        assert!(!stderr.contains("panicked"), "{stderr}");
    }
}

#[test]
fn brume_info_reports_tightness_for_every_example_grid() {
    for name in EXAMPLE_GRIDS {
        let out = Command::new(env!("CARGO_BIN_EXE_brume"))
            .arg("info")
            .arg(example(name))
            .output()
            .unwrap();
        assert!(out.status.success());
        let stdout = String::from_utf8_lossy(&out.stdout);
        let line = stdout
            .lines()
            .find(|l| l.contains("mean leaf majorant / global max"))
            .expect("tightness line");
        let ratio: f64 = line.rsplit('=').next().unwrap().trim().parse().unwrap();
        assert!(ratio > 0.0 && ratio <= 1.0, "{name}: {line}");
        assert!(stdout.contains("empty leaf cells"));
    }
}

/// Files on which OpenVDB 10.0.1's own reader overflows the heap, segfaults or asks for absurd
/// memory (kept in `tests/fuzz/vdb-regressions/`). Read in this process they would abort the
/// test binary; `VdbFile::open` reads them in a child process, so each is a clear error naming
/// the file, and this process goes on.
#[test]
fn files_that_crash_openvdbs_reader_give_clear_errors() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz/vdb-regressions");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    assert!(files.len() >= 10);
    let mut crashed = 0;
    for path in &files {
        let e = match VdbFile::open(path) {
            Ok(_) => panic!("{}: a corrupt file was accepted", path.display()),
            Err(e) => e,
        };
        let msg = e.to_string();
        println!("{msg}");
        assert!(msg.starts_with(&path.display().to_string()), "{msg}");
        if e.kind == brume_ffi::VdbErrorKind::ReaderCrashed {
            assert!(msg.contains("crashed"), "{msg}");
            crashed += 1;
        }
    }
    // Most of them kill the reader (SIGABRT from glibc's heap checks, or SIGSEGV).
    assert!(crashed * 2 > files.len(), "{crashed} of {}", files.len());
    // And the CLI says the same in one line.
    let out = Command::new(env!("CARGO_BIN_EXE_brume"))
        .args(["info", "--no-layout"])
        .arg(dir.join("seed1-151-bloscFromStream-overflow.vdb"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("OpenVDB's reader crashed"), "{err}");
    assert!(
        !err.contains("malloc"),
        "the child's own dying words leak out: {err}"
    );
}

/// A reader that runs past its time limit is killed and reported, not waited on forever.
#[test]
fn a_reader_past_its_time_limit_is_stopped() {
    let out = Command::new(env!("CARGO_BIN_EXE_brume"))
        .args(["info", "--no-layout"])
        .arg(example("cloud"))
        .env("BRUME_VDB_READ_TIMEOUT", "0.000001")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("did not finish within"), "{err}");
    // Trusted and isolated reads see the same grids.
    let a = VdbFile::open(example("fire")).unwrap();
    let b = VdbFile::open_trusted(example("fire")).unwrap();
    assert_eq!(format!("{:?}", a.grids()), format!("{:?}", b.grids()));
    assert_eq!(a.metadata(), b.metadata());
}
