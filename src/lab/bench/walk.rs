//! `brume bench walk`: the majorant walks alone, on seeded random rays through each example
//! grid (index space, from a sphere around the grid towards a random point in it): nanoseconds
//! per segment and per ray for the global bound, the per-leaf DDA and the adaptive hierarchy,
//! next to the cost of a trilinear lookup at random points of the same grid. The figures the
//! cost model's step prices come from. Prints; never asserts.
use std::path::PathBuf;
use std::time::Instant;

use crate::math::Ray;
use crate::volume::check::SplitMix64;
use crate::volume::{
    load_grid, AdaptiveMajorantIterator, AdaptiveMajorants, ConversionPolicy, CostModel,
    DdaMajorantIterator,
};
use anyhow::Result;
use glam::DVec3;

/// Rays per grid and walk.
const RAYS: usize = 100_000;

/// Best of `runs` timings of `f`, in seconds.
fn best_of(runs: usize, mut f: impl FnMut() -> f32) -> (f64, f32) {
    let mut best = f64::INFINITY;
    let mut sink = 0.0;
    for _ in 0..runs {
        let t = Instant::now();
        sink += f();
        best = best.min(t.elapsed().as_secs_f64());
    }
    (best, sink)
}

pub fn run(files: Vec<PathBuf>, grid_name: &str) -> Result<()> {
    let files = if files.is_empty() {
        let mut v: Vec<PathBuf> = std::fs::read_dir("scenes/vdb")?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == "vdb"))
            .collect();
        v.sort();
        v
    } else {
        files
    };
    println!(
        "majorant walks on {RAYS} random rays per grid (one thread, best of 3; adaptive built for density 1 per voxel)"
    );
    println!(
        "{:<20} {:>10} {:>12} {:>12} {:>12} {:>12} {:>12} {:>12} {:>11}",
        "grid",
        "global/ray",
        "leaf segs",
        "leaf ns/seg",
        "leaf ns/ray",
        "adapt segs",
        "adapt ns/seg",
        "adapt ns/ray",
        "lookup ns"
    );
    for path in files {
        let Ok(g) = load_grid(&path, grid_name, ConversionPolicy::default()) else {
            continue;
        };
        let b = g.grid.index_bounds();
        if b.is_empty() {
            continue;
        }
        let (lo, hi) = (b.min.as_dvec3(), b.max.as_dvec3());
        let centre = (lo + hi) * 0.5;
        let radius = 0.75 * (hi - lo).length() + 1.0;
        let mut rng = SplitMix64(0x3a1c);
        let inside = |rng: &mut SplitMix64| {
            DVec3::new(
                rng.range(lo.x, hi.x),
                rng.range(lo.y, hi.y),
                rng.range(lo.z, hi.z),
            )
        };
        let rays: Vec<Ray> = (0..RAYS)
            .map(|_| {
                let o = centre + rng.unit_vector() * radius;
                let d = (inside(&mut rng) - o).normalize();
                Ray::new(o.as_vec3(), d.as_vec3())
            })
            .collect();
        let tree = AdaptiveMajorants::build(&g.bounds, 1.0, 1.0, CostModel::DEFAULT);
        let walk = |it: &mut dyn Iterator<Item = crate::volume::MajorantSegment>| {
            it.fold((0u64, 0f32), |(n, a), s| {
                (n + 1, a + s.sigma_maj * (s.t_max - s.t_min))
            })
        };
        let count = |f: &dyn Fn(&Ray) -> (u64, f32)| rays.iter().map(|r| f(r).0).sum::<u64>();
        // Each walk covers the whole ray with the bounds unscaled.
        let (t0, t1, b) = (0.0, f32::INFINITY, 1.0);
        let global = |r: &Ray| walk(&mut DdaMajorantIterator::global(&g.bounds, r, t0, t1, b));
        let leaf = |r: &Ray| walk(&mut DdaMajorantIterator::new(&g.bounds, r, t0, t1, b));
        let adaptive = |r: &Ray| walk(&mut AdaptiveMajorantIterator::new(&tree, r, t0, t1, b));
        let time = |f: &dyn Fn(&Ray) -> (u64, f32)| {
            best_of(3, || rays.iter().map(|r| f(r).1).sum::<f32>()).0
        };
        let (t_global, t_leaf, t_adaptive) = (time(&global), time(&leaf), time(&adaptive));
        let (n_leaf, n_adaptive) = (count(&leaf), count(&adaptive));
        let points: Vec<DVec3> = (0..RAYS).map(|_| inside(&mut rng)).collect();
        let (t_lookup, _) = best_of(3, || {
            points.iter().map(|&p| g.grid.sample_trilinear(p)).sum()
        });
        let n = RAYS as f64;
        println!(
            "{:<20} {:>10.1} {:>12.2} {:>12.1} {:>12.1} {:>12.2} {:>12.1} {:>12.1} {:>11.1}",
            path.file_name().unwrap_or_default().to_string_lossy(),
            1e9 * t_global / n,
            n_leaf as f64 / n,
            1e9 * t_leaf / n_leaf.max(1) as f64,
            1e9 * t_leaf / n,
            n_adaptive as f64 / n,
            1e9 * t_adaptive / n_adaptive.max(1) as f64,
            1e9 * t_adaptive / n,
            1e9 * t_lookup / n,
        );
    }
    Ok(())
}
