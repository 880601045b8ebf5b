//! The majorant DDA: exact tiling of the walk box overlap and bounds that hold along every ray.
use crate::common;

use brume::math::{Ray, Vec3};
use brume::volume::check::check_ray_bounds;
use brume::volume::{DdaMajorantIterator, LeafBounds, MajorantSegment, SparseGrid};
use proptest::prelude::*;

const RAYS: usize = 100_000;

fn ray_check(name: &str, data: &brume_ffi::FloatGridData, seed: u64) {
    let grid = common::convert(data);
    let bounds = LeafBounds::build(&grid);
    let stats =
        check_ray_bounds(&grid, &bounds, RAYS, seed).unwrap_or_else(|e| panic!("{name}: {e}"));
    assert_eq!(stats.rays, RAYS as u64);
    if !grid.cells.is_empty() {
        // The generator must actually exercise the grid (rays aim at the walk box from a
        // margin around it: a one-voxel grid's small box is hit by about a fifth).
        assert!(stats.rays_hit > RAYS as u64 / 10, "{name}: {stats:?}");
        // And the cells every walk clips away, where the grid has any.
        let (lo, hi) = bounds.walk_box();
        let cell_box = grid.index_bounds();
        if lo != cell_box.min || hi != cell_box.max {
            assert!(stats.clipped_samples > 0, "{name}: {stats:?}");
        }
        assert!(stats.samples > stats.rays_hit, "{name}: {stats:?}");
    }
    // The culled walk's cell bounds were checked wherever culling is sound for the grid.
    let culls = brume::volume::LeafCulling::new(&bounds).is_some();
    assert_eq!(
        stats.culled_samples > 0,
        culls && stats.rays_hit > 0,
        "{name}: {stats:?}"
    );
    // So were the per-voxel bounds, wherever they are sound and built.
    let voxels = brume::volume::VoxelCulling::new(&bounds, &grid.cells, 1.0).is_some();
    assert_eq!(
        stats.voxel_samples > 0,
        voxels && stats.rays_hit > 0,
        "{name}: {stats:?}"
    );
    let tightness = stats.mean_value_over_majorant();
    assert!((0.0..=1.0).contains(&tightness), "{name}: {stats:?}");
}

#[test]
fn rays_respect_bounds_in_blob() {
    ray_check("blob", &common::blob(), 1);
}

#[test]
fn rays_respect_bounds_with_tiles() {
    ray_check("with_tiles", &common::with_tiles(), 2);
}

#[test]
fn rays_respect_bounds_with_nonzero_background() {
    ray_check(
        "sparse_with_background",
        &common::sparse_with_background(),
        3,
    );
}

#[test]
fn rays_respect_bounds_around_a_single_voxel() {
    ray_check("single_voxel", &common::single_voxel(), 4);
}

#[test]
fn rays_respect_bounds_far_from_the_origin() {
    ray_check("far_from_origin", &common::far_from_origin(), 6);
}

#[test]
fn empty_grid_yields_no_segments() {
    ray_check("empty", &common::empty(), 5);
}

/// Many more rays than the suite can afford: `cargo test --release -- --ignored`.
#[test]
#[ignore]
fn stress_many_seeds() {
    for (name, data) in common::all_grids() {
        for seed in 100..140 {
            ray_check(name, &data, seed);
        }
    }
}

/// A 4 x 1 x 1 row of cells with distinct densities, x from 0 to 32 after padding.
fn row() -> (SparseGrid, LeafBounds) {
    let values: Vec<f32> = (0..16).map(|x| if x < 8 { 1.0 } else { 2.0 }).collect();
    let (grid, _) = SparseGrid::from_dense([16, 1, 1], [0, 0, 0], &values, 0.0).unwrap();
    let bounds = LeafBounds::build(&grid);
    (grid, bounds)
}

fn segments(bounds: &LeafBounds, ray: Ray, t0: f32, t1: f32) -> Vec<MajorantSegment> {
    DdaMajorantIterator::new(bounds, &ray, t0, t1, 1.0).collect()
}

#[test]
fn axis_parallel_ray_with_negative_zeros_walks_one_row() {
    let (grid, bounds) = row();
    assert_eq!(grid.cell_origin, [-1, -1, -1]);
    assert_eq!(grid.dims, [4, 3, 3]);
    // Along x through voxel centres of the row, with -0.0 on the other axes.
    let ray = Ray::new(Vec3::new(-20.0, 0.0, 0.0), Vec3::new(1.0, -0.0, -0.0));
    let segs = segments(&bounds, ray, 0.0, f32::INFINITY);
    let ends: Vec<(f32, f32)> = segs.iter().map(|s| (s.t_min, s.t_max)).collect();
    assert_eq!(
        ends,
        vec![(12.0, 20.0), (20.0, 28.0), (28.0, 36.0), (36.0, 44.0)]
    );
    // Padding cell, then the two data cells (each reaching a voxel into its neighbours).
    let maj: Vec<f32> = segs.iter().map(|s| s.sigma_maj).collect();
    assert_eq!(maj, vec![1.0, 2.0, 2.0, 2.0]);
    let min: Vec<f32> = segs.iter().map(|s| s.sigma_min).collect();
    assert_eq!(min, vec![0.0, 0.0, 0.0, 0.0]);
    // Reversed, starting inside.
    let back = Ray::new(Vec3::new(10.0, 0.0, 0.0), Vec3::new(-2.0, 0.0, -0.0));
    let ends: Vec<(f32, f32)> = segments(&bounds, back, 0.0, 100.0)
        .iter()
        .map(|s| (s.t_min, s.t_max))
        .collect();
    assert_eq!(ends, vec![(0.0, 1.0), (1.0, 5.0), (5.0, 9.0)]);
}

#[test]
fn density_scale_multiplies_both_bounds() {
    let (_, bounds) = row();
    let ray = Ray::new(Vec3::new(-20.0, 0.5, 0.5), Vec3::X);
    for s in DdaMajorantIterator::new(&bounds, &ray, 0.0, 100.0, 3.0)
        .zip(segments(&bounds, ray, 0.0, 100.0))
    {
        assert_eq!(s.0.sigma_maj, 3.0 * s.1.sigma_maj);
        assert_eq!(s.0.sigma_min, 3.0 * s.1.sigma_min);
    }
}

#[test]
fn degenerate_intervals_and_misses_yield_nothing() {
    let (_, bounds) = row();
    let ray = Ray::new(Vec3::new(-20.0, 0.0, 0.0), Vec3::X);
    assert!(segments(&bounds, ray, 30.0, 20.0).is_empty(), "t0 > t1");
    assert!(segments(&bounds, ray, 25.0, 25.0).is_empty(), "zero length");
    assert!(segments(&bounds, ray, f32::NAN, 25.0).is_empty(), "NaN t0");
    assert!(
        segments(&bounds, ray, 0.0, 5.0).is_empty(),
        "ends before the box"
    );
    let miss = Ray::new(Vec3::new(-20.0, 50.0, 0.0), Vec3::X);
    assert!(segments(&bounds, miss, 0.0, f32::INFINITY).is_empty());
    let still = Ray::new(Vec3::new(-20.0, 0.0, 0.0), Vec3::ZERO);
    assert!(segments(&bounds, still, 0.0, f32::INFINITY).is_empty());
    // A motionless ray inside the box is one segment over the whole interval.
    let inside = Ray::new(Vec3::new(3.0, 0.0, 0.0), -Vec3::ZERO);
    let segs = segments(&bounds, inside, -1.0, 2.0);
    assert_eq!(segs.len(), 1);
    assert_eq!((segs[0].t_min, segs[0].t_max), (-1.0, 2.0));
    let global: Vec<_> = DdaMajorantIterator::global(&bounds, &ray, 0.0, 1e9, 1.0).collect();
    assert_eq!(
        global,
        vec![MajorantSegment {
            t_min: 12.0,
            t_max: 44.0,
            sigma_maj: 2.0,
            sigma_min: 0.0
        }]
    );
}

#[test]
fn ray_along_a_cell_edge_is_bounded_on_both_sides() {
    let (grid, bounds) = row();
    // Along x on the edge y = z = 0 shared by four cell columns... of which only one holds data.
    let ray = Ray::new(Vec3::new(-8.0, 0.0, 0.0), Vec3::new(1.0, 0.0, -0.0));
    for s in segments(&bounds, ray, 0.0, f32::INFINITY) {
        for k in 0..=16 {
            let t = s.t_min + (s.t_max - s.t_min) * k as f32 / 16.0;
            let v = grid.sample_trilinear(ray.at(t).as_dvec3());
            assert!(
                s.sigma_min <= v && v <= s.sigma_maj,
                "{v} at {t} outside {s:?}"
            );
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// Segments tile the box overlap for arbitrary (finite) rays, including huge and tiny
    /// directions that stress the crossing arithmetic.
    #[test]
    fn segments_tile_the_overlap(
        o in prop::array::uniform3(-60.0f32..60.0),
        d in prop::array::uniform3(prop_oneof![Just(0.0f32), Just(-0.0f32), -1e3f32..1e3, -1e-3f32..1e-3]),
        t0 in -1e3f32..1e3,
        len in 0.0f32..1e4,
    ) {
        let grid = common::convert(&common::blob());
        let bounds = LeafBounds::build(&grid);
        let ray = Ray::new(Vec3::from_array(o), Vec3::from_array(d));
        let segs = segments(&bounds, ray, t0, t0 + len);
        // The walk box (the non-zero cells' box) inside the cell box: every walk clips to it.
        let (lo, hi) = bounds.walk_box();
        let cell_box = grid.index_bounds();
        let walk_box = brume::math::Aabb::new(cell_box.min.max(lo), cell_box.max.min(hi));
        let want = walk_box.intersect(&ray, t0, t0 + len).filter(|(a, b)| a < b);
        // The global bound's walk (a one-cell box, which skips the DDA's set-up) is one
        // segment over the same overlap, bit for bit.
        let global: Vec<_> =
            DdaMajorantIterator::global(&bounds, &ray, t0, t0 + len, 1.0).collect();
        let global_ends: Vec<_> =
            global.iter().map(|s| (s.t_min.to_bits(), s.t_max.to_bits())).collect();
        prop_assert_eq!(global_ends, want.map(|(a, b)| (a.to_bits(), b.to_bits())).into_iter().collect::<Vec<_>>());
        prop_assert!(global.iter().all(|s| s.sigma_maj == bounds.global.max && s.sigma_min == bounds.global.min));
        match want {
            None => prop_assert!(segs.is_empty()),
            Some((a, b)) => {
                prop_assert_eq!(segs.first().unwrap().t_min.to_bits(), a.to_bits());
                prop_assert_eq!(segs.last().unwrap().t_max.to_bits(), b.to_bits());
                for w in segs.windows(2) {
                    prop_assert_eq!(w[0].t_max.to_bits(), w[1].t_min.to_bits());
                }
                prop_assert!(segs.iter().all(|s| s.t_min < s.t_max));
            }
        }
    }
}
