//! Every estimator's WGSL transmittance (shaders/common/tracking.wgsl via the transmittance
//! kernel) against the analytic / quadrature value by a z-test at 99.9 %, and against the CPU
//! `tracking::transmittance` sample by sample with the same `Rng::new(i, 0, seed)` streams.
//!
//! Majorants: per-cell, global, and the culled global walk (the same global segment, its
//! collisions culled by the leaf cells on both sides with the same uniforms).
//!
//! Media: a homogeneous slab (a dense block of ones; along x its optical depth is exactly
//! `scale * 32 / d.x`, the trilinear ramps at both faces included) and the heterogeneous `blob`
//! grid (optical depth by fine midpoint quadrature of the CPU lookup).
use crate::common;

use brume::backend::gpu::shader::TRANSMITTANCE_MODULE;
use brume::backend::gpu::GpuGrid;
use brume::gpu_types::{GpuEstimator, GpuMajorantMode};
use brume::math::{Ray, Vec3};
use brume::sampling::Rng;
use brume::volume::tracking::spectral::SpectralProbabilities;
use brume::volume::tracking::{
    self as tr, Coeffs, CoeffsRgb, ControlExtinction, FnMedium, FnMediumRgb, TrackingStats,
};
use brume::volume::{DdaMajorantIterator, LeafCulling, VoxelCulling};
use common::culled::CulledBy;
use common::gpu::{blob, run_tracking, slab, Medium, TrackingCase, ALBEDO, RGB, SAMPLES};
use common::{assert_z, Moments};

struct Case {
    label: String,
    estimator: GpuEstimator,
    b: f32,
    control: ControlExtinction,
    majorant: GpuMajorantMode,
}

fn case(est: GpuEstimator, b: f32, control: ControlExtinction, maj: GpuMajorantMode) -> Case {
    Case {
        label: format!("{est:?} b={b} {control:?} {maj:?}"),
        estimator: est,
        b,
        control,
        majorant: maj,
    }
}

fn cases() -> Vec<Case> {
    use ControlExtinction as C;
    use GpuEstimator::*;
    use GpuMajorantMode::*;
    vec![
        case(Delta, 1.0, C::None, PerCell),
        case(Delta, 1.0, C::None, Global),
        case(WeightedDelta, 1.0, C::None, PerCell),
        case(WeightedDelta, 0.5, C::None, PerCell),
        case(Decomposition, 1.0, C::SegmentMinorant, PerCell),
        case(WeightedDecomposition, 1.0, C::FractionOfBound(0.8), PerCell),
        case(WeightedDecomposition, 0.5, C::FractionOfBound(0.8), PerCell),
        case(Ratio, 1.0, C::None, PerCell),
        case(Ratio, 1.0, C::None, Global),
        case(ResidualRatio, 1.0, C::SegmentMinorant, PerCell),
        case(ResidualRatio, 1.0, C::FractionOfBound(0.8), PerCell),
        case(Spectral, 1.0, C::None, PerCell),
        // The culled global walk (volume::cull): its renders' control is the segment minorant,
        // 0 over a grid whose global minimum is 0 (both test grids).
        case(Delta, 1.0, C::None, Culled),
        case(WeightedDelta, 0.5, C::None, Culled),
        case(Decomposition, 1.0, C::SegmentMinorant, Culled),
        case(WeightedDecomposition, 1.0, C::SegmentMinorant, Culled),
        case(Ratio, 1.0, C::None, Culled),
        case(ResidualRatio, 1.0, C::SegmentMinorant, Culled),
        case(Spectral, 1.0, C::None, Culled),
    ]
}

/// The CPU estimate for invocation `i` (same stream as the kernel).
fn cpu_estimate(m: &Medium, c: &Case, seed: u32, i: u32, st: &mut TrackingStats) -> [f32; 3] {
    let ray = Ray::new(Vec3::from_array(m.ray.o), Vec3::from_array(m.ray.d));
    let rgb = c.estimator == GpuEstimator::Spectral;
    let maj_scale = if rgb { m.scale * RGB[2] } else { m.scale };
    let segs = match c.majorant {
        GpuMajorantMode::PerCell => {
            DdaMajorantIterator::new(&m.bounds, &ray, m.ray.t_min, m.ray.t_max, maj_scale)
        }
        GpuMajorantMode::Global | GpuMajorantMode::Culled => {
            DdaMajorantIterator::global(&m.bounds, &ray, m.ray.t_min, m.ray.t_max, maj_scale)
        }
        GpuMajorantMode::Adaptive => unreachable!("the adaptive walk is checked in gpu_dda"),
    };
    let lookup = |t: f32| m.scale * m.grid.sample_trilinear(ray.at(t).as_dvec3());
    // The kernels thin the per-leaf and culled walks' kept collisions by the voxel bounds.
    let voxel_culling = matches!(
        c.majorant,
        GpuMajorantMode::PerCell | GpuMajorantMode::Culled
    )
    .then(|| VoxelCulling::new(&m.bounds, &m.grid.cells, maj_scale))
    .flatten();
    let voxel = |t: f32, bound: f32| voxel_culling.map_or(1.0, |v| v.ratio(ray.at(t), bound));
    let culling = (c.majorant == GpuMajorantMode::Culled)
        .then(|| LeafCulling::new(&m.bounds))
        .flatten();
    let medium = CulledBy {
        inner: FnMedium::with_control(
            |t| Coeffs::from_sigma_t(lookup(t), ALBEDO),
            c.control,
            ALBEDO,
        ),
        ratio: |t: f32| culling.map_or(1.0, |c| c.ratio(ray.at(t))),
        voxel: &voxel,
    };
    let mut rng = Rng::new(i, 0, seed);
    let t_max = m.ray.t_max;
    // One estimate of a grey estimator.
    macro_rules! grey {
        ($estimator:expr) => {
            [
                tr::transmittance(&$estimator, segs, t_max, &medium, &mut rng, st),
                0.0,
                0.0,
            ]
        };
    }
    match c.estimator {
        GpuEstimator::Delta => grey!(tr::Delta),
        GpuEstimator::WeightedDelta => grey!(tr::WeightedDelta { b: c.b }),
        GpuEstimator::Decomposition => grey!(tr::Decomposition),
        GpuEstimator::WeightedDecomposition => grey!(tr::WeightedDecomposition { b: c.b }),
        GpuEstimator::Ratio => grey!(tr::Ratio { b: c.b }),
        GpuEstimator::ResidualRatio => grey!(tr::ResidualRatio { b: c.b }),
        GpuEstimator::Spectral => {
            let k = Vec3::from_array(RGB);
            let rgb_medium = CulledBy {
                inner: FnMediumRgb(|t: f32| {
                    let s = k * lookup(t);
                    CoeffsRgb::new((1.0 - ALBEDO) * s, ALBEDO * s)
                }),
                ratio: |t: f32| culling.map_or(1.0, |c| c.ratio(ray.at(t))),
                voxel: &voxel,
            };
            tr::transmittance(
                &tr::Spectral {
                    b: c.b,
                    mode: SpectralProbabilities::HistoryAwareMax,
                    beta: Vec3::ONE,
                },
                segs,
                t_max,
                &rgb_medium,
                &mut rng,
                st,
            )
            .to_array()
        }
    }
}

#[test]
fn wgsl_transmittance_matches_analytic_and_cpu() {
    let Some(ctx) = common::gpu::gpu_or_skip("gpu_transmittance") else {
        return;
    };
    let pipeline = ctx.pipeline(&TRANSMITTANCE_MODULE, &[]).unwrap();
    let mut failures = Vec::new();
    for m in [slab(), blob()] {
        // Culling is sound on both grids (global minimum 0); on the blob it culls.
        assert!(
            LeafCulling::new(&m.bounds).is_some(),
            "{}: no culling",
            m.name
        );
        let mut ratio_lookups = std::collections::HashMap::new();
        let grid = GpuGrid::upload(&ctx, &m.grid, &m.bounds, m.scale).unwrap();
        println!("{}: tau = {:.6}, T = {:.6}", m.name, m.tau, (-m.tau).exp());
        for (ci, c) in cases().iter().enumerate() {
            let seed = 1000 + ci as u32;
            let t0 = std::time::Instant::now();
            let case = TrackingCase {
                estimator: c.estimator,
                b: c.b,
                control: c.control,
                majorant: c.majorant,
            };
            let out = run_tracking(&ctx, &pipeline, &grid, &m, case, seed, false);
            let (gpu, gpu_stats) = (out.results, out.stats);
            let gpu_time = t0.elapsed();
            let channels = if c.estimator == GpuEstimator::Spectral {
                3
            } else {
                1
            };
            let mut moments = [Moments::default(); 3];
            let mut cpu_stats = TrackingStats::default();
            let (mut identical, mut same_lookups, mut max_diff) = (0u32, 0u32, 0.0f32);
            for (i, g) in gpu.iter().enumerate() {
                let mut st = TrackingStats::default();
                let cpu = cpu_estimate(&m, c, seed, i as u32, &mut st);
                cpu_stats.merge(&st);
                let mut same = true;
                for ch in 0..channels {
                    moments[ch].push(g[ch] as f64);
                    same &= g[ch].to_bits() == cpu[ch].to_bits();
                    max_diff = max_diff.max((g[ch] - cpu[ch]).abs());
                }
                identical += same as u32;
                same_lookups += (g[3] as u64 == st.lookups) as u32;
            }
            let gs = gpu_stats.to_cpu();
            if c.estimator == GpuEstimator::Ratio {
                ratio_lookups.insert(c.majorant as u32, cpu_stats.lookups);
            }
            println!(
                "  {:<58} gpu {:>6.0} ms; per sample: identical {:.3} %, same lookups {:.3} %, \
                 max |gpu - cpu| {max_diff:.2e}; lookups gpu {} cpu {}",
                c.label,
                gpu_time.as_secs_f64() * 1e3,
                100.0 * identical as f64 / SAMPLES as f64,
                100.0 * same_lookups as f64 / SAMPLES as f64,
                gs.lookups,
                cpu_stats.lookups
            );
            for (ch, mo) in moments.iter().enumerate().take(channels) {
                let k = if channels == 3 { RGB[ch] as f64 } else { 1.0 };
                let expected = (-k * m.tau).exp();
                let label = format!("    {} {} ch{ch}", m.name, c.label);
                let result = std::panic::catch_unwind(|| assert_z(&label, mo, expected));
                if result.is_err() {
                    failures.push(label);
                }
            }
            if gs.is_biased() {
                failures.push(format!(
                    "{} {}: GPU stats report bias {gs:?}",
                    m.name, c.label
                ));
            }
        }
        if m.name == "blob" {
            let (culled, global) = (
                ratio_lookups[&(GpuMajorantMode::Culled as u32)],
                ratio_lookups[&(GpuMajorantMode::Global as u32)],
            );
            println!("  blob ratio tracking lookups: culled {culled}, global {global}");
            assert!(culled < global, "culling removed no lookup on the blob");
        }
    }
    assert!(failures.is_empty(), "failed: {failures:#?}");
}
