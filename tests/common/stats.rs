//! Helpers shared by the statistical tests: running moments, the z-test, and media whose
//! transmittance is known in closed form, with hand-built majorant segments.
#![allow(dead_code)]

use brume::volume::tracking::{Coeffs, ControlExtinction, FnMedium};
use brume::volume::MajorantSegment;

/// Two-sided z critical value at 99.9 %.
pub const Z_CRIT: f64 = 3.3;

/// `n` scaled by the environment variable `BRUME_STAT_SCALE` (default 1): the suite runs
/// quickly by default and can be re-run with many more samples to hunt small biases.
pub fn samples(n: u32) -> u32 {
    let scale: f64 = std::env::var("BRUME_STAT_SCALE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1.0);
    ((n as f64) * scale).max(2.0) as u32
}

/// Running mean and variance in f64 (Welford).
#[derive(Clone, Copy, Debug, Default)]
pub struct Moments {
    pub n: u64,
    mean: f64,
    m2: f64,
}

impl Moments {
    pub fn push(&mut self, x: f64) {
        self.n += 1;
        let d = x - self.mean;
        self.mean += d / self.n as f64;
        self.m2 += d * (x - self.mean);
    }

    pub fn mean(&self) -> f64 {
        self.mean
    }

    /// Standard error of the mean, estimated from the sample.
    pub fn std_err(&self) -> f64 {
        if self.n < 2 {
            return f64::INFINITY;
        }
        (self.m2 / (self.n - 1) as f64 / self.n as f64).sqrt()
    }
}

/// Asserts `|mean - expected| < Z_CRIT * std_err` and prints the z-score. A zero standard
/// error (a deterministic estimator) must match to f32 precision instead.
pub fn assert_z(label: &str, m: &Moments, expected: f64) -> f64 {
    let se = m.std_err();
    let diff = m.mean() - expected;
    let z = if se > 0.0 { diff / se } else { 0.0 };
    println!(
        "{label:<60} mean {:>9.5} expected {:>9.5} se {:.2e} z {:+.2}",
        m.mean(),
        expected,
        se,
        z
    );
    if se > 0.0 {
        assert!(
            z.abs() < Z_CRIT,
            "{label}: mean {} vs expected {expected}, z = {z:.2}",
            m.mean()
        );
    } else {
        assert!(
            diff.abs() <= 1e-5 * expected.abs().max(1.0),
            "{label}: deterministic {} vs {expected}",
            m.mean()
        );
    }
    z
}

/// Albedo of every test medium: `sigma_s = ALBEDO sigma_t`.
pub const ALBEDO: f32 = 0.7;

/// A grey medium on `[0, t_max]` whose optical depth is known in closed form, with the
/// majorant segments a DDA would give (built by hand).
pub struct Scene {
    pub name: &'static str,
    pub segments: Vec<MajorantSegment>,
    pub t_max: f32,
    pub sigma_t: fn(f32) -> f32,
    /// `tau(t) = int_0^t sigma_t`, f64.
    pub tau: fn(f64) -> f64,
    /// Smallest sigma_t anywhere on the ray (for controls "above the minorant").
    pub true_min: f32,
}

impl Scene {
    pub fn transmittance(&self) -> f64 {
        (-(self.tau)(self.t_max as f64)).exp()
    }

    /// The culled global walk over the scene: ONE segment from the first segment's start to
    /// the last one's end with the largest majorant and minorant 0, and the ratio at `t` of
    /// the hand-built segment's majorant there (0 in a gap) to that global majorant, which
    /// the culling of `tracking::sample_free_flight` thins the global walk's collisions by.
    pub fn culled(&self) -> (MajorantSegment, impl Fn(f32) -> f32 + '_) {
        let global = self.segments.iter().fold(0.0f32, |m, s| m.max(s.sigma_maj));
        let seg = MajorantSegment {
            t_min: self.segments[0].t_min,
            t_max: self.segments[self.segments.len() - 1].t_max,
            sigma_maj: global,
            sigma_min: 0.0,
        };
        let ratio = move |t: f32| {
            self.segments
                .iter()
                .find(|s| s.t_min <= t && t < s.t_max)
                .map_or(0.0, |s| s.sigma_maj / global)
        };
        (seg, ratio)
    }

    /// A second culling stage for the culled walk (`Medium::voxel_ratio`): thins a collision
    /// kept with raw majorant `bound` down to the pointwise bound `1.25 sigma_t(t)`, as the
    /// per-voxel bounds thin the renderer's.
    pub fn voxel_ratio(&self, t: f32, bound: f32) -> f32 {
        let fine = 1.25 * (self.sigma_t)(t);
        if fine < bound {
            fine / bound
        } else {
            1.0
        }
    }

    /// The scene as a `Medium` with the given control policy (albedo `ALBEDO` everywhere, so
    /// the control's split is known without a lookup).
    pub fn medium(&self, control: ControlExtinction) -> FnMedium<impl Fn(f32) -> Coeffs> {
        let f = self.sigma_t;
        FnMedium::with_control(move |t| Coeffs::from_sigma_t(f(t), ALBEDO), control, ALBEDO)
    }
}

fn seg(t_min: f32, t_max: f32, sigma_maj: f32, sigma_min: f32) -> MajorantSegment {
    MajorantSegment {
        t_min,
        t_max,
        sigma_maj,
        sigma_min,
    }
}

fn homogeneous(_t: f32) -> f32 {
    2.0
}

fn homogeneous_tau(t: f64) -> f64 {
    2.0 * t
}

/// Piecewise constant: tight, loose, empty-but-bounded, tight, zero-majorant, a gap with no
/// segment, then a loose piece cut by `t_max`.
fn piecewise(t: f32) -> f32 {
    match t {
        t if t < 0.3 => 1.0,
        t if t < 0.7 => 3.0,
        t if t < 1.0 => 0.0,
        t if t < 1.4 => 2.0,
        t if t < 1.8 => 0.0,
        _ => 0.5,
    }
}

fn piecewise_tau(t: f64) -> f64 {
    let pieces = [
        (0.0, 0.3, 1.0),
        (0.3, 0.7, 3.0),
        (0.7, 1.0, 0.0),
        (1.0, 1.4, 2.0),
        (1.4, 1.8, 0.0),
        (1.8, 10.0, 0.5),
    ];
    pieces
        .iter()
        .map(|&(a, b, s)| s * (t.min(b) - a).max(0.0))
        .sum()
}

/// Linear ramp `sigma_t = 2 t`.
fn ramp(t: f32) -> f32 {
    2.0 * t
}

fn ramp_tau(t: f64) -> f64 {
    t * t
}

pub fn scenes() -> Vec<Scene> {
    let ramp_local = (0..6)
        .map(|i| {
            let (a, b) = (0.25 * i as f32, 0.25 * (i + 1) as f32);
            // Alternate tight and loose (x1.5) bounds, tight minorants.
            let loose = if i % 2 == 1 { 1.5 } else { 1.0 };
            seg(a, b, loose * ramp(b), ramp(a))
        })
        .collect();
    vec![
        Scene {
            name: "homogeneous/tight",
            segments: vec![seg(0.0, 0.8, 2.0, 2.0)],
            t_max: 0.8,
            sigma_t: homogeneous,
            tau: homogeneous_tau,
            true_min: 2.0,
        },
        Scene {
            name: "homogeneous/loose",
            segments: vec![seg(0.0, 0.8, 3.0, 1.0)],
            t_max: 0.8,
            sigma_t: homogeneous,
            tau: homogeneous_tau,
            true_min: 2.0,
        },
        Scene {
            name: "piecewise",
            segments: vec![
                seg(0.0, 0.3, 1.0, 1.0),
                seg(0.3, 0.7, 5.0, 2.0),
                seg(0.7, 1.0, 0.5, 0.0),
                seg(1.0, 1.4, 2.0, 2.0),
                seg(1.4, 1.6, 0.0, 0.0),
                seg(1.8, 2.5, 1.0, 0.25),
            ],
            t_max: 1.9,
            sigma_t: piecewise,
            tau: piecewise_tau,
            true_min: 0.0,
        },
        Scene {
            name: "ramp/global",
            segments: vec![seg(0.0, 1.5, 3.0, 0.0)],
            t_max: 1.5,
            sigma_t: ramp,
            tau: ramp_tau,
            true_min: 0.0,
        },
        Scene {
            name: "ramp/local",
            segments: ramp_local,
            t_max: 1.5,
            sigma_t: ramp,
            tau: ramp_tau,
            true_min: 0.0,
        },
    ]
}
