//! Vec3 (velocity) grids: Brume's vector lookups against OpenVDB's own samplers on written
//! fixtures (cell-centred and staggered, float and half storage, vec3d), the per-cell speed
//! bounds against lookups inside each cell, and the load errors.
use crate::common::scratch;

use std::path::{Path, PathBuf};

use brume::volume::check::SplitMix64;
use brume::volume::{load_vector_grid_from, ConversionPolicy, LoadError, VectorGrid};
use brume_ffi::{write_float_grids, GridClass, GridSpec, VdbFile, Vec3Sampler};
use glam::DVec3;

/// A swirling velocity with non-representable, signed components at every voxel.
fn velocity(ijk: [i32; 3]) -> [f32; 3] {
    let [i, j, k] = ijk.map(|c| c as f64);
    [
        (2.0 * (0.31 * j).sin() + 0.013 * k) as f32,
        ((0.23 * i).cos() - 0.5 + 0.07 * (0.5 * k).sin()) as f32,
        (0.11 * (i - j) * (0.17 * k).cos()) as f32,
    ]
}

/// The fixture grids: name, class, vec3d values, half storage.
const GRIDS: [(&str, GridClass, bool, bool); 5] = [
    ("vel", GridClass::Staggered, false, false),
    ("vel_centred", GridClass::Unknown, false, false),
    ("vel_half", GridClass::Staggered, false, true),
    ("vel_centred_half", GridClass::Unknown, false, true),
    ("vel_double", GridClass::Staggered, true, false),
];

/// A 32 x 26 x 24 block of `velocity` starting at negative coordinates (so leaves are partly
/// filled and their inactive voxels hold the background), a constant leaf that pruning makes
/// a tile, and a non-zero background.
fn velocity_spec(name: &str, class: GridClass, double: bool, half: bool) -> GridSpec {
    let mut g = GridSpec::vec3(name, class, 0.05, [0.3, -0.2, 1.0]);
    g.prune = true;
    g.save_as_half = half;
    let v = g.vectors.as_mut().unwrap();
    v.double = double;
    v.background = [0.25, -0.125, 0.0];
    for i in -13..19 {
        for j in -5..21 {
            for k in 0..24 {
                v.voxels.push(([i, j, k], velocity([i, j, k])));
            }
        }
    }
    for i in 32..40 {
        for j in 0..8 {
            for k in 0..8 {
                v.voxels.push(([i, j, k], [-3.0, 1.5, 0.75]));
            }
        }
    }
    g
}

/// The fixture file: every grid of [`GRIDS`] plus a float `density`.
fn fixture(dir: &str) -> PathBuf {
    let path = scratch::dir(dir).join("fluid.vdb");
    let mut grids: Vec<GridSpec> = GRIDS
        .iter()
        .map(|&(name, class, double, half)| velocity_spec(name, class, double, half))
        .collect();
    let mut density = GridSpec::fog("density", 0.05, [0.3, -0.2, 1.0]);
    density.voxels.push(([0, 0, 0], 1.0));
    grids.push(density);
    write_float_grids(&path, &grids).unwrap();
    path
}

fn load(path: &Path, name: &str) -> VectorGrid {
    try_load(path, name).unwrap_or_else(|e| panic!("{e}"))
}

fn try_load(path: &Path, name: &str) -> Result<VectorGrid, LoadError> {
    let file = VdbFile::open(path).unwrap();
    load_vector_grid_from(&file, name, ConversionPolicy::default())
}

/// Points over the data with a margin outside it; every fourth on a voxel centre or half-way
/// between centres, every fourth just below a leaf cell's upper faces (where a staggered
/// lookup reads furthest into the next cell).
fn probe_points(n: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut rng = SplitMix64(seed);
    let (lo, hi) = (DVec3::new(-16.0, -8.0, -3.0), DVec3::new(42.0, 24.0, 27.0));
    (0..n)
        .map(|i| {
            let p = DVec3::new(
                rng.range(lo.x, hi.x),
                rng.range(lo.y, hi.y),
                rng.range(lo.z, hi.z),
            );
            match i % 4 {
                1 => ((p * 2.0).round() * 0.5).to_array(),
                2 => {
                    ((p / 8.0).floor() * 8.0 + 7.5 + DVec3::splat(0.49) * rng.uniform()).to_array()
                }
                _ => p.to_array(),
            }
        })
        .collect()
}

#[test]
fn vector_lookups_match_openvdb_box_and_staggered_box_samplers() {
    let path = fixture("vectors-samplers");
    let file = VdbFile::open(&path).unwrap();
    let pts = probe_points(200_000, 17);
    for (name, class, _, _) in GRIDS {
        let grid = load(&path, name);
        assert_eq!(grid.staggered, class == GridClass::Staggered, "{name}");
        let sampler = Vec3Sampler::trilinear_for(class);
        let expected = file
            .open_vec3_grid(name)
            .unwrap()
            .sample(&pts, sampler)
            .unwrap();
        let (mut worst, mut in_data) = (0f64, 0usize);
        for (p, e) in pts.iter().zip(&expected) {
            let g = grid.sample(DVec3::from_array(*p)).to_array();
            for a in 0..3 {
                let d = (g[a] - e[a] as f64).abs();
                worst = worst.max(d);
                assert!(d == 0.0, "{name} at {p:?}: brume {g:?}, OpenVDB {e:?}");
            }
            in_data += (*e != grid.background) as usize;
        }
        println!(
            "{name:<17} {sampler:?}: {} points ({in_data} off the background), max |brume - OpenVDB| {worst:e}",
            pts.len()
        );
        assert!(
            in_data > pts.len() / 4,
            "{name}: the points must reach the data"
        );
    }
}

#[test]
fn staggered_and_cell_centred_differ_where_openvdb_says() {
    // The same values read as staggered and as cell-centred agree at no generic point, and the
    // staggered x component at ijk - 0.5 e_x is voxel ijk's x.
    let path = fixture("vectors-class");
    let (staggered, centred) = (load(&path, "vel"), load(&path, "vel_centred"));
    let ijk = [3, 4, 5];
    let v = velocity(ijk);
    assert_eq!(staggered.voxel(3, 4, 5), v);
    let p = DVec3::new(3.0, 4.0, 5.0);
    assert_eq!(centred.sample(p), DVec3::from(v.map(f64::from)));
    assert_eq!(staggered.sample(p - DVec3::X * 0.5).x, v[0] as f64);
    assert_eq!(staggered.sample(p - DVec3::Y * 0.5).y, v[1] as f64);
    assert_eq!(staggered.sample(p - DVec3::Z * 0.5).z, v[2] as f64);
    assert_ne!(staggered.sample(p), centred.sample(p));
}

#[test]
fn speed_bounds_hold_inside_every_cell() {
    let path = fixture("vectors-speed");
    let pts = probe_points(200_000, 23);
    for (name, _, _, _) in GRIDS {
        let grid = load(&path, name);
        let (mut worst_ratio, mut ratio_sum, mut bounded) = (0f64, 0f64, 0usize);
        for p in &pts {
            let p = DVec3::from_array(*p);
            let v = grid.sample(p);
            let bound = grid.speed.speed_at(p) as f64;
            assert!(
                v.length() <= bound,
                "{name} at {p}: |v| {} > bound {bound}",
                v.length()
            );
            if let Some(cell) = grid.speed.cell_at(p) {
                let m = grid.speed.component_max[cell];
                assert!(
                    (0..3).all(|a| v[a].abs() <= m[a] as f64),
                    "{name} at {p}: {v} vs {m:?}"
                );
            }
            if bound > 0.0 {
                worst_ratio = worst_ratio.max(v.length() / bound);
                ratio_sum += v.length() / bound;
                bounded += 1;
            }
        }
        let max = grid.speed.max_speed();
        println!(
            "{name:<17} {} points: |v| <= cell bound everywhere, |v| / bound max {worst_ratio:.6} mean {:.3}, max speed {max} ({:.3} voxels per unit time)",
            pts.len(),
            ratio_sum / bounded as f64,
            grid.max_index_speed()
        );
        // Voxel size 0.05 on every axis: the index speed bound is 20 times the speed bound.
        let ratio = grid.max_index_speed() / (20.0 * max as f64);
        assert!((ratio - 1.0).abs() < 1e-5, "{name}: {ratio}");
        assert!(
            worst_ratio > 0.5,
            "{name}: the bounds should be near the values somewhere"
        );
    }
}

#[test]
fn vector_load_errors_name_the_file_the_grid_and_the_grids_there() {
    let path = fixture("vectors-errors");
    let listing = "'vel' (vec3s), 'vel_centred' (vec3s), 'vel_half' (vec3s), \
                   'vel_centred_half' (vec3s), 'vel_double' (vec3d), 'density' (float)";
    let file_name = path.display().to_string();

    let err = try_load(&path, "density").err().unwrap();
    let msg = err.to_string();
    assert!(matches!(err, LoadError::Vdb(_)));
    assert!(
        msg.contains(&file_name)
            && msg.contains("grid 'density' is a float grid, not a Vec3 grid")
            && msg.contains(listing),
        "{msg}"
    );

    let msg = try_load(&path, "velocity").err().unwrap().to_string();
    assert!(
        msg.contains(&file_name)
            && msg.contains("no grid named 'velocity'")
            && msg.contains(listing),
        "{msg}"
    );

    let bad = scratch::dir("vectors-nan").join("bad.vdb");
    let mut g = velocity_spec("vel", GridClass::Staggered, false, false);
    let v = g.vectors.as_mut().unwrap();
    v.voxels[10].1[1] = f32::NAN;
    v.voxels[20].1 = [f32::INFINITY, 0.0, f32::NAN];
    write_float_grids(&bad, &[g]).unwrap();
    let err = try_load(&bad, "vel").err().unwrap();
    let msg = err.to_string();
    assert!(matches!(err, LoadError::Volume { .. }));
    assert!(
        msg.contains(&bad.display().to_string())
            && msg.contains("grid 'vel'")
            && msg.contains("3 non-finite value(s) (NaN or Inf)"),
        "{msg}"
    );
    println!("{msg}");
}
