//! The WGSL grid lookups (shaders/common/grid.wgsl) against `SparseGrid` on the synthetic test
//! grids: voxel and nearest values must be equal bit for bit; trilinear agrees to rounding (the
//! CPU scales differences in f64, the GPU in f32; see grid.wgsl) and the test reports how often
//! it is bit-exact.
use crate::common;

use brume::backend::gpu::shader::TEST_GRID_MODULE;
use brume::backend::gpu::GpuGrid;
use brume::volume::check::SplitMix64;
use brume::volume::{load_grid, ConversionPolicy, LeafBounds, SparseGrid};
use glam::DVec3;

/// Trilinear tolerance, relative to the largest |voxel| of the grid: a blend of three lerps
/// in f32 has at most a few ulps of the operands' magnitude of rounding difference.
const TRILINEAR_REL_TOL: f32 = 1e-6;

#[test]
fn wgsl_grid_lookups_equal_cpu() {
    let Some(ctx) = common::gpu::gpu_or_skip("gpu_grid") else {
        return;
    };
    let pipeline = ctx.pipeline(&TEST_GRID_MODULE, &[]).unwrap();
    let mut grids: Vec<(String, SparseGrid, LeafBounds)> = common::all_grids()
        .into_iter()
        .map(|(name, data)| {
            let grid = common::convert(&data);
            let bounds = LeafBounds::build(&grid);
            (name.to_string(), grid, bounds)
        })
        .collect();
    // A real file too: the cloud example (scenes/make_vdbs.sh), 'density' grid.
    let cloud = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/vdb/cloud.vdb");
    let loaded = load_grid(&cloud, "density", ConversionPolicy::default())
        .unwrap_or_else(|e| panic!("{}: {e}", cloud.display()));
    grids.push(("cloud.vdb".into(), loaded.grid, loaded.bounds));
    for (name, grid, bounds) in &grids {
        let (grid, bounds) = (grid, bounds);
        let gpu_grid = GpuGrid::upload(&ctx, grid, bounds, 1.0).unwrap();
        let b = grid.index_bounds();
        let (lo, hi) = if b.is_empty() {
            ([-10.0f32; 3], [10.0f32; 3])
        } else {
            (b.min.to_array(), b.max.to_array())
        };
        let mut rng = SplitMix64(0xB0B + name.len() as u64);
        let mut points: Vec<[f32; 4]> = Vec::new();
        for n in 0..200_000 {
            let p: [f32; 3] = std::array::from_fn(|a| {
                let x = rng.range(lo[a] as f64 - 3.0, hi[a] as f64 + 3.0) as f32;
                // Every fourth point on an integer or half-integer: rounding edge cases.
                match n % 8 {
                    0 => x.round(),
                    1 => x.floor() + 0.5,
                    _ => x,
                }
            });
            points.push([p[0], p[1], p[2], 0.0]);
        }
        let input = ctx.storage_buffer("points", &points);
        let out = ctx.storage_buffer_zeroed("values", points.len() as u64 * 16);
        let mut bindings = gpu_grid.bindings(true, false);
        bindings.extend([(1, 0, &input), (1, 1, &out)]);
        ctx.dispatch(&pipeline, &bindings, (points.len() as u32).div_ceil(64))
            .unwrap();
        let gpu: Vec<[f32; 4]> = ctx.read_buffer(&out);

        let vmax = grid
            .bricks
            .iter()
            .chain(&grid.constants)
            .fold(grid.background.abs(), |m, v| m.max(v.abs()))
            .max(f32::MIN_POSITIVE);
        let (mut nearest_bad, mut voxel_bad, mut tri_exact, mut tri_bad) = (0, 0, 0, 0);
        let mut tri_max_rel = 0.0f32;
        for (p, g) in points.iter().zip(&gpu) {
            let q = DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
            let nearest = grid.sample_nearest(q);
            let tri = grid.sample_trilinear(q);
            let f = q.floor();
            let voxel = grid.voxel(f.x as i32, f.y as i32, f.z as i32);
            nearest_bad += (g[0].to_bits() != nearest.to_bits()) as u32;
            voxel_bad += (g[2].to_bits() != voxel.to_bits()) as u32;
            if g[1].to_bits() == tri.to_bits() {
                tri_exact += 1;
            }
            let rel = (g[1] - tri).abs() / vmax;
            tri_max_rel = tri_max_rel.max(rel);
            // Negated so that a NaN fails.
            #[allow(clippy::neg_cmp_op_on_partial_ord)]
            let outside = !(rel <= TRILINEAR_REL_TOL);
            if outside {
                if tri_bad < 5 {
                    eprintln!("{name}: trilinear at {p:?}: gpu {} cpu {tri}", g[1]);
                }
                tri_bad += 1;
            }
        }
        println!(
            "{name:<24} {} points: nearest mismatches {nearest_bad}, voxel mismatches \
             {voxel_bad}, trilinear bit-exact {:.4} %, max |diff| / max|v| {tri_max_rel:.2e}",
            points.len(),
            100.0 * tri_exact as f64 / points.len() as f64
        );
        assert_eq!(nearest_bad, 0, "{name}: nearest lookups differ");
        assert_eq!(voxel_bad, 0, "{name}: voxel lookups differ");
        assert_eq!(tri_bad, 0, "{name}: trilinear beyond tolerance");
    }
}
