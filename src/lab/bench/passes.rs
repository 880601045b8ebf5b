//! `brume bench passes`: what each kind of pass costs, the same scene rendered with the light
//! passes, the data passes, the light groups and none of them, side by side.
use std::path::Path;

use anyhow::{anyhow, Result};

use crate::lab::render_cpu;
use crate::render::light_groups::LightGroups;
use crate::render::RenderSettings;

/// Renders `path` `runs` times with each kind of pass and without, in turn, and prints the best
/// time per sample of each and its ratio to the beauty alone.
pub fn run(path: &Path, width: u32, height: u32, spp: u32, runs: usize) -> Result<()> {
    let scene = crate::scene::load(path).map_err(|e| anyhow!("{e}"))?;
    let groups = LightGroups::of(&scene).map_err(|e| anyhow!(e))?.names;
    println!(
        "{}: {width} x {height}, {spp} spp, best of {runs} ({} light groups)",
        path.display(),
        groups.len()
    );
    let base = RenderSettings {
        width,
        height,
        spp,
        ..RenderSettings::default()
    };
    let kinds: [(&str, RenderSettings); 4] = [
        (
            "light",
            RenderSettings {
                light_passes: true,
                ..base.clone()
            },
        ),
        (
            "data",
            RenderSettings {
                data_passes: true,
                ..base.clone()
            },
        ),
        (
            "lights",
            RenderSettings {
                light_groups: groups,
                ..base.clone()
            },
        ),
        ("beauty", base.clone()),
    ];
    println!("{:<8} {:>12} {:>8}", "passes", "ns/sample", "ratio");
    let mut best = [f64::INFINITY; 4];
    for _ in 0..runs.max(1) {
        for (i, (_, settings)) in kinds.iter().enumerate() {
            let out = render_cpu(&scene, settings)?;
            let samples = (width as u64 * height as u64 * spp as u64).max(1) as f64;
            best[i] = best[i].min(out.seconds * 1e9 / samples);
        }
    }
    for (i, (name, _)) in kinds.iter().enumerate() {
        println!("{name:<8} {:>12.1} {:>7.3}x", best[i], best[i] / best[3]);
    }
    println!(
        "time per sample with the light passes over without: {:.3}x",
        best[0] / best[3]
    );
    Ok(())
}
