//! Light passes: the beauty split by where its light comes from, each a running mean and
//! variance per pixel and RGB channel beside the beauty's, kept only when asked for.
//!
//! Each pixel's passes share its sample count (`PixelStats::count`): the update and the merge
//! are the beauty's (Welford; Chan et al.) with that count, so parts, checkpoints and merges
//! carry the passes exactly as they carry the beauty.

/// The light passes, in the order the integrator fills them: what the camera sees before any
/// scattering event (emission of media and surfaces, and the sky), then the light reaching the
/// first event, by its kind, directly (next-event estimation there and what the ray leaving it
/// meets) and after further events (Cycles' Emission, Background, Volume and Diffuse/Glossy
/// Direct and Indirect, surfaces taken together).
pub const LIGHT_PASSES: [&str; 6] = [
    "emission",
    "background",
    "volume.direct",
    "volume.indirect",
    "surface.direct",
    "surface.indirect",
];

/// The data passes a denoiser takes, with Cycles' conventions: `albedo` (the throughput times
/// the base colour at the first surface that is not a smooth dielectric, the throughput past
/// the albedo at a first medium event, the sky where the path escapes), `normal` (the shading
/// normal there, in world space; the view direction in a medium) and `depth` (the camera-space
/// Z of the camera ray's first surface; 1e10 where it escapes, 0 where it scatters first).
pub const DATA_PASSES: [&str; 3] = ["albedo", "normal", "depth"];

/// The EXR channels of pass `name`: `normal.X/Y/Z`, `depth.Z` (its first value), else
/// `name.R/G/B`; `(channel, index of the value)`.
pub fn exr_channels(name: &str) -> Vec<(String, usize)> {
    match name {
        "normal" => ["X", "Y", "Z"]
            .iter()
            .enumerate()
            .map(|(c, ch)| (format!("normal.{ch}"), c))
            .collect(),
        "depth" => vec![("depth.Z".to_string(), 0)],
        _ => ["R", "G", "B"]
            .iter()
            .enumerate()
            .map(|(c, ch)| (format!("{name}.{ch}"), c))
            .collect(),
    }
}

/// Per-pixel statistics of some passes, three channels each.
#[derive(Debug, Clone, PartialEq)]
pub struct PassLayers {
    names: Vec<String>,
    /// Means, `(pixel * passes + pass) * 3 + channel`.
    mean: Vec<f64>,
    /// Welford's `M2`, laid out as `mean`.
    m2: Vec<f64>,
}

impl PassLayers {
    /// Empty statistics of passes `names` over `pixels` pixels.
    pub fn new(names: &[String], pixels: usize) -> Self {
        let n = pixels * names.len() * 3;
        PassLayers {
            names: names.to_vec(),
            mean: vec![0.0; n],
            m2: vec![0.0; n],
        }
    }

    /// The passes' names, in layer order.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// Values kept: pixels x passes x 3.
    pub fn len(&self) -> usize {
        self.mean.len()
    }

    pub fn is_empty(&self) -> bool {
        self.mean.is_empty()
    }

    fn stride(&self) -> usize {
        self.names.len() * 3
    }

    /// Adds pixel `i`'s sample `values` (one RGB per pass), the pixel's `n`-th.
    pub fn add(&mut self, i: usize, n: u32, values: &[[f32; 3]]) {
        debug_assert_eq!(values.len(), self.names.len());
        let s = self.stride();
        let n = n as f64;
        for (k, v) in values.iter().enumerate() {
            for (c, &x) in v.iter().enumerate() {
                let j = i * s + 3 * k + c;
                let x = x as f64;
                let delta = x - self.mean[j];
                self.mean[j] += delta / n;
                self.m2[j] += delta * (x - self.mean[j]);
            }
        }
    }

    /// Folds pixel `j` of `other` (`nb` samples) into pixel `i` of these (`na` samples), as
    /// `PixelStats::merge` does; call before the beauty's counts change.
    pub fn merge(&mut self, i: usize, na: u32, other: &PassLayers, j: usize, nb: u32) {
        if nb == 0 {
            return;
        }
        let s = self.stride();
        let (a, b) = (i * s..(i + 1) * s, j * s..(j + 1) * s);
        if na == 0 {
            self.mean[a.clone()].copy_from_slice(&other.mean[b.clone()]);
            self.m2[a].copy_from_slice(&other.m2[b]);
            return;
        }
        let (na, nb) = (na as f64, nb as f64);
        let n = na + nb;
        for (x, y) in a.zip(b) {
            let delta = other.mean[y] - self.mean[x];
            self.mean[x] += delta * (nb / n);
            self.m2[x] += other.m2[y] + delta * delta * (na * nb / n);
        }
    }

    /// Pass `k`'s mean at pixel `i`.
    pub fn mean(&self, i: usize, k: usize) -> [f64; 3] {
        let j = i * self.stride() + 3 * k;
        [self.mean[j], self.mean[j + 1], self.mean[j + 2]]
    }

    /// Pass `k`'s `M2` at pixel `i`.
    pub fn m2(&self, i: usize, k: usize) -> [f64; 3] {
        let j = i * self.stride() + 3 * k;
        [self.m2[j], self.m2[j + 1], self.m2[j + 2]]
    }

    /// Sets pass `k`'s mean and `M2` at pixel `i` (a state read back from a file).
    pub fn set(&mut self, i: usize, k: usize, mean: [f64; 3], m2: [f64; 3]) {
        let j = i * self.stride() + 3 * k;
        self.mean[j..j + 3].copy_from_slice(&mean);
        self.m2[j..j + 3].copy_from_slice(&m2);
    }

    /// Pass `k`'s variance of the mean at pixel `i` of `count` samples (0 below two).
    pub fn variance_of_mean(&self, i: usize, k: usize, count: u32) -> [f64; 3] {
        if count < 2 {
            return [0.0; 3];
        }
        let n = count as f64;
        self.m2(i, k).map(|m2| (m2 / (n - 1.0)).max(0.0) / n)
    }
}
