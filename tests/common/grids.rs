//! Synthetic grids shared by the volume tests.
use brume::volume::check::SplitMix64;
use brume::volume::{dense_to_vdb, synthetic_info, ConversionPolicy, SparseGrid};
use brume_ffi::{FloatGridData, Leaf, Tile};

/// A smooth blob with noise and exact zeros on a block that is not leaf-aligned.
pub fn blob() -> FloatGridData {
    let dims = [37, 29, 45];
    let origin = [-13, 5, -20];
    let mut rng = SplitMix64(7);
    let mut values = Vec::with_capacity(dims[0] * dims[1] * dims[2]);
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let q = [
                    x as f64 / dims[0] as f64,
                    y as f64 / dims[1] as f64,
                    z as f64 / dims[2] as f64,
                ];
                let r2: f64 = q.iter().map(|c| (c - 0.5) * (c - 0.5)).sum();
                let v = (1.0 - 4.0 * r2).max(0.0) * 3.0
                    + if r2 < 0.2 { 0.5 * rng.uniform() } else { 0.0 };
                values.push(v as f32);
            }
        }
    }
    dense_to_vdb(dims, origin, &values, 0.0).unwrap()
}

/// A small dense block next to two 128^3 tiles (one active, one inactive but non-background).
pub fn with_tiles() -> FloatGridData {
    let mut rng = SplitMix64(11);
    let dims = [20, 20, 20];
    let values: Vec<f32> = (0..8000).map(|_| rng.uniform() as f32 * 5.0).collect();
    let mut data = dense_to_vdb(dims, [120, 4, 4], &values, 0.0).unwrap();
    data.tiles.push(Tile {
        origin: [0, 0, 0],
        dim: 128,
        value: 2.5,
        active: true,
    });
    data.tiles.push(Tile {
        origin: [128, -128, 0],
        dim: 128,
        value: 0.75,
        active: false,
    });
    // A tile equal to the background needs no cells.
    data.tiles.push(Tile {
        origin: [-128, -128, -128],
        dim: 128,
        value: 0.0,
        active: false,
    });
    data
}

/// Scattered leaves with a non-zero background: random, uniform and background-valued leaves,
/// inactive voxels holding values too.
pub fn sparse_with_background() -> FloatGridData {
    let mut rng = SplitMix64(23);
    let background = 0.25;
    let mut leaves = Vec::new();
    let mut origins = std::collections::HashSet::new();
    while origins.len() < 60 {
        origins.insert([0, 1, 2].map(|_| (rng.below(12) as i32 - 6) * 8));
    }
    let mut origins: Vec<[i32; 3]> = origins.into_iter().collect();
    origins.sort();
    for origin in origins {
        let kind = rng.below(4);
        let mut values = Box::new([0.0f32; 512]);
        let level = rng.uniform() as f32 * 4.0;
        for v in values.iter_mut() {
            *v = match kind {
                0 => level,
                1 => background,
                _ => {
                    if rng.below(5) == 0 {
                        0.0
                    } else {
                        rng.uniform() as f32 * 4.0
                    }
                }
            };
        }
        let active = [0, 1, 2, 3, 4, 5, 6, 7].map(|_| rng.next_u64());
        leaves.push(Leaf {
            origin,
            values,
            active,
        });
    }
    let mut info = synthetic_info("sparse");
    info.background = Some(background as f64);
    FloatGridData {
        info,
        background,
        leaves,
        tiles: Vec::new(),
    }
}

/// A single non-zero voxel: the sharpest possible feature.
pub fn single_voxel() -> FloatGridData {
    dense_to_vdb([1, 1, 1], [8, -1, 0], &[7.0], 0.0).unwrap()
}

/// A noisy block far from the index origin, where f32 ray arithmetic has ulps of 1/64 voxel.
pub fn far_from_origin() -> FloatGridData {
    let mut rng = SplitMix64(31);
    let values: Vec<f32> = (0..20 * 12 * 9).map(|_| rng.uniform() as f32).collect();
    dense_to_vdb(
        [20, 12, 9],
        [1 << 19, -(1 << 18) + 3, 123_456],
        &values,
        0.0,
    )
    .unwrap()
}

pub fn empty() -> FloatGridData {
    FloatGridData {
        info: synthetic_info("empty"),
        background: 0.0,
        leaves: Vec::new(),
        tiles: Vec::new(),
    }
}

pub fn all_grids() -> Vec<(&'static str, FloatGridData)> {
    vec![
        ("blob", blob()),
        ("with_tiles", with_tiles()),
        ("sparse_with_background", sparse_with_background()),
        ("single_voxel", single_voxel()),
        ("far_from_origin", far_from_origin()),
        ("empty", empty()),
    ]
}

pub fn convert(data: &FloatGridData) -> SparseGrid {
    SparseGrid::from_vdb(data, ConversionPolicy::default())
        .unwrap()
        .0
}
