//! Thinning decisions that hand their uniform on ([`thin`]): the culled walk's cell stage and
//! the voxel stage of `sample_free_flight`, mirrored by `tracker_thin` in
//! `shaders/common/tracking.wgsl`.
use crate::sampling::Rng;

/// The smallest probability of a thinning outcome whose uniform [`thin`] hands on. Rescaling
/// by `1 / p` coarsens the uniform's 2^-24 grid `1 / p` times, so each rescaling keeps at
/// least 22 of its 24 bits, and a value rescaled by both stages (cell, then voxel) at least
/// 20. A bound of 1/16 (at least 16 bits left) gave the same variance on the fire.
pub const RECYCLE_MIN_P: f32 = 1.0 / 4.0;

/// One thinning decision: keeps a tentative collision with probability `r` (`!(u < r)`: a NaN
/// ratio culls), and, when `u` was a queued value (a sampler's point or one handed on before),
/// hands it on as the next one drawn (pbrt-v4's `SampleDiscrete` remapping), where the outcome
/// had probability at least [`RECYCLE_MIN_P`]:
///
/// ```text
/// u <  r  -> kept,   next uniform u / r
/// u >= r  -> culled, next uniform (u - r) / (1 - r)
/// ```
///
/// Given the outcome, the rescaled value is uniform on `[0, 1)` and independent of it, so
/// every decision keeps its distribution. What it keeps is stratification: the first
/// tentative collision of a flight and its decision take a (Sobol) point of the sampler
/// ([`crate::sampling::Sampler::queue_on_stream`]); a fresh uniform for the next collision's
/// depth, or for the kept one's event choice, lost it wherever a collision was thinned. A
/// stream value carries no stratification, so it is not handed on (the stream's next value
/// is as good, and the rescaling costs instructions on every culled shadow ray). On the
/// example fire and plumes it lowers the per-pixel variance by about a tenth; with the
/// independent sampler the per-leaf and culled walks' variances are equal, so what it
/// restores is stratification alone.
#[inline(always)]
pub fn thin(rng: &mut Rng, r: f32) -> bool {
    let queued = rng.has_queued();
    let u = rng.uniform_f32();
    let keep = u < r;
    // The outcome's interval of `u`: `[0, r)` or `[r, 1)`, of length `p`. A NaN ratio fails
    // both tests; a ratio outside `[0, 1]` would leave `u` uniform on part of the interval
    // only, and `p <= 1` refuses it.
    let (below, p) = if keep { (u, r) } else { (u - r, 1.0 - r) };
    if queued && (RECYCLE_MIN_P..=1.0).contains(&p) {
        rng.push_front(below / p);
    }
    keep
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::{chi2_test, histogram_1d, sidak};

    #[test]
    fn a_pushed_value_comes_next_then_the_queue_then_the_stream() {
        let fresh = Rng::new(3, 4, 5);
        let mut stream = fresh;
        let next = stream.uniform_f32();

        let mut rng = fresh;
        rng.push_front(0.25);
        assert_eq!(rng.uniform_f32(), 0.25);
        assert_eq!(rng.uniform_f32(), next, "the stream resumes where it was");

        let mut rng = fresh;
        rng.queue_uniforms(0x4000_0000, 0x8000_0000);
        assert_eq!(rng.uniform_f32(), 0.25);
        rng.push_front(0.75);
        assert_eq!(rng.uniform_f32(), 0.75, "ahead of the value still queued");
        assert_eq!(rng.uniform_f32(), 0.5);
        assert_eq!(rng.uniform_f32(), next);

        // A full queue takes nothing, and a value at or past 1 stays below 1.
        let mut rng = fresh;
        rng.queue_uniforms(0, 0);
        rng.push_front(0.5);
        assert_eq!((rng.uniform_f32(), rng.uniform_f32()), (0.0, 0.0));
        assert_eq!(rng.uniform_f32(), next);
        let mut rng = fresh;
        rng.push_front(1.0);
        assert!(rng.uniform_f32() < 1.0);
    }

    /// Given either outcome, the uniform drawn after a decision is uniform on [0, 1): the
    /// keep rate is r (z-test) and the next uniform's histogram passes chi-square, for ratios
    /// whose outcomes are handed on, one-sidedly or not at all, and for NaN (always culls).
    #[test]
    fn the_next_uniform_is_uniform_whatever_the_outcome() {
        const N: usize = 200_000;
        const BINS: usize = 32;
        let ratios = [0.0, 0.1, 0.25, 0.3, 0.5, 0.75, 0.8, 0.97, f32::NAN];
        let alpha = sidak(1e-3, 2 * ratios.len() + ratios.len());
        for (k, &r) in ratios.iter().enumerate() {
            // Each decision takes a queued value (as a flight's first does), with a second one
            // queued behind it: the next uniform is the value handed on, or that one.
            let mut src = Rng::new(k as u32, 0, 77);
            let mut rng = Rng::new(0, 0, 0);
            let (mut kept, mut culled) = (Vec::new(), Vec::new());
            for _ in 0..N {
                rng.queue_uniforms(src.next_u32(), src.next_u32());
                let keep = thin(&mut rng, r);
                let next = rng.uniform_f32() as f64;
                if keep {
                    kept.push(next)
                } else {
                    culled.push(next)
                }
            }
            let p = if r.is_nan() { 0.0 } else { r as f64 };
            let z =
                (kept.len() as f64 - N as f64 * p) / (N as f64 * p * (1.0 - p)).sqrt().max(1e-9);
            assert!(
                z.abs() < 4.0,
                "r = {r}: kept {} of {N} (z = {z:.2})",
                kept.len()
            );
            for (what, xs) in [("kept", &kept), ("culled", &culled)] {
                if xs.len() < 20 * BINS {
                    continue;
                }
                assert!(xs.iter().all(|&x| (0.0..1.0).contains(&x)));
                let observed = histogram_1d(xs.iter().copied(), 0.0, 1.0, BINS);
                let expected = vec![xs.len() as f64 / BINS as f64; BINS];
                let outcome = chi2_test(&observed, &expected, 5.0);
                assert!(
                    outcome.p_value > alpha,
                    "r = {r}, {what}: next uniform not uniform, {outcome:?}"
                );
            }
        }
    }

    /// A stream value is not handed on: nothing is queued after a decision that drew one.
    #[test]
    fn a_stream_value_is_not_handed_on() {
        let mut rng = Rng::new(1, 2, 3);
        for r in [0.3, 0.5, 0.7] {
            thin(&mut rng, r);
            assert!(!rng.has_queued());
        }
        // A queued one is: after the last queued value, the one handed on is next.
        rng.queue_uniforms(0x4000_0000, 0xC000_0000);
        rng.uniform_f32();
        assert!(!thin(&mut rng, 0.5));
        assert!(rng.has_queued());
        assert_eq!(rng.uniform_f32(), (0.75 - 0.5) / (1.0 - 0.5));
    }

    /// What the recycling is for: evenly spread (stratified) uniforms stay evenly spread
    /// after the decision, in each outcome, so the next collision's depth or the kept one's
    /// event choice keeps the sampler's stratification.
    #[test]
    fn stratified_uniforms_stay_stratified() {
        const N: u32 = 4096;
        for r in [0.25f32, 0.3, 0.5, 0.6, 0.75] {
            let (mut kept, mut culled) = (Vec::new(), Vec::new());
            for i in 0..N {
                // One point per stratum of [0, 1) (exact in 24 bits).
                let mut rng = Rng::new(0, 0, 0);
                rng.queue_uniforms((2 * i + 1) << 19, 0);
                let keep = thin(&mut rng, r);
                let next = rng.uniform_f32();
                if keep {
                    kept.push(next)
                } else {
                    culled.push(next)
                }
            }
            for (what, xs) in [("kept", &kept), ("culled", &culled)] {
                // n points spread one per 1/n-wide stratum, up to the strata cut by r.
                let n = xs.len();
                let counts = histogram_1d(xs.iter().map(|&x| x as f64), 0.0, 1.0, n / 4);
                assert!(
                    counts.iter().all(|&c| (3.0..=5.0).contains(&c)),
                    "r = {r}, {what}: {n} points are not 4 to a bin: {counts:?}"
                );
            }
        }
    }
}
