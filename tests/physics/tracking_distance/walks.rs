//! Whole walks rather than single flights: the heterogeneous furnace (every estimator's random
//! walk keeps its energy) and the distance samplers over the culled global walk.
use super::*;

/// Heterogeneous furnace: a slab `0 < z < 1` with `sigma_t = 2 + 2 z`, albedo 1, lit by
/// uniform radiance 1 from outside. Every estimator's random walk must return 1 exactly
/// in expectation (only geometry and scattering change the path, never its energy).
#[test]
fn furnace_slab() {
    let g = HenyeyGreenstein::new(0.6);
    let run = |which: u32, b: f32, seed: u32| {
        // Grey estimators use channel 0 only; spectral tracking checks every channel (the
        // expectation is per channel: a min or product over channels would not be 1).
        let mut m = [Moments::default(); 3];
        let mut st = TrackingStats::default();
        for i in 0..samples(50_000) {
            let mut rng = Rng::new(i, 10, seed);
            let mut p = Vec3::new(0.0, 0.0, 0.0);
            let mut d = Vec3::new(0.3, 0.1, 1.0).normalize();
            let mut beta = 1.0f32;
            let mut beta_rgb = Vec3::ONE;
            loop {
                // Distance to the slab's far side along d.
                let t_exit = if d.z > 0.0 {
                    (1.0 - p.z) / d.z
                } else if d.z < 0.0 {
                    -p.z / d.z
                } else {
                    f32::INFINITY
                };
                let seg = [MajorantSegment {
                    t_min: 0.0,
                    t_max: t_exit,
                    sigma_maj: 4.0,
                    sigma_min: 2.0,
                }];
                let (o, dir) = (p, d);
                let sigma = move |t: f32| 2.0 + 2.0 * (o.z + t * dir.z).clamp(0.0, 1.0);
                let medium = FnMedium::with_control(
                    move |t| Coeffs::from_sigma_t(sigma(t), 1.0),
                    ControlExtinction::SegmentMinorant,
                    1.0,
                );
                let rgb = FnMediumRgb(move |t: f32| {
                    CoeffsRgb::new(Vec3::ZERO, Vec3::new(1.0, 0.5, 0.75) * sigma(t))
                });
                // One flight of a grey estimator.
                macro_rules! grey {
                    ($estimator:expr) => {
                        tr::sample_distance(&$estimator, seg, t_exit, &medium, &mut rng, &mut st)
                    };
                }
                let e = match which {
                    0 => grey!(tr::Delta),
                    1 => grey!(tr::WeightedDelta { b }),
                    2 => grey!(tr::Decomposition),
                    3 => grey!(tr::WeightedDecomposition { b }),
                    _ => match tr::sample_distance(
                        &tr::Spectral {
                            b,
                            mode: SpectralProbabilities::HistoryAwareMax,
                            beta: beta_rgb,
                        },
                        seg,
                        t_exit,
                        &rgb,
                        &mut rng,
                        &mut st,
                    ) {
                        Event::Scatter { t, weight } => {
                            beta_rgb *= weight;
                            Event::Scatter { t, weight: 1.0 }
                        }
                        Event::Escape { weight } => {
                            beta_rgb *= weight;
                            Event::Escape { weight: 1.0 }
                        }
                        Event::Absorb { t, .. } => {
                            beta_rgb = Vec3::ZERO;
                            Event::Absorb { t, weight: 0.0 }
                        }
                    },
                };
                match e {
                    Event::Escape { weight } => {
                        beta *= weight;
                        break;
                    }
                    Event::Absorb { .. } => {
                        beta = 0.0;
                        break;
                    }
                    Event::Scatter { t, weight } => {
                        beta *= weight;
                        p += t * d;
                        d = g.sample(-d, rng.uniform_vec2()).wi;
                    }
                }
            }
            let est = if which == 4 {
                beta_rgb
            } else {
                Vec3::splat(beta)
            };
            for c in 0..3 {
                m[c].push(est[c] as f64);
            }
        }
        (m, st)
    };
    // b = 0.9 leaves the majorant (3.6) below sigma_t only where z > 0.8: over the dozens of
    // bounces of an albedo-1 walk, smaller b makes |w| explode (b = 0.7 gave |mean| ~ 20 with a
    // standard error as large: unbiased but useless as a test).
    for (which, b, name) in [
        (0, 1.0, "delta"),
        (1, 0.9, "weighted delta b=0.9"),
        (2, 1.0, "decomposition"),
        (3, 0.9, "weighted decomposition b=0.9"),
        (4, 1.0, "spectral"),
    ] {
        let (m, st) = run(which, b, 23 + which);
        let channels = if which == 4 { 3 } else { 1 };
        for (c, mc) in m.iter().enumerate().take(channels) {
            assert_z(&format!("furnace {name} channel {c}"), mc, 1.0);
        }
        println!("    max |w| = {:.3e}", st.max_abs_weight);
        assert!(!st.is_biased(), "{name}: {st:?}");
    }
}

/// The distance samplers over the culled global walk (`volume::cull`): one segment with the
/// largest bound, its collisions thinned back to the hand-built segments' bounds, with the
/// segment minorant (0 there) as control as in a culled render. The same three expectations as
/// `distance_samplers_score_the_right_expectations`, and delta tracking's collision distances
/// against the free-flight pdf (chi-square).
#[test]
fn culled_global_walk_samples_the_right_distances() {
    const BINS: usize = 40;
    let all = scenes();
    let alpha = sidak(0.01, all.len());
    for s in &all {
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
        let rgb = CulledBy {
            inner: FnMediumRgb(|t: f32| {
                let c = Coeffs::from_sigma_t((s.sigma_t)(t), ALBEDO);
                CoeffsRgb::new(Vec3::splat(c.sigma_a), Vec3::splat(c.sigma_s))
            }),
            ratio: &ratio,
            voxel: &voxel,
        };
        let t_end = s.transmittance();
        let t_mid = 0.5 * s.t_max;
        let t_half = (-(s.tau)(t_mid as f64)).exp();
        type Sample<'a> = Box<dyn Fn(&mut Rng, &mut TrackingStats) -> Event<f32> + 'a>;
        let samplers: [(&str, Sample); 5] = [
            (
                "delta",
                Box::new(|rng, st| tr::sample_distance(&tr::Delta, seg(), s.t_max, &none, rng, st)),
            ),
            (
                "weighted delta b=0.5",
                Box::new(|rng, st| {
                    tr::sample_distance(
                        &tr::WeightedDelta { b: 0.5 },
                        seg(),
                        s.t_max,
                        &none,
                        rng,
                        st,
                    )
                }),
            ),
            (
                "decomposition",
                Box::new(|rng, st| {
                    tr::sample_distance(&tr::Decomposition, seg(), s.t_max, &minorant, rng, st)
                }),
            ),
            (
                "weighted decomposition b=0.5",
                Box::new(|rng, st| {
                    tr::sample_distance(
                        &tr::WeightedDecomposition { b: 0.5 },
                        seg(),
                        s.t_max,
                        &minorant,
                        rng,
                        st,
                    )
                }),
            ),
            (
                "spectral",
                Box::new(|rng, st| {
                    let e = tr::sample_distance(
                        &tr::Spectral {
                            b: 1.0,
                            mode: SpectralProbabilities::HistoryAwareMax,
                            beta: Vec3::ONE,
                        },
                        seg(),
                        s.t_max,
                        &rgb,
                        rng,
                        st,
                    );
                    match e {
                        Event::Absorb { t, weight } => Event::Absorb {
                            t,
                            weight: weight.x,
                        },
                        Event::Scatter { t, weight } => Event::Scatter {
                            t,
                            weight: weight.x,
                        },
                        Event::Escape { weight } => Event::Escape { weight: weight.x },
                    }
                }),
            ),
        ];
        for (k, (name, sample)) in samplers.iter().enumerate() {
            let mut st = TrackingStats::default();
            let (mut esc, mut sca, mut abs) =
                (Moments::default(), Moments::default(), Moments::default());
            // b < 1: heavy-tailed weights, as in the unculled test.
            let n = samples(if name.contains("b=0.5") { 16 * N } else { N });
            let mut ts = Vec::new();
            let mut escaped = 0.0;
            for i in 0..n {
                let mut rng = Rng::new(i, 3, 30 + k as u32);
                let e = sample(&mut rng, &mut st);
                let (mut xe, mut xs, mut xa) = (0.0, 0.0, 0.0);
                match e {
                    Event::Escape { weight } => {
                        xe = weight as f64;
                        escaped += 1.0;
                    }
                    Event::Scatter { t, weight } => {
                        ts.push(t as f64);
                        if t < t_mid {
                            xs = weight as f64;
                        }
                    }
                    Event::Absorb { t, weight } => {
                        ts.push(t as f64);
                        xa = weight as f64;
                    }
                }
                esc.push(xe);
                sca.push(xs);
                abs.push(xa);
            }
            let label = format!("culled {name} {}", s.name);
            assert_z(&format!("{label} escape"), &esc, t_end);
            assert_z(
                &format!("{label} scatter t<t_max/2"),
                &sca,
                ALBEDO as f64 * (1.0 - t_half),
            );
            assert_z(
                &format!("{label} absorb"),
                &abs,
                (1.0 - ALBEDO as f64) * (1.0 - t_end),
            );
            assert!(!st.is_biased(), "{label}: {st:?}");
            if k == 0 {
                let (f, tau) = (s.sigma_t, s.tau);
                let pdf = move |t: f64| f(t as f32) as f64 * (-tau(t)).exp();
                let mut obs = histogram_1d(ts, 0.0, s.t_max as f64, BINS);
                let mut exp = expected_1d(n as f64, &pdf, 0.0, s.t_max as f64, BINS, 1e-9);
                obs.push(escaped);
                exp.push(n as f64 * t_end);
                let r = chi2_test(&obs, &exp, 5.0);
                println!(
                    "{label}: chi2 {:.1} dof {} p {:.4} (alpha {alpha:.2e})",
                    r.statistic, r.dof, r.p_value
                );
                assert!(r.p_value >= alpha, "{label}: {r:?}");
            }
        }
    }
}
