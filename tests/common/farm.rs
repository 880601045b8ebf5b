//! Farm parts: the definition of "equal to the last rounding of the summation order" that
//! split-and-merge renders are held to (tests/cli/farm_parts.rs, farm_cli.rs, farm_slurm.rs).
use brume::film::Film;

/// Half-open distance in units of the last place of f32, with +0 and -0 equal.
pub fn f32_ulps(a: f32, b: f32) -> u32 {
    let key = |v: f32| {
        let i = v.to_bits() as i32;
        if i < 0 {
            i32::MIN - i
        } else {
            i
        }
    };
    (key(a) as i64 - key(b) as i64).unsigned_abs() as u32
}

/// The definition of "equal to the last rounding of the summation order": every pixel holds
/// the same number of samples; its f64 mean and M2 differ by at most 2^-40 relative to the
/// largest of them (Chan's pairwise merge adds O(2^-53) per fold, a few dozen folds at most);
/// the f32 values an EXR stores (mean, variance of the mean) are at most 1 ulp apart.
pub fn assert_rounding_equal(merged: &Film, single: &Film, what: &str) {
    let tol = 2f64.powi(-40);
    let same_bits = merged
        .pixels()
        .iter()
        .zip(single.pixels())
        .filter(|(a, b)| a == b)
        .count();
    let f32_same = merged
        .pixels()
        .iter()
        .zip(single.pixels())
        .filter(|(a, b)| a.mean.map(|m| m as f32) == b.mean.map(|m| m as f32))
        .count();
    println!(
        "{what}: {same_bits} of {} pixels identical in f64 state, {f32_same} in the f32 EXR mean",
        merged.pixels().len()
    );
    for (i, (a, b)) in merged.pixels().iter().zip(single.pixels()).enumerate() {
        assert_eq!(a.count, b.count, "{what}: pixel {i} sample count");
        // R, G, B and the coverage A.
        for c in 0..4 {
            let scale = a.mean[c].abs().max(b.mean[c].abs());
            assert!(
                (a.mean[c] - b.mean[c]).abs() <= tol * scale,
                "{what}: pixel {i} mean {} vs {}",
                a.mean[c],
                b.mean[c]
            );
            let scale = a.m2[c].abs().max(b.m2[c].abs());
            assert!(
                (a.m2[c] - b.m2[c]).abs() <= tol * scale,
                "{what}: pixel {i} M2 {} vs {}",
                a.m2[c],
                b.m2[c]
            );
            assert!(f32_ulps(a.mean[c] as f32, b.mean[c] as f32) <= 1, "{what}");
            let (va, vb) = (a.variance_of_mean()[c], b.variance_of_mean()[c]);
            assert!(f32_ulps(va as f32, vb as f32) <= 1, "{what}: {va} vs {vb}");
        }
    }
    match (merged.passes(), single.passes()) {
        (None, None) => {}
        (Some(a), Some(b)) => {
            assert_eq!(a.names(), b.names(), "{what}: passes");
            for i in 0..merged.pixels().len() {
                for k in 0..a.names().len() {
                    for (x, y) in [(a.mean(i, k), b.mean(i, k)), (a.m2(i, k), b.m2(i, k))] {
                        for c in 0..3 {
                            let scale = x[c].abs().max(y[c].abs());
                            assert!(
                                (x[c] - y[c]).abs() <= tol * scale,
                                "{what}: pixel {i} pass {} {} vs {}",
                                a.names()[k],
                                x[c],
                                y[c]
                            );
                        }
                    }
                    let (ma, mb) = (a.mean(i, k), b.mean(i, k));
                    for c in 0..3 {
                        assert!(f32_ulps(ma[c] as f32, mb[c] as f32) <= 1, "{what}");
                    }
                }
            }
        }
        _ => panic!("{what}: one film keeps passes, the other not"),
    }
}
