//! VDB media inside a homogeneous medium (`integrator::nested`): the homogeneous medium's
//! closed-form flight, then the VDB flight cut short at its collision, against the merged
//! flight through their sum (`integrator::mixture`), which tracks the sum's coefficients
//! directly. Both are unbiased estimators of the same free-flight functional, so for each ray
//! the expected weight that scatters in each stretch of the ray, split by the medium that
//! scattered, and the expected escape weight must agree: a z-test per ray, stretch, medium and
//! channel, Sidak-corrected at 99.9 % over all of them, independent random streams. Grey and
//! chromatic homogeneous media; delta, decomposition, the weighted estimators and spectral
//! tracking; the adaptive and global majorants; and an emitting medium (the fire's) inside a
//! grey one, whose gathered emission is tested the same way.
use crate::common;
use common::render::{load_scene, sidak_z};

use brume::integrator::features::{bit, Features, Variant};
use brume::integrator::mixture::{sample_mixture, RayMedia, VdbSpan};
use brume::integrator::{media::Emitted, media::Flight, media::MediumEvent};
use brume::integrator::{nested::nested_applies, nested::sample_nested};
use brume::math::Ray;
use brume::render::{media::HomogeneousMedium, media::MediaStats, media::TrackingConfig};
use brume::render::{
    Absorption, Estimator, MajorantMode, RenderScene, RenderSettings, ShadowEstimator,
};
use brume::sampling::Rng;
use brume::volume::phases::Phase;
use glam::Vec3;

/// Stretches of each ray the scattered weight is binned into.
const BINS: usize = 6;
/// Rays per configuration, flights per ray and method.
const RAYS: usize = 8;
const FLIGHTS: u32 = 12_000;

/// Per ray: running sums (weight, weight^2) of scatter by (stretch, medium), escape, emission.
#[derive(Clone)]
struct Tally {
    sum: Vec<[f64; 3]>,
    sum2: Vec<[f64; 3]>,
}

/// Slots of a tally: `BINS` stretches x 2 media (VDB, homogeneous), escape, emission.
const SLOTS: usize = 2 * BINS + 2;

impl Tally {
    fn new() -> Self {
        Tally {
            sum: vec![[0.0; 3]; SLOTS],
            sum2: vec![[0.0; 3]; SLOTS],
        }
    }

    /// One flight's contributions (a flight adds to at most one scatter or escape slot, and
    /// the emission slot; every other slot gets a zero).
    fn add(&mut self, slot: Option<usize>, w: Vec3, emitted: Vec3) {
        for (s, v) in [(slot, w), (Some(SLOTS - 1), emitted)] {
            if let Some(s) = s {
                for c in 0..3 {
                    let x = v[c] as f64;
                    self.sum[s][c] += x;
                    self.sum2[s][c] += x * x;
                }
            }
        }
    }
}

/// The rays: from a sphere around the medium's world bounds towards random points inside.
fn rays(lo: Vec3, hi: Vec3, seed: u32) -> Vec<(Ray, f32)> {
    let mut rng = Rng::new(seed, 0, 77);
    let centre = (lo + hi) * 0.5;
    let radius = 0.5 * (hi - lo).length() + 0.1;
    (0..RAYS)
        .map(|_| {
            let z = 2.0 * rng.uniform_f32() - 1.0;
            let phi = std::f32::consts::TAU * rng.uniform_f32();
            let r = (1.0 - z * z).max(0.0).sqrt();
            let o = centre + radius * Vec3::new(r * phi.cos(), r * phi.sin(), z);
            let target =
                lo + (hi - lo) * Vec3::new(rng.uniform_f32(), rng.uniform_f32(), rng.uniform_f32());
            (Ray::new(o, (target - o).normalize()), 2.0 * radius)
        })
        .collect()
}

/// Tallies `FLIGHTS` flights along `ray` over `[0, t1]` by the nested flight (`nested`) or
/// the merged one.
#[allow(clippy::too_many_arguments)]
fn tally<F: Features>(
    nested: bool,
    span: VdbSpan,
    hom: &HomogeneousMedium,
    vdb_g: f32,
    ray: &Ray,
    t1: f32,
    cfg: &TrackingConfig,
    seed: u32,
) -> Tally {
    let mut t = Tally::new();
    let spans = [span];
    let mut stats = MediaStats::default();
    for i in 0..FLIGHTS {
        let mut rng = Rng::new(i, seed, 0x5eed);
        let mut l = Vec3::ZERO;
        let media = RayMedia {
            vdb: &spans,
            hom: Some(hom),
            ray,
            t0: 0.0,
            t1,
        };
        let f = Flight {
            cfg,
            rng: &mut rng,
            stats: &mut stats,
            l: Emitted {
                mis: None,
                l: &mut l,
                groups: None,
            },
        };
        let (event, phase): (MediumEvent, Phase) = if nested {
            sample_nested::<F>(media, Vec3::ONE, f)
        } else {
            sample_mixture::<F>(media, Vec3::ONE, f)
        };
        match event {
            MediumEvent::Scatter { t: ts, weight } => {
                let bin = ((ts / t1 * BINS as f32) as usize).min(BINS - 1);
                let medium = usize::from(phase.henyey_greenstein_g() != Some(vdb_g));
                t.add(Some(2 * bin + medium), weight, l);
            }
            MediumEvent::Escape { weight } => t.add(Some(2 * BINS), weight, l),
            MediumEvent::Absorb => t.add(None, Vec3::ZERO, l),
        }
    }
    t
}

/// z of the difference of two tallies' means in one slot and channel (0 where both are
/// exactly equal, e.g. both zero).
fn z(a: &Tally, b: &Tally, s: usize, c: usize) -> f64 {
    let n = FLIGHTS as f64;
    let (ma, mb) = (a.sum[s][c] / n, b.sum[s][c] / n);
    let va = (a.sum2[s][c] / n - ma * ma).max(0.0) / n;
    let vb = (b.sum2[s][c] / n - mb * mb).max(0.0) / n;
    if ma == mb {
        0.0
    } else {
        (ma - mb) / (va + vb).sqrt().max(1e-12)
    }
}

fn cfg(estimator: Estimator, majorant: MajorantMode, spectral: bool) -> TrackingConfig {
    TrackingConfig::from_settings(&RenderSettings {
        estimator,
        majorant,
        force_spectral: spectral,
        shadow: ShadowEstimator::Auto,
        absorption: Absorption::Weight,
        ..RenderSettings::default()
    })
}

/// Every configuration's z-scores for the medium of `scene` inside each homogeneous medium of
/// `homs` (extinction per unit of the medium's world size). The flights are compiled for the
/// features `Grey` around a grey homogeneous medium, `Chromatic` around a chromatic one.
fn check<Grey: Features, Chromatic: Features>(
    scene: &str,
    homs: &[(Vec3, Vec3)],
    configs: &[(Estimator, MajorantMode, bool)],
) {
    let loaded = load_scene(scene);
    let rs = RenderScene::new(&loaded, false).unwrap();
    let m = &rs.vdb[0];
    let (lo, hi) = (m.world_bounds.min, m.world_bounds.max);
    let size = (hi - lo).max_element();
    let mut zs = Vec::new();
    let mut scattered = [0.0f64; 2];
    for (h_index, &(sigma_a, sigma_s)) in homs.iter().enumerate() {
        let hom = HomogeneousMedium {
            sigma_a: sigma_a / size,
            sigma_s: sigma_s / size,
            // Unlike the VDB medium's, so the scatter event names its medium.
            phase: Phase::hg(-0.45),
        };
        let chromatic = sigma_a + sigma_s != Vec3::splat((sigma_a + sigma_s).x);
        for (c_index, &(estimator, majorant, spectral)) in configs.iter().enumerate() {
            let cfg = cfg(estimator, majorant, spectral);
            for (r, (ray, t1)) in rays(lo, hi, 3 + h_index as u32).into_iter().enumerate() {
                let Some((a, b)) = m.world_bounds.intersect(&ray, 0.0, t1) else {
                    continue;
                };
                let span: VdbSpan = (m, a, b);
                assert!(nested_applies(&[span], &hom, cfg.absorption));
                let seed = (1000 * h_index + 100 * c_index + r) as u32;
                let g = m.phase.henyey_greenstein_g().unwrap();
                let run = |nested: bool, seed: u32| {
                    if chromatic {
                        tally::<Chromatic>(nested, span, &hom, g, &ray, t1, &cfg, seed)
                    } else {
                        tally::<Grey>(nested, span, &hom, g, &ray, t1, &cfg, seed)
                    }
                };
                let (a, b) = (run(true, 2 * seed), run(false, 2 * seed + 1));
                for s in 0..SLOTS {
                    for c in 0..3 {
                        zs.push((z(&a, &b, s, c), format!("{scene} hom {h_index} {estimator:?} {majorant:?} spectral {spectral} ray {r} slot {s} channel {c}")));
                    }
                }
                for s in 0..BINS {
                    scattered[0] += a.sum[2 * s][0];
                    scattered[1] += a.sum[2 * s + 1][0];
                }
            }
        }
    }
    let threshold = sidak_z(1e-3, zs.len());
    let worst = zs
        .iter()
        .max_by(|x, y| x.0.abs().total_cmp(&y.0.abs()))
        .unwrap();
    println!(
        "{scene}: {} z-tests, worst |z| {:.2} ({}), threshold {threshold:.2}; scattered weight by the VDB medium {:.0}, by the homogeneous one {:.0}",
        zs.len(),
        worst.0.abs(),
        worst.1,
        scattered[0],
        scattered[1]
    );
    // Both media scatter often enough for the test to see either one's share.
    assert!(
        scattered[0] > 1000.0 && scattered[1] > 1000.0,
        "{scattered:?}"
    );
    let failing: Vec<_> = zs.iter().filter(|(z, _)| z.abs() > threshold).collect();
    assert!(failing.is_empty(), "{failing:?}");
}

#[test]
fn a_smoke_inside_a_homogeneous_medium_flies_as_the_merged_sum() {
    use Estimator::*;
    use MajorantMode::*;
    check::<Variant<0>, Variant<{ bit::CHROM }>>(
        "smoke_tank.gltf",
        &[
            // Grey, and chromatic (spectral MIS distances in the homogeneous part).
            (Vec3::splat(0.3), Vec3::splat(0.9)),
            (Vec3::new(0.05, 0.8, 2.0), Vec3::new(0.45, 0.4, 0.5)),
        ],
        &[
            (Delta, Adaptive, false),
            (Delta, Global, false),
            (Decomposition, Adaptive, false),
            (WeightedDelta, Adaptive, false),
            (WeightedDecomposition, Adaptive, false),
            (Delta, Adaptive, true),
        ],
    );
}

#[test]
fn an_emitting_medium_inside_a_grey_one_gathers_the_same_emission() {
    use Estimator::*;
    use MajorantMode::*;
    check::<Variant<{ bit::EMIT }>, Variant<{ bit::EMIT | bit::CHROM }>>(
        "fire.gltf",
        &[(Vec3::splat(0.2), Vec3::splat(0.8))],
        &[(Delta, Adaptive, false), (Decomposition, Global, false)],
    );
    // Chromatic extinction around an emitting medium goes to the merged flight: the nested
    // one would count emission with the survival of the homogeneous draw, not its
    // transmittance.
    let loaded = load_scene("fire.gltf");
    let rs = RenderScene::new(&loaded, false).unwrap();
    let m = &rs.vdb[0];
    let hom = HomogeneousMedium {
        sigma_a: Vec3::new(0.1, 0.2, 0.3),
        sigma_s: Vec3::splat(0.5),
        phase: Phase::hg(0.0),
    };
    assert!(!nested_applies(&[(m, 0.0, 1.0)], &hom, Absorption::Weight));
    // So do absorption events (the homogeneous absorption carries no distance to cut at).
    let grey = HomogeneousMedium {
        sigma_a: Vec3::splat(0.2),
        ..hom
    };
    assert!(nested_applies(&[(m, 0.0, 1.0)], &grey, Absorption::Weight));
    assert!(!nested_applies(&[(m, 0.0, 1.0)], &grey, Absorption::Event));
}
