//! Every distance-sampling estimator's WGSL `sample_distance` (shaders/common/tracking.wgsl via
//! the distance kernel) against the CPU `tracking::sample_distance`, sample by sample with
//! the same `Rng::new(i, 0, seed)` streams, and by z-tests at 99.9 % of two unbiased
//! functionals with known values:
//!
//! * `E[w 1{escape}] = T(t_max)`, and
//! * `E[w 1{event before s}] = 1 - T(s)` for `s` inside the medium,
//!
//! on the homogeneous slab and the heterogeneous blob of `tests/common/gpu.rs`, over per-cell
//! bounds and over the culled global walk (the global segment, its collisions culled by the
//! leaf cells: `volume::cull`).
use crate::common;

use brume::backend::gpu::shader::DISTANCE_MODULE;
use brume::backend::gpu::GpuGrid;
use brume::gpu_types::{GpuEstimator, GpuMajorantMode};
use brume::math::{Ray, Vec3};
use brume::sampling::Rng;
use brume::volume::tracking::spectral::SpectralProbabilities;
use brume::volume::tracking::{
    self as tr, Coeffs, CoeffsRgb, ControlExtinction, Event, FnMedium, FnMediumRgb, TrackingStats,
};
use brume::volume::{DdaMajorantIterator, LeafCulling, VoxelCulling};
use common::culled::CulledBy;
use common::gpu::{blob, run_tracking, slab, Medium, TrackingCase, ALBEDO, RGB, SAMPLES};
use common::{assert_z, Moments};

/// (estimator, b, control)
fn cases() -> Vec<(GpuEstimator, f32, ControlExtinction, GpuMajorantMode)> {
    use ControlExtinction as C;
    use GpuEstimator::*;
    use GpuMajorantMode::{Culled, PerCell};
    vec![
        (Delta, 1.0, C::None, PerCell),
        (WeightedDelta, 1.0, C::None, PerCell),
        (WeightedDelta, 0.5, C::None, PerCell),
        (Decomposition, 1.0, C::SegmentMinorant, PerCell),
        (WeightedDecomposition, 1.0, C::FractionOfBound(0.8), PerCell),
        (WeightedDecomposition, 0.5, C::FractionOfBound(0.8), PerCell),
        (Spectral, 1.0, C::None, PerCell),
        // The culled walk's renders take the segment minorant as control (0 on both grids).
        (Delta, 1.0, C::None, Culled),
        (WeightedDelta, 0.5, C::None, Culled),
        (Decomposition, 1.0, C::SegmentMinorant, Culled),
        (WeightedDecomposition, 0.5, C::SegmentMinorant, Culled),
        (Spectral, 1.0, C::None, Culled),
    ]
}

/// (event kind as in the kernel, t, weight) of the CPU sampler for invocation `i`.
#[allow(clippy::too_many_arguments)]
fn cpu_sample(
    m: &Medium,
    est: GpuEstimator,
    b: f32,
    control: ControlExtinction,
    majorant: GpuMajorantMode,
    seed: u32,
    i: u32,
    st: &mut TrackingStats,
) -> (u32, f32, [f32; 3]) {
    let ray = Ray::new(Vec3::from_array(m.ray.o), Vec3::from_array(m.ray.d));
    let rgb = est == GpuEstimator::Spectral;
    let maj_scale = if rgb { m.scale * RGB[2] } else { m.scale };
    let (t0, t1) = (m.ray.t_min, m.ray.t_max);
    let (segs, culling) = if majorant == GpuMajorantMode::Culled {
        let segs = DdaMajorantIterator::global(&m.bounds, &ray, t0, t1, maj_scale);
        (segs, LeafCulling::new(&m.bounds))
    } else {
        (
            DdaMajorantIterator::new(&m.bounds, &ray, t0, t1, maj_scale),
            None,
        )
    };
    let lookup = |t: f32| m.scale * m.grid.sample_trilinear(ray.at(t).as_dvec3());
    // The kernels thin the per-leaf and culled walks' kept collisions by the voxel bounds.
    let voxel_culling = matches!(majorant, GpuMajorantMode::PerCell | GpuMajorantMode::Culled)
        .then(|| VoxelCulling::new(&m.bounds, &m.grid.cells, maj_scale))
        .flatten();
    let voxel = |t: f32, bound: f32| voxel_culling.map_or(1.0, |v| v.ratio(ray.at(t), bound));
    let medium = CulledBy {
        inner: FnMedium::with_control(|t| Coeffs::from_sigma_t(lookup(t), ALBEDO), control, ALBEDO),
        ratio: |t: f32| culling.map_or(1.0, |c| c.ratio(ray.at(t))),
        voxel: &voxel,
    };
    let mut rng = Rng::new(i, 0, seed);
    let t_max = m.ray.t_max;
    // One flight of a grey estimator.
    macro_rules! grey {
        ($estimator:expr) => {
            tr::sample_distance(&$estimator, segs, t_max, &medium, &mut rng, st).map3()
        };
    }
    match est {
        GpuEstimator::Delta => grey!(tr::Delta),
        GpuEstimator::WeightedDelta => grey!(tr::WeightedDelta { b }),
        GpuEstimator::Decomposition => grey!(tr::Decomposition),
        GpuEstimator::WeightedDecomposition => grey!(tr::WeightedDecomposition { b }),
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
            let e = tr::sample_distance(
                &tr::Spectral {
                    b,
                    mode: SpectralProbabilities::HistoryAwareMax,
                    beta: Vec3::ONE,
                },
                segs,
                t_max,
                &rgb_medium,
                &mut rng,
                st,
            );
            let (kind, t) = kind_t(e.t(), matches!(e, Event::Absorb { .. }));
            (kind, t, e.weight().to_array())
        }
        _ => unreachable!("no distance sampler for {est:?}"),
    }
}

fn kind_t(t: Option<f32>, absorb: bool) -> (u32, f32) {
    match t {
        None => (0, 0.0),
        Some(t) => (if absorb { 1 } else { 2 }, t),
    }
}

trait Map3 {
    fn map3(self) -> (u32, f32, [f32; 3]);
}

impl Map3 for Event<f32> {
    fn map3(self) -> (u32, f32, [f32; 3]) {
        let (kind, t) = kind_t(self.t(), matches!(self, Event::Absorb { .. }));
        (kind, t, [self.weight(), 0.0, 0.0])
    }
}

#[test]
fn wgsl_sample_distance_matches_cpu_and_analytic() {
    let Some(ctx) = common::gpu::gpu_or_skip("gpu_distance") else {
        return;
    };
    let pipeline = ctx.pipeline(&DISTANCE_MODULE, &[]).unwrap();
    let mut failures = Vec::new();
    for m in [slab(), blob()] {
        let grid = GpuGrid::upload(&ctx, &m.grid, &m.bounds, m.scale).unwrap();
        // A point inside the medium for the collision-before-s functional.
        let s_half = if m.name == "slab" {
            20.0
        } else {
            0.5 * m.ray.t_max
        };
        let tau_half = m.tau_to(s_half, 1_000_000);
        println!(
            "{}: T(t_max) = {:.6}, T(s = {s_half}) = {:.6}",
            m.name,
            (-m.tau).exp(),
            (-tau_half).exp()
        );
        for (ci, &(est, b, control, majorant)) in cases().iter().enumerate() {
            let label = format!("{est:?} b={b} {control:?} {majorant:?}");
            let seed = 2000 + ci as u32;
            let rgb = est == GpuEstimator::Spectral;
            let case = TrackingCase {
                estimator: est,
                b,
                control,
                majorant,
            };
            let out = run_tracking(&ctx, &pipeline, &grid, &m, case, seed, true);
            let (gpu, gpu_events) = (out.results, out.events);
            let gpu_stats = out.stats.to_cpu();

            let channels = if rgb { 3 } else { 1 };
            let mut escape = [Moments::default(); 3];
            let mut before = [Moments::default(); 3];
            let (mut same_kind, mut identical, mut max_t_rel) = (0u32, 0u32, 0.0f32);
            let mut cpu_stats = TrackingStats::default();
            for (i, (g, ge)) in gpu.iter().zip(&gpu_events).enumerate() {
                let mut st = TrackingStats::default();
                let (kind, t, w) =
                    cpu_sample(&m, est, b, control, majorant, seed, i as u32, &mut st);
                cpu_stats.merge(&st);
                if kind == ge[0] {
                    same_kind += 1;
                    if kind != 0 {
                        max_t_rel = max_t_rel.max((g[3] - t).abs() / t.abs().max(1e-30));
                    }
                    let same_w = (0..channels).all(|c| g[c].to_bits() == w[c].to_bits());
                    identical += (same_w && g[3].to_bits() == t.to_bits()) as u32;
                }
                for c in 0..channels {
                    let w = g[c] as f64;
                    escape[c].push(if ge[0] == 0 { w } else { 0.0 });
                    before[c].push(if ge[0] != 0 && g[3] < s_half { w } else { 0.0 });
                }
            }
            println!(
                "  {label:<44} per sample: same event {:.3} %, identical (event, t, weight) \
                 {:.3} %, max t rel diff {max_t_rel:.1e}; lookups gpu {} cpu {}",
                100.0 * same_kind as f64 / SAMPLES as f64,
                100.0 * identical as f64 / SAMPLES as f64,
                gpu_stats.lookups,
                cpu_stats.lookups
            );
            for c in 0..channels {
                let k = if rgb { RGB[c] as f64 } else { 1.0 };
                let checks = [
                    (
                        format!("    {} {label} ch{c} E[w 1{{escape}}]", m.name),
                        &escape[c],
                        (-k * m.tau).exp(),
                    ),
                    (
                        format!("    {} {label} ch{c} E[w 1{{t < {s_half}}}]", m.name),
                        &before[c],
                        1.0 - (-k * tau_half).exp(),
                    ),
                ];
                for (l, mo, expected) in checks {
                    if std::panic::catch_unwind(|| assert_z(&l, mo, expected)).is_err() {
                        failures.push(l);
                    }
                }
            }
            if gpu_stats.is_biased() {
                failures.push(format!(
                    "{} {label}: GPU stats report bias {gpu_stats:?}",
                    m.name
                ));
            }
        }
    }
    assert!(failures.is_empty(), "failed: {failures:#?}");
}
