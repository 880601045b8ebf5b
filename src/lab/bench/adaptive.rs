//! `brume bench adaptive`: what adaptive sampling saves, as the time to reach the same error.
//! A reference render, then fixed sample counts doubling up to the cap and one adaptive render
//! capped there; the fixed renders' time at the adaptive render's RMSE is interpolated
//! (log-log) between the two that bracket it.
use std::path::Path;

use anyhow::{anyhow, Result};

use crate::film::Film;
use crate::lab::render_cpu;
use crate::render::RenderSettings;

/// RMSE of `film` against `reference` over every pixel and channel, less the reference's own
/// noise (its mean variance of the pixel mean), so that a converged image scores 0.
fn rmse(film: &Film, reference: &Film) -> f64 {
    let (mut sq, mut noise, mut n) = (0.0, 0.0, 0.0);
    for (p, r) in film.pixels().iter().zip(reference.pixels()) {
        let v = r.variance_of_mean();
        for ((a, b), v) in p.mean.iter().zip(&r.mean).zip(&v).take(3) {
            sq += (a - b).powi(2);
            noise += v;
            n += 1.0;
        }
    }
    ((sq - noise) / n).max(0.0).sqrt()
}

/// Runs the comparison on `path` at `width` x `height`: threshold `threshold`, cap `spp`, the
/// reference at `reference_spp`.
pub fn run(
    path: &Path,
    (width, height): (u32, u32),
    threshold: f32,
    spp: u32,
    reference_spp: u32,
) -> Result<()> {
    let scene = crate::scene::load(path).map_err(|e| anyhow!("{e}"))?;
    let at = |spp: u32, seed: u32, noise_threshold: Option<f32>| RenderSettings {
        width,
        height,
        spp,
        seed,
        noise_threshold,
        ..RenderSettings::default()
    };
    let reference = render_cpu(&scene, &at(reference_spp, 1000, None))?;
    println!(
        "{}: {width} x {height}; reference {reference_spp} spp in {:.2} s",
        path.display(),
        reference.seconds
    );
    println!(
        "{:<22} {:>9} {:>10} {:>10}",
        "render", "seconds", "spp/pixel", "RMSE"
    );
    let mut fixed = Vec::new();
    let mut s = 16;
    while s <= spp {
        let out = render_cpu(&scene, &at(s, 1, None))?;
        let e = rmse(&out.film, &reference.film);
        println!(
            "{:<22} {:>9.3} {:>10} {:>10.6}",
            format!("fixed {s}"),
            out.seconds,
            s,
            e
        );
        fixed.push((out.seconds, e));
        s *= 2;
    }
    let out = render_cpu(&scene, &at(spp, 1, Some(threshold)))?;
    let e = rmse(&out.film, &reference.film);
    let pixels = out.film.pixels();
    let mean_spp = pixels.iter().map(|p| p.count as f64).sum::<f64>() / pixels.len() as f64;
    println!(
        "{:<22} {:>9.3} {:>10.1} {:>10.6}",
        format!("adaptive {threshold}"),
        out.seconds,
        mean_spp,
        e
    );
    // The fixed renders' time at RMSE e: log-log between the two that bracket it.
    let at_e = fixed.windows(2).find_map(|w| {
        let ((t0, e0), (t1, e1)) = (w[0], w[1]);
        (e0 >= e && e >= e1 && e0 > e1 && e1 > 0.0).then(|| {
            let f = (e0 / e).ln() / (e0 / e1).ln();
            (t0.ln() + f * (t1 / t0).ln()).exp()
        })
    });
    match at_e {
        Some(t) => println!(
            "fixed sampling reaches RMSE {e:.6} in {t:.3} s: adaptive takes {:.2}x less time",
            t / out.seconds
        ),
        None => {
            println!("the fixed renders do not bracket RMSE {e:.6}: raise --spp or the threshold")
        }
    }
    Ok(())
}
