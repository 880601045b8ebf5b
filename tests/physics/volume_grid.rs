//! SparseGrid conversion and lookups against the brute-force reference, the bad-value policy
//! and the bounds' own validation.
use crate::common;

use brume::math::DVec3;
use brume::volume::check::check_lookups;
use brume::volume::{
    dense_to_vdb, synthetic_info, ConversionPolicy, LeafBounds, SparseGrid, VolumeError,
    CONSTANT_BIT,
};
use brume_ffi::{FloatGridData, Leaf, Tile};

#[test]
fn lookups_match_reference_on_every_synthetic_grid() {
    for (name, data) in common::all_grids() {
        let grid = common::convert(&data);
        let stats =
            check_lookups(&grid, &data, 60_000, 0x5eed).unwrap_or_else(|e| panic!("{name}: {e}"));
        // Brume mirrors OpenVDB's arithmetic, so agreement is exact, not just within 1e-6.
        assert_eq!(stats.exact, stats.points, "{name}: {stats:?}");
    }
}

#[test]
fn bricks_are_transposed_from_openvdb_leaf_order() {
    let mut values = Box::new([0.0f32; 512]);
    for (offset, v) in values.iter_mut().enumerate() {
        *v = offset as f32;
    }
    let data = FloatGridData {
        info: synthetic_info("order"),
        background: 0.0,
        leaves: vec![Leaf {
            origin: [-8, 16, 0],
            values,
            active: [0; 8],
        }],
        tiles: vec![],
    };
    let grid = common::convert(&data);
    for (x, y, z) in [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (7, 3, 5)] {
        let want = Leaf::offset(x, y, z) as f32;
        assert_eq!(grid.voxel(-8 + x as i32, 16 + y as i32, z as i32), want);
    }
    // The brick itself is in Brume order, x fastest.
    assert_eq!(grid.bricks[1], Leaf::offset(1, 0, 0) as f32);
    assert_eq!(grid.bricks[8], Leaf::offset(0, 1, 0) as f32);
    assert_eq!(grid.bricks[64], Leaf::offset(0, 0, 1) as f32);
}

#[test]
fn trilinear_blends_z_then_y_then_x_like_openvdb() {
    // Corner values 1..8 at the eight voxels around (0.25, 0.5, 0.75).
    let values: Vec<f32> = (1..=8).map(|v| v as f32).collect();
    let (grid, _) = SparseGrid::from_dense([2, 2, 2], [0, 0, 0], &values, 0.0).unwrap();
    let f = DVec3::new(0.25, 0.5, 0.75);
    let v = |x: usize, y: usize, z: usize| values[x + 2 * y + 4 * z];
    let lerp = |a: f32, b: f32, w: f64| a + ((b - a) as f64 * w) as f32;
    let a = lerp(
        lerp(v(0, 0, 0), v(0, 0, 1), f.z),
        lerp(v(0, 1, 0), v(0, 1, 1), f.z),
        f.y,
    );
    let b = lerp(
        lerp(v(1, 0, 0), v(1, 0, 1), f.z),
        lerp(v(1, 1, 0), v(1, 1, 1), f.z),
        f.y,
    );
    assert_eq!(grid.sample_trilinear(f), lerp(a, b, f.x));
    // The exact trilinear value for this linear field is 1 + x + 2y + 4z.
    assert!((grid.sample_trilinear(f) - (1.0 + 0.25 + 1.0 + 3.0)).abs() < 1e-6);
    // Nearest rounds half up: 0.5 goes to voxel 1.
    assert_eq!(grid.sample_nearest(DVec3::new(0.49, 0.5, 0.0)), v(0, 1, 0));
    // Outside the box and at NaN: the background.
    assert_eq!(grid.sample_trilinear(DVec3::new(1e9, 0.0, 0.0)), 0.0);
    assert_eq!(grid.sample_trilinear(DVec3::new(f64::NAN, 0.0, 0.0)), 0.0);
    assert_eq!(
        grid.sample_nearest(DVec3::new(0.0, f64::NEG_INFINITY, 0.0)),
        0.0
    );
}

#[test]
fn uniform_leaves_and_tiles_become_constant_cells() {
    let mut data = dense_to_vdb([8, 8, 8], [0, 0, 0], &[1.5; 512], 0.0).unwrap();
    data.tiles.push(Tile {
        origin: [128, 0, 0],
        dim: 128,
        value: 1.5,
        active: true,
    });
    let (grid, report) = SparseGrid::from_vdb(&data, ConversionPolicy::default()).unwrap();
    assert_eq!(grid.brick_count(), 0);
    assert_eq!(report.uniform_leaves, 1);
    // Background and one shared constant.
    assert_eq!(grid.constants, vec![0.0, 1.5]);
    let tile_cells = grid
        .cells
        .iter()
        .filter(|&&e| e == (CONSTANT_BIT | 1))
        .count();
    assert_eq!(tile_cells, 16 * 16 * 16 + 1);
    // The box spans the leaf and the tile, padded by a cell: x cells -1..33, y and z -1..17.
    assert_eq!(grid.cell_origin, [-1, -1, -1]);
    assert_eq!(grid.dims, [34, 18, 18]);
    let stats = grid.stats();
    assert_eq!(stats.brick_bytes, 0);
    assert_eq!(stats.cell_bytes, 4 * 34 * 18 * 18);
    assert!((stats.constant_fraction - 1.0).abs() < 1e-12);
    assert!(stats.empty_fraction > 0.0 && stats.empty_fraction < 1.0);
}

#[test]
fn nan_and_inf_are_rejected_with_count_and_first_index() {
    let mut values = vec![1.0f32; 27];
    values[1] = f32::NAN; // voxel (1, 0, 0) of a block at (4, 5, 6)
    values[26] = f32::INFINITY;
    let data = dense_to_vdb([3, 3, 3], [4, 5, 6], &values, 0.0).unwrap();
    let err = SparseGrid::from_vdb(&data, ConversionPolicy::default()).unwrap_err();
    match &err {
        VolumeError::NonFinite { count, first, .. } => {
            assert_eq!(*count, 2);
            assert_eq!(*first, [5, 5, 6]);
        }
        other => panic!("unexpected error {other:?}"),
    }
    let message = err.to_string();
    assert!(
        message.contains('2') && message.contains("[5, 5, 6]"),
        "{message}"
    );

    let mut data = common::empty();
    data.tiles.push(Tile {
        origin: [0, 0, 0],
        dim: 128,
        value: f32::NEG_INFINITY,
        active: true,
    });
    assert!(matches!(
        SparseGrid::from_vdb(&data, ConversionPolicy::default()),
        Err(VolumeError::NonFinite {
            count: 1,
            first: [0, 0, 0],
            ..
        })
    ));
}

#[test]
fn negatives_are_clamped_to_zero_with_a_warning() {
    let mut values = vec![1.0f32; 8];
    values[3] = -0.5;
    values[5] = -2.0;
    let mut data = dense_to_vdb([2, 2, 2], [0, 0, 0], &values, 0.0).unwrap();
    data.tiles.push(Tile {
        origin: [8, 0, 0],
        dim: 8,
        value: -1.0,
        active: true,
    });
    let (grid, report) = SparseGrid::from_vdb(&data, ConversionPolicy::default()).unwrap();
    assert_eq!(report.negative_voxels, 2);
    assert_eq!(report.negative_tiles, 1);
    assert_eq!(report.most_negative, -2.0);
    // "First" follows OpenVDB's leaf order (z fastest): (1, 0, 1) comes before (1, 1, 0).
    assert_eq!(report.first_negative, Some([1, 0, 1]));
    assert_eq!(report.warnings.len(), 1, "{:?}", report.warnings);
    assert!(report.warnings[0].contains("clamped"));
    assert_eq!(grid.voxel(1, 1, 0), 0.0);
    assert_eq!(grid.voxel(9, 0, 0), 0.0);
    assert!(grid
        .bricks
        .iter()
        .chain(grid.constants.iter())
        .all(|&v| v >= 0.0));
}

#[test]
fn oversized_index_is_refused_with_counts() {
    let mut data = common::empty();
    // A root-level tile: 512^3 cells before padding.
    data.tiles.push(Tile {
        origin: [0, 0, 0],
        dim: 4096,
        value: 1.0,
        active: true,
    });
    let err = SparseGrid::from_vdb(&data, ConversionPolicy::default()).unwrap_err();
    let VolumeError::TooManyCells { cells, limit, .. } = err else {
        panic!("unexpected {err:?}")
    };
    assert_eq!(cells, 514u64.pow(3));
    assert_eq!(limit, 1 << 26);
    assert!(
        err.to_string().contains(&cells.to_string())
            && err.to_string().contains(&limit.to_string())
    );
    // A tighter policy refuses smaller grids too.
    let small = ConversionPolicy { max_cells: 100 };
    assert!(matches!(
        SparseGrid::from_vdb(&common::blob(), small),
        Err(VolumeError::TooManyCells { .. })
    ));
}

#[test]
fn transforms_are_kept_and_world_bounds_follow_them() {
    let mut data = common::single_voxel();
    // Half-unit voxels, translated; rows of a column-vector matrix.
    data.info.world_from_index = [
        [0.5, 0.0, 0.0, 10.0],
        [0.0, 0.5, 0.0, -2.0],
        [0.0, 0.0, 0.5, 1.0],
        [0.0, 0.0, 0.0, 1.0],
    ];
    data.info.voxel_size = [0.5; 3];
    let grid = common::convert(&data);
    let index = grid.index_bounds();
    let world = grid.world_bounds();
    assert_eq!(
        world.min,
        index.min * 0.5 + brume::math::Vec3::new(10.0, -2.0, 1.0)
    );
    assert_eq!(
        world.max,
        index.max * 0.5 + brume::math::Vec3::new(10.0, -2.0, 1.0)
    );
    let p = DVec3::new(3.0, 4.0, 5.0);
    let round_trip = grid
        .index_from_world
        .transform_point3(grid.world_from_index.transform_point3(p));
    assert!((round_trip - p).length() < 1e-12);

    // OpenVDB's own row-vector layout (translation in the last row) is refused, not guessed.
    data.info.world_from_index = [
        [0.5, 0.0, 0.0, 0.0],
        [0.0, 0.5, 0.0, 0.0],
        [0.0, 0.0, 0.5, 0.0],
        [10.0, -2.0, 1.0, 1.0],
    ];
    assert!(matches!(
        SparseGrid::from_vdb(&data, ConversionPolicy::default()),
        Err(VolumeError::Transform(_))
    ));
    data.info.world_from_index = [[0.0; 4], [0.0; 4], [0.0; 4], [0.0, 0.0, 0.0, 1.0]];
    assert!(matches!(
        SparseGrid::from_vdb(&data, ConversionPolicy::default()),
        Err(VolumeError::Transform(_))
    ));
}

#[test]
fn bounds_validate_on_every_synthetic_grid() {
    for (name, data) in common::all_grids() {
        let grid = common::convert(&data);
        let bounds = LeafBounds::build(&grid);
        bounds
            .validate(&grid, usize::MAX)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let stats = bounds.stats();
        assert!(stats.global_min <= stats.global_max, "{name}: {stats:?}");
        assert!(
            (0.0..=1.0).contains(&stats.mean_max_over_global),
            "{name}: {stats:?}"
        );
    }
}

#[test]
fn bounds_include_the_apron_and_the_padding() {
    let grid = common::convert(&common::single_voxel());
    let bounds = LeafBounds::build(&grid);
    // The voxel (8, -1, 0) lies in cell (1, -1, 0); its apron reaches cells whose blocks
    // [8c - 1, 8c + 9] contain it: c.x in {0, 1}, c.y in {-1, 0}, c.z in {-1, 0}.
    let mut hot = Vec::new();
    for z in 0..bounds.dims[2] {
        for y in 0..bounds.dims[1] {
            for x in 0..bounds.dims[0] {
                if bounds.get(x, y, z).max > 0.0 {
                    let o = bounds.cell_origin;
                    hot.push([x as i32 + o[0], y as i32 + o[1], z as i32 + o[2]]);
                }
            }
        }
    }
    hot.sort();
    let want: Vec<[i32; 3]> = (0..8)
        .map(|n| [n >> 2, (n >> 1 & 1) - 1, (n & 1) - 1])
        .collect();
    assert_eq!(hot, want);
    assert_eq!(
        bounds.global,
        brume::volume::CellBounds { min: 0.0, max: 7.0 }
    );
    let stats = bounds.stats();
    assert!(
        (stats.empty_fraction - (1.0 - 8.0 / 27.0)).abs() < 1e-12,
        "{stats:?}"
    );
}

#[test]
fn validate_catches_a_wrong_bound() {
    let grid = common::convert(&common::blob());
    let mut bounds = LeafBounds::build(&grid);
    let hot = bounds.cells.iter().position(|b| b.max > 0.0).unwrap();
    bounds.cells[hot].max *= 0.5;
    bounds.global = bounds
        .cells
        .iter()
        .copied()
        .fold(brume::volume::CellBounds::EMPTY, |a, b| a.union(b));
    assert!(bounds.validate(&grid, usize::MAX).is_err());
}

#[test]
fn batch_lookups_equal_single_lookups() {
    let grid = common::convert(&common::blob());
    let points: Vec<[f64; 3]> = (0..1000)
        .map(|n| [n as f64 * 0.037 - 14.0, 17.3, n as f64 * 0.05 - 21.0])
        .collect();
    let mut tri = vec![0.0; points.len()];
    let mut near = vec![0.0; points.len()];
    grid.sample_trilinear_batch(&points, &mut tri);
    grid.sample_nearest_batch(&points, &mut near);
    for (n, p) in points.iter().enumerate() {
        assert_eq!(tri[n], grid.sample_trilinear(DVec3::from_array(*p)));
        assert_eq!(near[n], grid.sample_nearest(DVec3::from_array(*p)));
    }
}

/// Throughput of the lookups and of the bounds build on a 128^3 grid, printed for the record:
/// `cargo test --release --test physics volume_grid:: -- --ignored --nocapture`.
#[test]
#[ignore]
fn lookup_and_bounds_throughput() {
    use brume::volume::check::SplitMix64;
    use std::time::Instant;
    let n = 128;
    let mut rng = SplitMix64(99);
    let values: Vec<f32> = (0..n * n * n).map(|_| rng.uniform() as f32).collect();
    let data = dense_to_vdb([n, n, n], [0, 0, 0], &values, 0.0).unwrap();
    let grid = common::convert(&data);
    let start = Instant::now();
    let bounds = LeafBounds::build(&grid);
    println!(
        "bounds build: {:?} for {} cells",
        start.elapsed(),
        bounds.cells.len()
    );
    let points: Vec<[f64; 3]> = (0..2_000_000)
        .map(|_| [0, 1, 2].map(|_| rng.range(-2.0, n as f64 + 2.0)))
        .collect();
    // Coherent points, as along a ray: cache misses no longer dominate.
    let coherent: Vec<[f64; 3]> = (0..2_000_000)
        .map(|k| {
            [
                (k % 1_000_000) as f64 * 1.1e-4 + 3.3,
                40.7 + (k / 1_000_000) as f64,
                61.2,
            ]
        })
        .collect();
    let mut out = vec![0.0; points.len()];
    let start = Instant::now();
    grid.sample_trilinear_batch(&coherent, &mut out);
    let ns = start.elapsed().as_nanos() as f64 / coherent.len() as f64;
    println!(
        "coherent trilinear: {ns:.1} ns per lookup (checksum {})",
        out.iter().sum::<f32>()
    );
    for (name, f) in [
        (
            "trilinear",
            SparseGrid::sample_trilinear_batch as fn(&SparseGrid, &[[f64; 3]], &mut [f32]),
        ),
        ("nearest", SparseGrid::sample_nearest_batch),
    ] {
        let start = Instant::now();
        f(&grid, &points, &mut out);
        let ns = start.elapsed().as_nanos() as f64 / points.len() as f64;
        println!(
            "{name}: {ns:.1} ns per lookup (checksum {})",
            out.iter().sum::<f32>()
        );
    }
    let reference = brume::volume::VdbReference::new(&data);
    let start = Instant::now();
    let sum: f32 = points[..200_000]
        .iter()
        .map(|p| reference.sample_trilinear(DVec3::from_array(*p)))
        .sum();
    let ns = start.elapsed().as_nanos() as f64 / 200_000.0;
    println!("reference trilinear: {ns:.1} ns per lookup (checksum {sum})");
}
