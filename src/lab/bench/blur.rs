//! `brume bench blur`: what velocity and camera motion blur cost, the same scene rendered with
//! its shutter and with the shutter closed, side by side.
use std::path::Path;

use anyhow::{anyhow, Result};

use crate::film::totals;
use crate::lab::render_cpu;
use crate::render::RenderSettings;
use crate::scene::{self, LoadOptions, Shutter};

/// Renders `path` `runs` times with its own shutter and with `--shutter 0,0`, alternating, and
/// prints the best time per sample of each, their ratio, and what the walks did.
pub fn run(path: &Path, width: u32, height: u32, spp: u32, runs: usize) -> Result<()> {
    let load = |shutter: Option<Shutter>| {
        scene::load_with(
            path,
            &LoadOptions {
                shutter,
                ..Default::default()
            },
        )
        .map_err(|e| anyhow!("{e}"))
    };
    let blurred = load(None)?;
    if !blurred.shutter.is_open() {
        return Err(anyhow!(
            "{}: the scene has no open shutter (BRUME_render shutter): nothing to compare",
            path.display()
        ));
    }
    let still = load(Some(Shutter::CLOSED))?;
    let settings = RenderSettings {
        width,
        height,
        spp,
        ..RenderSettings::default()
    };
    println!(
        "{}: {width} x {height}, {spp} spp, best of {runs}; shutter {} to {} frames",
        path.display(),
        blurred.shutter.open,
        blurred.shutter.close
    );
    println!(
        "{:<8} {:>12} {:>14} {:>16} {:>11}",
        "shutter", "ns/sample", "lookups/sample", "lookups/real", "violations"
    );
    let mut best = [f64::INFINITY; 2];
    let mut rows = [(0.0, 0.0, 0u64); 2];
    for _ in 0..runs.max(1) {
        for (i, scene) in [&blurred, &still].into_iter().enumerate() {
            let out = render_cpu(scene, &settings)?;
            let t = totals(&out.records).counters;
            let samples = t.samples.max(1) as f64;
            best[i] = best[i].min(out.seconds * 1e9 / samples);
            rows[i] = (
                t.density_lookups as f64 / samples,
                t.density_lookups as f64 / t.real_collisions.max(1) as f64,
                t.majorant_violations,
            );
        }
    }
    for (i, name) in ["open", "closed"].into_iter().enumerate() {
        let (per_sample, per_real, violations) = rows[i];
        println!(
            "{name:<8} {:>12.1} {per_sample:>14.3} {per_real:>16.3} {violations:>11}",
            best[i]
        );
    }
    println!(
        "time per sample with blur over without: {:.2}x",
        best[0] / best[1]
    );
    Ok(())
}
