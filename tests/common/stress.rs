//! Helpers of the stress suite (`tests/stress_*.rs`): a grey medium over a real `SparseGrid`
//! along an index-space ray, its exact optical depth, and one runner per estimator so that
//! every case is checked with every estimator and both majorant modes.
#![allow(dead_code)]
// Negated comparisons are NaN guards, as in the library.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use brume::math::Ray;
use brume::sampling::Rng;
use brume::volume::tracking::{self as tr, Coeffs, ControlExtinction, Medium, TrackingStats};
use brume::volume::{DdaMajorantIterator, LeafBounds, MajorantSegment, SparseGrid};
use glam::DVec3;

use super::stats::Moments;

/// A grey medium: `sigma_t = scale * trilinear(grid, ray(t))`, constant albedo.
pub struct GridMedium<'a> {
    pub grid: &'a SparseGrid,
    pub ray: Ray,
    pub scale: f32,
    pub albedo: f32,
    pub control: ControlExtinction,
}

impl Medium for GridMedium<'_> {
    fn coeffs(&self, t: f32) -> Coeffs {
        let p = self.ray.at(t);
        let d = self
            .grid
            .sample_trilinear(DVec3::new(p.x as f64, p.y as f64, p.z as f64));
        Coeffs::from_sigma_t(self.scale * d, self.albedo)
    }

    fn control(&self, seg: &MajorantSegment) -> Coeffs {
        Coeffs::from_sigma_t(self.control.sigma_c(seg), self.albedo)
    }
}

/// `integral_{t0}^{t1} sigma_t dt` along `ray` (index space), exactly: trilinear
/// reconstruction is a cubic in `t` between voxel-plane crossings, and Simpson's rule is exact
/// for cubics, so the ray is split at every integer plane and Simpson applied per piece.
pub fn optical_depth(grid: &SparseGrid, ray: &Ray, t0: f64, t1: f64, scale: f64) -> f64 {
    if !(t1 > t0) {
        return 0.0;
    }
    let o = ray.o.as_dvec3();
    let d = ray.d.as_dvec3();
    let mut cuts = vec![t0, t1];
    for a in 0..3 {
        if d[a] == 0.0 {
            continue;
        }
        let (x0, x1) = (o[a] + t0 * d[a], o[a] + t1 * d[a]);
        let (lo, hi) = (x0.min(x1).ceil() as i64, x0.max(x1).floor() as i64);
        assert!(hi - lo < 1_000_000, "optical_depth: ray too long in voxels");
        for k in lo..=hi {
            let t = (k as f64 - o[a]) / d[a];
            if t > t0 && t < t1 {
                cuts.push(t);
            }
        }
    }
    cuts.sort_by(f64::total_cmp);
    let f = |t: f64| grid.sample_trilinear(o + t * d) as f64;
    let mut tau = 0.0;
    for w in cuts.windows(2) {
        let (a, b) = (w[0], w[1]);
        if b > a {
            tau += (b - a) / 6.0 * (f(a) + 4.0 * f(0.5 * (a + b)) + f(b));
        }
    }
    tau * scale
}

/// Where the bounds come from, as in `MajorantMode`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    Global,
    Local,
}

pub fn segments<'a>(
    bounds: &'a LeafBounds,
    ray: &Ray,
    t0: f32,
    t1: f32,
    scale: f32,
    mode: Mode,
) -> DdaMajorantIterator<'a> {
    match mode {
        Mode::Global => DdaMajorantIterator::global(bounds, ray, t0, t1, scale),
        Mode::Local => DdaMajorantIterator::new(bounds, ray, t0, t1, scale),
    }
}

/// One estimator of `T` (transmittance) with its parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Est {
    /// Bernoulli delta tracking.
    Delta,
    /// Weighted delta tracking with scale `b`.
    WeightedDelta(f32),
    /// Analog decomposition with the given control (must be a true minorant).
    Decomposition(ControlExtinction),
    /// Weighted decomposition with scale `b` and any control.
    WeightedDecomposition(f32, ControlExtinction),
    Ratio(f32),
    ResidualRatio(f32, ControlExtinction),
    /// The escape weight of a distance sampler (`E[w 1{escape}] = T`): delta, weighted delta
    /// (b), decomposition, weighted decomposition (b, control).
    DistDelta,
    DistWeightedDelta(f32),
    DistDecomposition(ControlExtinction),
    DistWeightedDecomposition(f32, ControlExtinction),
}

impl Est {
    /// Every estimator, with non-bounding scale `b` and (for the decomposition family) the
    /// analog control `analog` (a true minorant) and the weighted control `weighted` (any).
    pub fn all(b: f32, analog: ControlExtinction, weighted: ControlExtinction) -> Vec<Est> {
        vec![
            Est::Delta,
            Est::WeightedDelta(b),
            Est::Decomposition(analog),
            Est::WeightedDecomposition(b, weighted),
            Est::Ratio(b),
            Est::ResidualRatio(b, weighted),
            Est::DistDelta,
            Est::DistWeightedDelta(b),
            Est::DistDecomposition(analog),
            Est::DistWeightedDecomposition(b, weighted),
        ]
    }

    pub fn control(&self) -> ControlExtinction {
        match *self {
            Est::Decomposition(c)
            | Est::WeightedDecomposition(_, c)
            | Est::ResidualRatio(_, c)
            | Est::DistDecomposition(c)
            | Est::DistWeightedDecomposition(_, c) => c,
            _ => ControlExtinction::None,
        }
    }

    /// Analog estimators need a bounding majorant; they are skipped where it does not bound.
    pub fn is_analog(&self) -> bool {
        matches!(
            self,
            Est::Delta | Est::Decomposition(_) | Est::DistDelta | Est::DistDecomposition(_)
        )
    }

    /// One estimate of `T` over `segs` up to `t_max`.
    pub fn run<I>(
        &self,
        segs: I,
        t_max: f32,
        m: &dyn Medium,
        rng: &mut Rng,
        st: &mut TrackingStats,
    ) -> f32
    where
        I: IntoIterator<Item = MajorantSegment>,
        I::IntoIter: Clone,
    {
        // The estimate of `T` by a transmittance estimator, and by the escape of a distance one.
        macro_rules! transmittance {
            ($estimator:expr) => {
                tr::transmittance(&$estimator, segs, t_max, m, rng, st)
            };
        }
        macro_rules! escape {
            ($estimator:expr) => {
                match tr::sample_distance(&$estimator, segs, t_max, m, rng, st) {
                    tr::Event::Escape { weight } => weight,
                    _ => 0.0,
                }
            };
        }
        match *self {
            Est::Delta => transmittance!(tr::Delta),
            Est::WeightedDelta(b) => transmittance!(tr::WeightedDelta { b }),
            Est::Decomposition(_) => transmittance!(tr::Decomposition),
            Est::WeightedDecomposition(b, _) => transmittance!(tr::WeightedDecomposition { b }),
            Est::Ratio(b) => transmittance!(tr::Ratio { b }),
            Est::ResidualRatio(b, _) => transmittance!(tr::ResidualRatio { b }),
            Est::DistDelta => escape!(tr::Delta),
            Est::DistWeightedDelta(b) => escape!(tr::WeightedDelta { b }),
            Est::DistDecomposition(_) => escape!(tr::Decomposition),
            Est::DistWeightedDecomposition(b, _) => escape!(tr::WeightedDecomposition { b }),
        }
    }
}

/// `n` estimates with seeds `(i, 0, seed)`: their moments, the tracker counters, and whether
/// every estimate was finite.
pub fn sample_many(
    n: u32,
    seed: u32,
    mut one: impl FnMut(&mut Rng, &mut TrackingStats) -> f32,
) -> (Moments, TrackingStats, bool) {
    let mut m = Moments::default();
    let mut st = TrackingStats::default();
    let mut finite = true;
    for i in 0..n {
        let mut rng = Rng::new(i, 0, seed);
        let x = one(&mut rng, &mut st);
        finite &= x.is_finite();
        m.push(x as f64);
    }
    (m, st, finite)
}

/// z-score of `m` against `expected` with the sample's standard error. When every estimate
/// was equal (zero sample variance) the standard error of a Bernoulli estimator with mean
/// `expected` is used instead, so that e.g. 20 000 zeros from an estimator of T = 4.5e-5 are
/// not "infinitely" wrong; an exact match scores 0.
pub fn z_of(m: &Moments, expected: f64) -> f64 {
    let se = m.std_err();
    let diff = m.mean() - expected;
    if se > 0.0 && se.is_finite() {
        diff / se
    } else if diff.abs() <= 1e-5 * expected.abs().max(1.0) {
        0.0
    } else {
        let p = expected.clamp(0.0, 1.0);
        let se = (p * (1.0 - p) / m.n.max(1) as f64).sqrt();
        if se > 0.0 {
            diff / se
        } else {
            f64::INFINITY
        }
    }
}

/// A small scene for the render stress tests: one VDB medium (written with
/// `brume_ffi::write_float_grids`), a perspective camera, optional point light and constant
/// environment, and no surfaces.
#[derive(Clone, Debug)]
pub struct StressScene {
    pub voxel_size: f64,
    /// World position of index (0, 0, 0).
    pub grid_origin: [f64; 3],
    /// Voxels `(index, value)`.
    pub voxels: Vec<([i32; 3], f32)>,
    /// The `BRUME_medium_vdb` object, without `uri` (added).
    pub medium: serde_json::Value,
    pub camera_at: [f64; 3],
    /// Unit quaternion `[x, y, z, w]` of the camera node (glTF cameras look down -Z).
    pub camera_rotation: [f64; 4],
    pub znear: f64,
    pub yfov: f64,
    pub point_light: Option<([f64; 3], f64)>,
    pub environment: Option<f64>,
}

impl StressScene {
    /// The blob (`n^3` voxels, peak 1) in front of a camera on +Z, under an environment of
    /// radiance 1: a white furnace when the medium's albedo is 1.
    pub fn furnace(n: i32, voxel_size: f64, medium: serde_json::Value) -> Self {
        let c = n as f64 * voxel_size * 0.5;
        StressScene {
            voxel_size,
            grid_origin: [-c + 0.5 * voxel_size; 3],
            voxels: blob_voxels(n),
            medium,
            camera_at: [0.0, 0.0, 4.0 * c],
            camera_rotation: [0.0, 0.0, 0.0, 1.0],
            znear: 1e-3 * c,
            yfov: 0.7,
            point_light: None,
            environment: Some(1.0),
        }
    }

    /// Writes `scene.gltf` and `grid.vdb` into `dir` and returns the glTF path.
    pub fn write(&self, dir: &std::path::Path) -> std::path::PathBuf {
        std::fs::create_dir_all(dir).unwrap();
        let mut g = brume_ffi::GridSpec::fog("density", self.voxel_size, self.grid_origin);
        g.voxels = self.voxels.clone();
        brume_ffi::write_float_grids(dir.join("grid.vdb"), &[g]).unwrap();
        super::write_whole(&dir.join("scene.gltf"), self.json().to_string().as_bytes());
        dir.join("scene.gltf")
    }

    pub fn json(&self) -> serde_json::Value {
        use serde_json::json;
        let mut medium = self.medium.clone();
        medium["uri"] = json!("grid.vdb");
        let mut nodes = vec![
            json!({"name": "camera", "camera": 0, "translation": self.camera_at,
                   "rotation": self.camera_rotation}),
            json!({"name": "medium", "extensions": {"BRUME_medium_vdb": medium}}),
        ];
        let mut extensions = serde_json::Map::new();
        let mut used = vec!["BRUME_medium_vdb"];
        if let Some((p, intensity)) = self.point_light {
            nodes.push(json!({"name": "light", "translation": p,
                              "extensions": {"KHR_lights_punctual": {"light": 0}}}));
            extensions.insert(
                "KHR_lights_punctual".into(),
                json!({"lights": [{"type": "point", "color": [1, 1, 1], "intensity": intensity}]}),
            );
            used.push("KHR_lights_punctual");
        }
        if let Some(s) = self.environment {
            extensions.insert(
                "BRUME_environment".into(),
                json!({"color": [1, 1, 1], "strength": s}),
            );
            used.push("BRUME_environment");
        }
        let indices: Vec<usize> = (0..nodes.len()).collect();
        json!({
            "asset": {"version": "2.0", "generator": "brume tests/common/stress.rs"},
            "scene": 0,
            "scenes": [{"nodes": indices}],
            "nodes": nodes,
            "cameras": [{"type": "perspective",
                         "perspective": {"yfov": self.yfov, "znear": self.znear}}],
            "extensions": extensions,
            "extensionsUsed": used,
        })
    }
}

/// The blob of [`StressScene::furnace`]: `n^3` voxels, smooth, zero at the corners.
pub fn blob_voxels(n: i32) -> Vec<([i32; 3], f32)> {
    let mut v = Vec::new();
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let q = [x, y, z].map(|c| (c as f32 + 0.5) / n as f32 - 0.5);
                let r2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2];
                let d = (1.0 - 4.0 * r2).max(0.0) * (0.7 + 0.3 * (9.0 * q[1]).cos());
                if d > 0.0 {
                    v.push(([x, y, z], d));
                }
            }
        }
    }
    v
}
