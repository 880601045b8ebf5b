//! Every transmittance estimator against `exp(-int sigma_t)` on homogeneous, piecewise-constant
//! and linear-ramp media, with global and local majorant segments, tight and loose bounds.
//! z-test at 99.9 % with the standard error estimated from the sample; fixed seeds.
use crate::common;

use brume::sampling::Rng;
use brume::volume::tracking::spectral::SpectralProbabilities;
use brume::volume::tracking::{
    self as tr, Coeffs, CoeffsRgb, ControlExtinction, FnMediumRgb, Medium, TrackingStats,
};
use common::culled::CulledBy;
use common::{assert_z, scenes, Moments, Scene};
use glam::Vec3;

const N: u32 = 200_000;

/// One estimate of a grey `estimator` over scene `s` through `medium`.
fn estimate<E, M>(
    estimator: &E,
    s: &Scene,
    medium: &M,
    rng: &mut Rng,
    st: &mut TrackingStats,
) -> f64
where
    E: tr::TransmittanceEstimator<M, Weight = f32>,
    M: Medium,
{
    tr::transmittance(
        estimator,
        s.segments.iter().copied(),
        s.t_max,
        medium,
        rng,
        st,
    ) as f64
}

/// Runs `n` independent estimates of one estimator and z-tests their mean.
fn check(
    label: &str,
    seed: u32,
    n: u32,
    expected: f64,
    mut estimate: impl FnMut(&mut Rng, &mut TrackingStats) -> f64,
) -> TrackingStats {
    let mut stats = TrackingStats::default();
    let mut m = Moments::default();
    for i in 0..common::samples(n) {
        let mut rng = Rng::new(i, 0, seed);
        m.push(estimate(&mut rng, &mut stats));
    }
    assert_z(label, &m, expected);
    stats
}

fn unbiased_run(label: &str, stats: &TrackingStats) {
    assert!(
        !stats.is_biased(),
        "{label}: tracker reported a problem: {stats:?}"
    );
}

#[test]
fn delta_tracking_transmittance() {
    for s in scenes() {
        let medium = s.medium(ControlExtinction::None);
        let label = format!("delta {}", s.name);
        let st = check(&label, 1, N, s.transmittance(), |rng, st| {
            estimate(&tr::Delta, &s, &medium, rng, st)
        });
        unbiased_run(&label, &st);
    }
}

#[test]
fn weighted_delta_tracking_transmittance() {
    for s in scenes() {
        let medium = s.medium(ControlExtinction::None);
        for b in [0.25, 0.5, 0.75, 1.0, 2.0] {
            let label = format!("weighted delta b={b} {}", s.name);
            // Small b: weights grow geometrically and the estimate is heavy-tailed, so the
            // sample standard error needs many more samples to be trustworthy.
            let n = if b < 0.5 { 10 * N } else { N };
            let st = check(&label, 2, n, s.transmittance(), |rng, st| {
                estimate(&tr::WeightedDelta { b }, &s, &medium, rng, st)
            });
            println!("    max |w| = {:.3e}", st.max_abs_weight);
            unbiased_run(&label, &st);
        }
    }
}

#[test]
fn decomposition_tracking_transmittance() {
    for s in scenes() {
        let medium = s.medium(ControlExtinction::SegmentMinorant);
        let label = format!("decomposition sigma_c=seg.sigma_min {}", s.name);
        let st = check(&label, 3, N, s.transmittance(), |rng, st| {
            estimate(&tr::Decomposition, &s, &medium, rng, st)
        });
        unbiased_run(&label, &st);
    }
}

#[test]
fn weighted_decomposition_transmittance_control_above_minorant() {
    for s in scenes() {
        // m = 0.8 of each segment's bound: above the true minorant wherever the medium varies
        // (and above sigma_t in the empty pieces), so the residual is negative there.
        let medium = s.medium(ControlExtinction::FractionOfBound(0.8));
        for b in [1.0, 0.5] {
            let label = format!("weighted decomposition m=0.8 b={b} {}", s.name);
            let st = check(&label, 4, N, s.transmittance(), |rng, st| {
                estimate(&tr::WeightedDecomposition { b }, &s, &medium, rng, st)
            });
            unbiased_run(&label, &st);
        }
    }
}

#[test]
fn ratio_tracking_transmittance() {
    for s in scenes() {
        let medium = s.medium(ControlExtinction::None);
        for b in [1.0, 0.5, 2.0] {
            let label = format!("ratio b={b} {}", s.name);
            let st = check(&label, 5, N, s.transmittance(), |rng, st| {
                estimate(&tr::Ratio { b }, &s, &medium, rng, st)
            });
            unbiased_run(&label, &st);
        }
    }
}

#[test]
fn residual_ratio_tracking_transmittance() {
    for s in scenes() {
        for (control, b) in [
            (ControlExtinction::SegmentMinorant, 1.0),
            (ControlExtinction::FractionOfBound(0.8), 1.0),
            (ControlExtinction::Constant(1.0), 0.75),
        ] {
            let medium = s.medium(control);
            let label = format!("residual ratio {control:?} b={b} {}", s.name);
            let st = check(&label, 6, N, s.transmittance(), |rng, st| {
                estimate(&tr::ResidualRatio { b }, &s, &medium, rng, st)
            });
            unbiased_run(&label, &st);
        }
    }
}

/// Residual ratio tracking with the exact control of a homogeneous medium is deterministic
/// and needs no lookup at all.
#[test]
fn residual_ratio_exact_control_is_free() {
    let s = &scenes()[0];
    let medium = s.medium(ControlExtinction::SegmentMinorant);
    let mut st = TrackingStats::default();
    let mut rng = Rng::new(0, 0, 7);
    let t = tr::transmittance(
        &tr::ResidualRatio { b: 1.0 },
        s.segments.iter().copied(),
        s.t_max,
        &medium,
        &mut rng,
        &mut st,
    );
    assert!((t as f64 - s.transmittance()).abs() < 1e-6, "{t}");
    assert_eq!(st.lookups, 0);
}

/// Spectral tracking on a grey medium (all channels equal) must reduce to grey transmittance.
#[test]
fn spectral_tracking_transmittance_grey() {
    for s in scenes() {
        let f = s.sigma_t;
        let medium = FnMediumRgb(move |t: f32| {
            let c = Coeffs::from_sigma_t(f(t), common::ALBEDO);
            CoeffsRgb::new(Vec3::splat(c.sigma_a), Vec3::splat(c.sigma_s))
        });
        for mode in [
            SpectralProbabilities::HistoryAwareMax,
            SpectralProbabilities::HistoryAwareAverage,
        ] {
            for b in [1.0, 0.5] {
                let label = format!("spectral {mode:?} b={b} grey {}", s.name);
                let st = check(&label, 8, N, s.transmittance(), |rng, st| {
                    tr::transmittance(
                        &tr::Spectral {
                            b,
                            mode,
                            beta: Vec3::ONE,
                        },
                        s.segments.iter().copied(),
                        s.t_max,
                        &medium,
                        rng,
                        st,
                    )
                    .x as f64
                });
                unbiased_run(&label, &st);
            }
        }
    }
}

/// Chromatic extinction `sigma_t,c = k_c sigma(t)`: each channel must give `exp(-k_c tau)`.
#[test]
fn spectral_tracking_transmittance_per_channel() {
    let k = Vec3::new(0.4, 1.0, 2.0);
    for s in scenes() {
        let f = s.sigma_t;
        let medium = FnMediumRgb(move |t: f32| CoeffsRgb::new(0.3 * k * f(t), 0.7 * k * f(t)));
        // The majorant must bound the largest channel: scale the segments by max k.
        let segs: Vec<_> = s
            .segments
            .iter()
            .map(|g| brume::volume::MajorantSegment {
                sigma_maj: g.sigma_maj * 2.0,
                sigma_min: g.sigma_min * 0.4,
                ..*g
            })
            .collect();
        let tau = (s.tau)(s.t_max as f64);
        for mode in [
            SpectralProbabilities::HistoryAwareMax,
            SpectralProbabilities::HistoryAwareAverage,
        ] {
            let mut ms = [Moments::default(); 3];
            let mut st = TrackingStats::default();
            for i in 0..common::samples(N) {
                let mut rng = Rng::new(i, 0, 9);
                let t = tr::transmittance(
                    &tr::Spectral {
                        b: 1.0,
                        mode,
                        beta: Vec3::ONE,
                    },
                    segs.iter().copied(),
                    s.t_max,
                    &medium,
                    &mut rng,
                    &mut st,
                );
                for c in 0..3 {
                    ms[c].push(t[c] as f64);
                }
            }
            for c in 0..3 {
                assert_z(
                    &format!("spectral {mode:?} channel {c} {}", s.name),
                    &ms[c],
                    (-(k[c] as f64) * tau).exp(),
                );
            }
            unbiased_run("spectral chromatic", &st);
        }
    }
}

/// The scenes' control policies must never look anything up.
#[test]
fn control_is_lookup_free() {
    let s: &Scene = &scenes()[2];
    let counter = std::cell::Cell::new(0u32);
    let f = s.sigma_t;
    let medium = brume::volume::tracking::FnMedium::with_control(
        |t| {
            counter.set(counter.get() + 1);
            Coeffs::from_sigma_t(f(t), 0.5)
        },
        ControlExtinction::SegmentMinorant,
        0.5,
    );
    for g in &s.segments {
        let _ = medium.control(g);
    }
    assert_eq!(counter.get(), 0);
}

/// Every transmittance estimator over the culled global walk (`volume::cull`): one segment
/// with the largest bound, its collisions thinned back to the hand-built segments' bounds.
/// Controls are the segment minorant (0 over the global segment), as in a culled render.
#[test]
fn culled_global_walk_transmittance() {
    for s in scenes() {
        let (global, ratio) = s.culled();
        let seg = || std::iter::once(global);
        // A second stage thins the kept collisions again (`Scene::voxel_ratio`).
        let voxel = |t: f32, bound: f32| s.voxel_ratio(t, bound);
        let culled = |control| CulledBy {
            inner: s.medium(control),
            ratio: &ratio,
            voxel: &voxel,
        };
        let none = culled(ControlExtinction::None);
        let minorant = culled(ControlExtinction::SegmentMinorant);
        let t = s.transmittance();
        let mut runs: Vec<(String, TrackingStats)> = Vec::new();
        let mut run =
            |label: String, seed, est: &mut dyn FnMut(&mut Rng, &mut TrackingStats) -> f32| {
                let st = check(&label, seed, N, t, |rng, st| est(rng, st) as f64);
                unbiased_run(&label, &st);
                runs.push((label, st));
            };
        let weighted_delta = tr::WeightedDelta { b: 2.0 };
        let weighted_decomposition = tr::WeightedDecomposition { b: 1.0 };
        let residual_ratio = tr::ResidualRatio { b: 1.0 };
        run(format!("culled delta {}", s.name), 21, &mut |rng, st| {
            tr::transmittance(&tr::Delta, seg(), s.t_max, &none, rng, st)
        });
        run(
            format!("culled weighted delta b=2 {}", s.name),
            22,
            &mut |rng, st| tr::transmittance(&weighted_delta, seg(), s.t_max, &none, rng, st),
        );
        run(
            format!("culled decomposition {}", s.name),
            23,
            &mut |rng, st| {
                tr::transmittance(&tr::Decomposition, seg(), s.t_max, &minorant, rng, st)
            },
        );
        run(
            format!("culled weighted decomposition {}", s.name),
            24,
            &mut |rng, st| {
                tr::transmittance(&weighted_decomposition, seg(), s.t_max, &minorant, rng, st)
            },
        );
        run(format!("culled ratio {}", s.name), 25, &mut |rng, st| {
            tr::transmittance(&tr::Ratio { b: 1.0 }, seg(), s.t_max, &none, rng, st)
        });
        run(
            format!("culled residual ratio {}", s.name),
            26,
            &mut |rng, st| tr::transmittance(&residual_ratio, seg(), s.t_max, &minorant, rng, st),
        );
        // Thinned back to the segments' bounds, ratio tracking looks up as often as it does on
        // the segments themselves (within noise), never more than on the global segment.
        let ratio_culled = runs[4].1.lookups;
        let plain = check("ratio, global segment", 25, N, t, |rng, st| {
            tr::transmittance(
                &tr::Ratio { b: 1.0 },
                seg(),
                s.t_max,
                &s.medium(ControlExtinction::None),
                rng,
                st,
            ) as f64
        });
        assert!(
            ratio_culled <= plain.lookups,
            "{}: culling added lookups ({ratio_culled} against {})",
            s.name,
            plain.lookups
        );
    }
}

/// Ratio and residual ratio tracking never take the per-voxel stage (`tracking::voxel_stage`):
/// their variance `T^2 (exp(int sigma^2 / mu dt) - 1)` grows as the majorant `mu` tightens.
/// With a second stage that would thin every kept collision by half, both draw exactly what
/// they draw without it (same seeds: the same estimates and lookups), while delta tracking,
/// whose variance does not depend on the majorant, is thinned (fewer lookups).
#[test]
fn ratio_tracking_ignores_the_voxel_stage() {
    for s in scenes() {
        let (global, ratio) = s.culled();
        let seg = || std::iter::once(global);
        let half = |_t: f32, _bound: f32| 0.5f32;
        let (ratio_tracking, residual_ratio) = (tr::Ratio { b: 1.0 }, tr::ResidualRatio { b: 1.0 });
        let medium = |control, voxel: &dyn Fn(f32, f32) -> f32| {
            let inner = s.medium(control);
            let rng = &mut Rng::new(3, 5, 7);
            let st = &mut TrackingStats::default();
            let culled = CulledBy {
                inner,
                ratio: &ratio,
                voxel,
            };
            let mut out = Vec::new();
            for _ in 0..2000 {
                out.push(match control {
                    ControlExtinction::None => {
                        tr::transmittance(&ratio_tracking, seg(), s.t_max, &culled, rng, st)
                    }
                    _ => tr::transmittance(&residual_ratio, seg(), s.t_max, &culled, rng, st),
                });
            }
            (out, st.lookups)
        };
        for control in [ControlExtinction::None, ControlExtinction::SegmentMinorant] {
            let (plain, plain_lookups) = medium(control, &common::culled::no_voxel);
            let (halved, halved_lookups) = medium(control, &half);
            assert_eq!(plain, halved, "{} {control:?}: estimates differ", s.name);
            assert_eq!(plain_lookups, halved_lookups, "{} {control:?}", s.name);
        }
        let delta_lookups = |voxel: &dyn Fn(f32, f32) -> f32| {
            let culled = CulledBy {
                inner: s.medium(ControlExtinction::None),
                ratio: &ratio,
                voxel,
            };
            let (mut rng, mut st) = (Rng::new(3, 5, 7), TrackingStats::default());
            for _ in 0..2000 {
                tr::transmittance(&tr::Delta, seg(), s.t_max, &culled, &mut rng, &mut st);
            }
            st.lookups
        };
        let (plain, halved) = (
            delta_lookups(&common::culled::no_voxel),
            delta_lookups(&half),
        );
        assert!(
            halved < plain,
            "{}: delta tracking {halved} >= {plain}",
            s.name
        );
    }
}
