//! `brume bench passes`: what the light passes cost, the same scene rendered with and without
//! them, side by side.
use std::path::Path;

use anyhow::{anyhow, Result};

use crate::lab::render_cpu;
use crate::render::RenderSettings;

/// Renders `path` `runs` times with the light passes and without, alternating, and prints the
/// best time per sample of each and their ratio.
pub fn run(path: &Path, width: u32, height: u32, spp: u32, runs: usize) -> Result<()> {
    let scene = crate::scene::load(path).map_err(|e| anyhow!("{e}"))?;
    println!(
        "{}: {width} x {height}, {spp} spp, best of {runs}",
        path.display()
    );
    println!("{:<8} {:>12}", "passes", "ns/sample");
    let mut best = [f64::INFINITY; 2];
    for _ in 0..runs.max(1) {
        for (i, light_passes) in [true, false].into_iter().enumerate() {
            let settings = RenderSettings {
                width,
                height,
                spp,
                light_passes,
                ..RenderSettings::default()
            };
            let out = render_cpu(&scene, &settings)?;
            let samples = (width as u64 * height as u64 * spp as u64).max(1) as f64;
            best[i] = best[i].min(out.seconds * 1e9 / samples);
        }
    }
    for (i, name) in ["light", "beauty"].into_iter().enumerate() {
        println!("{name:<8} {:>12.1}", best[i]);
    }
    println!(
        "time per sample with the light passes over without: {:.3}x",
        best[0] / best[1]
    );
    Ok(())
}
