//! Adaptive sampling: a pixel stops taking samples once the standard error of its mean is
//! below a fraction of the mean (Cycles' noise threshold, measured with the variance the film
//! already keeps). The decision reads only the pixel's own statistics, so it is the same
//! wherever they are: a resumed checkpoint, a region of the image, the same seed again.

use super::accum::{Film, PixelStats};

/// Absolute floor of the mean in the relative error (radiance units): a black pixel with no
/// variance has converged, a nearly black noisy one does not stop on a tiny mean.
const MEAN_FLOOR: f64 = 1e-4;

/// The relative standard error of the pixel's mean: the RGB mean of the standard errors over
/// the RGB mean of the values (floored at [`MEAN_FLOOR`]).
pub fn relative_error(p: &PixelStats) -> f64 {
    let v = p.variance_of_mean();
    let se = ((v[0] + v[1] + v[2]) / 3.0).sqrt();
    let mean = (p.mean[0] + p.mean[1] + p.mean[2]) / 3.0;
    se / mean.abs().max(MEAN_FLOOR)
}

/// Whether the pixel still takes samples under `threshold`: below `min_spp` samples, or with
/// a relative error at or above the threshold. A pixel that stops keeps its statistics, so
/// asking again gives the same answer: stopping is final.
pub fn still_noisy(p: &PixelStats, threshold: f64, min_spp: u32) -> bool {
    p.count < min_spp || relative_error(p) >= threshold
}

/// [`still_noisy`] for every pixel of `film`, row-major.
pub fn noisy_pixels(film: &Film, threshold: f64, min_spp: u32) -> Vec<bool> {
    film.pixels()
        .iter()
        .map(|p| still_noisy(p, threshold, min_spp))
        .collect()
}
