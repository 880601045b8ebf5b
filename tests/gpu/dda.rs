//! The WGSL majorant DDA (shaders/common/dda.wgsl) against `DdaMajorantIterator` for many random
//! rays, including axis-parallel ones with +0.0 and -0.0 components, misses, rays starting
//! inside, bounded and unbounded intervals, per-cell and global walks.
use crate::common;

use brume::backend::gpu::shader::{Spec, TEST_DDA_MODULE};
use brume::backend::gpu::GpuGrid;
use brume::gpu_types::{GpuMajorantMode, GpuMajorantSegment, GpuRay};
use brume::math::{Ray, Vec3};
use brume::volume::check::SplitMix64;
use brume::volume::{
    AdaptiveMajorantIterator, AdaptiveMajorants, CostModel, DdaMajorantIterator, LeafBounds,
    MajorantSegment,
};

const MAX_SEGMENTS: u32 = 256;
const SCALE: f32 = 0.75;

/// Distance in units in the last place (0 for equal values, including +0.0 vs -0.0).
fn ulps(a: f32, b: f32) -> u32 {
    if a == b {
        return 0;
    }
    let key = |x: f32| {
        let i = x.to_bits() as i32;
        if i < 0 {
            i32::MIN - i
        } else {
            i
        }
    };
    (key(a) as i64 - key(b) as i64)
        .unsigned_abs()
        .min(u32::MAX as u64) as u32
}

fn random_rays(rng: &mut SplitMix64, lo: Vec3, hi: Vec3, n: usize) -> Vec<GpuRay> {
    let mut rays = Vec::with_capacity(n);
    let margin = Vec3::splat(12.0);
    for i in 0..n {
        let o: [f32; 3] = std::array::from_fn(|a| {
            rng.range((lo[a] - margin[a]) as f64, (hi[a] + margin[a]) as f64) as f32
        });
        let mut d: [f32; 3] = std::array::from_fn(|_| rng.range(-1.0, 1.0) as f32);
        // A quarter of the rays are axis-parallel on one or two axes, with either zero sign.
        if i % 4 == 0 {
            let axis = rng.below(3) as usize;
            d[axis] = if rng.below(2) == 0 { 0.0 } else { -0.0 };
            if rng.below(2) == 0 {
                let other = (axis + 1 + rng.below(2) as usize) % 3;
                d[other] = if rng.below(2) == 0 { 0.0 } else { -0.0 };
            }
        }
        // Some rays start on an integer (cell-plane) coordinate.
        let o = if i % 7 == 0 {
            o.map(|x| (x / 8.0).round() * 8.0)
        } else {
            o
        };
        let t_min = if i % 3 == 0 {
            rng.range(-5.0, 5.0) as f32
        } else {
            0.0
        };
        let t_max = if i % 2 == 0 {
            f32::INFINITY
        } else {
            rng.range(0.0, 200.0) as f32
        };
        rays.push(GpuRay { o, t_min, d, t_max });
    }
    rays
}

#[test]
fn wgsl_dda_segments_equal_cpu() {
    let Some(ctx) = common::gpu::gpu_or_skip("gpu_dda") else {
        return;
    };
    // Per-cell, global, and the adaptive hierarchy built two ways: with the default cost
    // model (fine and merged nodes side by side) and with steps so dear that large nodes form.
    let modes = [
        (GpuMajorantMode::PerCell, None),
        (GpuMajorantMode::Global, None),
        // The culled walk's segments are the global walk's (its culling is per collision:
        // tests/gpu/distance.rs, tests/gpu/transmittance.rs).
        (GpuMajorantMode::Culled, None),
        (GpuMajorantMode::Adaptive, Some(CostModel::DEFAULT)),
        (GpuMajorantMode::Adaptive, Some(CostModel::uniform(20.0))),
    ];
    for (mode, cost) in modes {
        let global = matches!(mode, GpuMajorantMode::Global | GpuMajorantMode::Culled);
        let specs = [
            Spec::u32("MAX_SEGMENTS", MAX_SEGMENTS),
            Spec::u32("DDA_MODE", mode as u32),
            Spec::f32("DDA_SCALE", SCALE),
        ];
        let pipeline = ctx.pipeline(&TEST_DDA_MODULE, &specs).unwrap();
        for (name, data) in common::all_grids() {
            let grid = common::convert(&data);
            let bounds = LeafBounds::build(&grid);
            let adaptive = cost.map(|c| AdaptiveMajorants::build(&bounds, 0.3, 1.0, c));
            let gpu_grid =
                GpuGrid::upload_adaptive(&ctx, &grid, &bounds, adaptive.as_ref(), 1.0).unwrap();
            let b = grid.index_bounds();
            let (lo, hi) = if b.is_empty() {
                (Vec3::splat(-10.0), Vec3::splat(10.0))
            } else {
                (b.min, b.max)
            };
            let mut rng = SplitMix64(0xDDA + name.len() as u64 + mode as u64);
            let rays = random_rays(&mut rng, lo, hi, 20_000);
            let ray_buf = ctx.storage_buffer("rays", &rays);
            let segs_buf =
                ctx.storage_buffer_zeroed("segments", rays.len() as u64 * MAX_SEGMENTS as u64 * 16);
            let counts_buf = ctx.storage_buffer_zeroed("counts", rays.len() as u64 * 4);
            let mut bindings = gpu_grid.bindings(false, true);
            bindings.extend([(1, 0, &ray_buf), (1, 1, &segs_buf), (1, 2, &counts_buf)]);
            ctx.dispatch(&pipeline, &bindings, (rays.len() as u32).div_ceil(64))
                .unwrap();
            let gpu_segs: Vec<GpuMajorantSegment> = ctx.read_buffer(&segs_buf);
            let counts: Vec<u32> = ctx.read_buffer(&counts_buf);

            let (mut count_bad, mut total, mut exact, mut max_ulps, mut hits) = (0, 0, 0, 0, 0);
            for (i, r) in rays.iter().enumerate() {
                let ray = Ray::new(Vec3::from_array(r.o), Vec3::from_array(r.d));
                let cpu: Vec<MajorantSegment> = if let Some(a) = &adaptive {
                    AdaptiveMajorantIterator::new(a, &ray, r.t_min, r.t_max, SCALE).collect()
                } else if global {
                    DdaMajorantIterator::global(&bounds, &ray, r.t_min, r.t_max, SCALE).collect()
                } else {
                    DdaMajorantIterator::new(&bounds, &ray, r.t_min, r.t_max, SCALE).collect()
                };
                hits += !cpu.is_empty() as u32;
                if cpu.len() != counts[i] as usize {
                    if count_bad < 5 {
                        eprintln!(
                            "{name} mode={mode:?} ray {r:?}: cpu {} segments, gpu {}",
                            cpu.len(),
                            counts[i]
                        );
                    }
                    count_bad += 1;
                    continue;
                }
                for (k, c) in cpu.iter().take(MAX_SEGMENTS as usize).enumerate() {
                    let g = gpu_segs[i * MAX_SEGMENTS as usize + k];
                    let u = [
                        ulps(c.t_min, g.t_min),
                        ulps(c.t_max, g.t_max),
                        ulps(c.sigma_maj, g.sigma_maj),
                        ulps(c.sigma_min, g.sigma_min),
                    ];
                    let m = *u.iter().max().unwrap();
                    total += 1;
                    exact += (m == 0) as u32;
                    if m > max_ulps {
                        max_ulps = m;
                        if m > 1 {
                            eprintln!("{name} ray {r:?} seg {k}: cpu {c:?} gpu {g:?}");
                        }
                    }
                }
            }
            println!(
                "{name:<24} mode={mode:?} {} rays ({hits} hit): count mismatches \
                 {count_bad}, {total} segments, bit-exact {:.4} %, max {max_ulps} ulp",
                rays.len(),
                100.0 * exact as f64 / total.max(1) as f64
            );
            assert_eq!(count_bad, 0, "{name}: segment counts differ");
            // Vulkan lets a device divide to 2.5 ulps (`1 / d`, then one rounded multiply per
            // crossing): 3 ulps at most. Devices that divide with IEEE rounding give the CPU's
            // bits (llvmpipe: 100 %); a GPU that does not can leave a fifth of the segments
            // an ulp or two off.
            assert!(max_ulps <= 3, "{name}: segments differ by {max_ulps} ulp");
        }
    }
}
