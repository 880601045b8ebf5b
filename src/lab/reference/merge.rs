//! Independent runs of a reference renderer merged into one image laid out like Brume's: the
//! mean, the variance of the mean across the runs, the samples.
use anyhow::{anyhow, bail, Result};

use crate::film::{Image, Metadata};

/// Averages independent runs; with two or more, the variance of the mean is the unbiased
/// sample variance across runs divided by their number.
pub fn merge_runs(images: &[Image], spp: u32, attributes: Metadata) -> Result<Image> {
    let first = images.first().ok_or_else(|| anyhow!("no images"))?;
    let (w, h) = (first.width, first.height);
    if images.iter().any(|i| i.width != w || i.height != h) {
        bail!("the runs differ in size");
    }
    let k = images.len() as f64;
    let n = w * h;
    let mut rgb = vec![[0f32; 3]; n];
    let mut var = vec![[0f32; 3]; n];
    for p in 0..n {
        for c in 0..3 {
            let mean = images.iter().map(|i| i.rgb[p][c] as f64).sum::<f64>() / k;
            let ss: f64 = images
                .iter()
                .map(|i| (i.rgb[p][c] as f64 - mean).powi(2))
                .sum();
            rgb[p][c] = mean as f32;
            var[p][c] = if k > 1.0 {
                (ss / (k - 1.0) / k) as f32
            } else {
                0.0
            };
        }
    }
    // Alpha: the runs' mean (1 where a run has none).
    let alpha = (0..n)
        .map(|p| {
            let sum: f64 = images
                .iter()
                .map(|i| i.alpha.as_ref().map_or(1.0, |a| a[p] as f64))
                .sum();
            (sum / k) as f32
        })
        .collect();
    Ok(Image {
        width: w,
        height: h,
        rgb,
        alpha: Some(alpha),
        variance: (k > 1.0).then_some(var),
        samples: Some(vec![spp as f32 * k as f32; n]),
        attributes,
    })
}
