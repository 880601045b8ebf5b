//! `brume bench render --majorants-only`: the majorant modes side by side, with the floor no
//! walk can pass, and the adaptive hierarchy's build on a 1024^3-voxel grid.
use std::path::PathBuf;

use anyhow::Result;
use brume::volume::check::SplitMix64;

use super::bench::render_once;

/// The majorant-mode table's rounds: how many, and the seed of the first.
#[derive(Clone, Copy)]
pub struct Rounds {
    pub runs: usize,
    pub first_seed: u32,
}

/// The four majorant modes side by side on every scene with a VDB medium, for delta and
/// decomposition tracking: time per sample (best of `runs` renders per mode, the modes taken
/// in turn so that a slow spell of the machine falls on all alike), the speed-up over the
/// global bound from those bests and its range over the rounds (each round's global time over
/// the same round's time: paired, so a slow spell cancels), the walk (segments per
/// sample, primary and shadow rays), density and emission lookups and real collisions per
/// sample (an emissive medium reads its emission at every tentative collision), and the
/// per-pixel variance of one render with the efficiency over the global bound,
/// `(t_global var_global) / (t var)`: a walk can buy its time with variance (ratio tracking's
/// grows as its majorant tightens; the culled walk spends the Sobol points of a flight's first
/// draws on culled collisions), so time alone does not rank the modes. Round `r` renders with
/// seed `first_seed + r` (`--first-seed`, default 0); the variance is
/// `study::stats::seed_variance` over the rounds (each pixel's sample variance across the
/// seeds, pooled over pixels and RGB), with the share of it in the
/// worst 0.1 % of pixel values (`top 0.1%`; where it passes half, a few fireflies set the
/// variance and the efficiency, and the table says so). The adaptive rows name the
/// walk each medium's hierarchy takes (`VdbMedium::walk_mode`, and in brackets its shadow rays'
/// where they differ: `VdbMedium::shadow_walk_mode`): where it is the global or
/// per-leaf walk for both kinds of flight, the two rows time the same code and differ by
/// noise only.
pub fn majorant_modes(
    scenes: &[PathBuf],
    width: u32,
    height: u32,
    spp: u32,
    rounds: Rounds,
) -> Result<()> {
    use brume::integrator::{Estimator, MajorantMode, RenderSettings};
    let Rounds { runs, first_seed } = rounds;
    println!();
    println!(
        "majorant modes ({width}x{height}, {spp} spp, {} threads; time per sample = best of {runs} renders, modes in turn; \
         'rounds': global over mode within each round, lowest-median-highest)",
        rayon::current_num_threads()
    );
    println!(
        "{:<22} {:<14} {:<9} {:>9} {:>10} {:>16} {:>10} {:>10} {:>10} {:>10} {:>10} {:>11} {:>10} {:>8} {:>10}  walk",
        "scene",
        "estimator",
        "bounds",
        "ns/sample",
        "vs global",
        "rounds",
        "segs prim",
        "segs shad",
        "lookups",
        "emit look",
        "real coll",
        "lookups/real",
        "var/px",
        "top 0.1%",
        "eff vs gl",
    );
    // Scenes whose variance a few pixels carry (the `top 0.1%` column), named after the table.
    let mut outlier_scenes: Vec<String> = Vec::new();
    for path in scenes {
        let scene = brume::scene::load(path)?;
        if scene.vdb_media.is_empty() {
            continue;
        }
        let rs =
            brume::integrator::RenderScene::new(&scene, false).map_err(|e| anyhow::anyhow!(e))?;
        let adaptive_walk = rs
            .vdb
            .iter()
            .map(|m| {
                let (walk, shadow) = (
                    m.walk_mode(MajorantMode::Adaptive),
                    m.shadow_walk_mode(MajorantMode::Adaptive),
                );
                let name = match walk {
                    MajorantMode::Adaptive => "mixed",
                    walk => walk.name(),
                };
                if shadow == walk {
                    name.to_string()
                } else {
                    format!("{name} ({} shadows)", shadow.name())
                }
            })
            .collect::<Vec<_>>()
            .join("+");
        for estimator in [Estimator::Delta, Estimator::Decomposition] {
            let settings = MajorantMode::ALL.map(|majorant| RenderSettings {
                width,
                height,
                spp,
                estimator,
                majorant,
                ..RenderSettings::default()
            });
            let mut best = [f64::INFINITY; MajorantMode::ALL.len()];
            let mut seconds = MajorantMode::ALL.map(|_| Vec::with_capacity(runs));
            let mut last = MajorantMode::ALL.map(|_| None);
            // Every round's image (seeds 0, 1, ...), for the per-pixel variance.
            let mut images: [Vec<Vec<[f32; 3]>>; MajorantMode::ALL.len()] = Default::default();
            for round in 0..runs {
                for (k, s) in settings.iter().enumerate() {
                    let s = RenderSettings {
                        seed: first_seed.wrapping_add(round as u32),
                        ..s.clone()
                    };
                    let o = render_once(&scene, &s)?;
                    best[k] = best[k].min(o.seconds);
                    seconds[k].push(o.seconds);
                    images[k].push(film_means(&o.film));
                    last[k] = Some(o);
                }
            }
            let variance = images.map(|im| {
                let views: Vec<&[[f32; 3]]> = im.iter().map(|v| v.as_slice()).collect();
                brume::study::stats::seed_variance_profile(
                    &views,
                    brume::study::stats::TOP_FRACTION,
                )
                .ok()
            });
            let global_k = MajorantMode::ALL
                .iter()
                .position(|&m| m == MajorantMode::Global)
                .unwrap_or(0);
            let mut global_ns = 0.0;
            let global_cost = variance[global_k].map(|v| best[global_k] * v.pooled);
            for (k, majorant) in MajorantMode::ALL.into_iter().enumerate() {
                let out = last[k].take().unwrap();
                let t = brume::film::totals(&out.records);
                let n = t.samples.max(1) as f64;
                let ns = 1e9 * best[k] / n;
                if majorant == MajorantMode::Global {
                    global_ns = ns;
                }
                let mut rounds: Vec<f64> = seconds[global_k]
                    .iter()
                    .zip(&seconds[k])
                    .map(|(g, m)| g / m)
                    .collect();
                rounds.sort_by(f64::total_cmp);
                let paired = (
                    rounds.first().copied().unwrap_or(f64::NAN),
                    median(&rounds),
                    rounds.last().copied().unwrap_or(f64::NAN),
                );
                let (var, top, eff) = match (variance[k], global_cost) {
                    (Some(v), Some(g)) => (
                        format!("{:.3e}", v.pooled),
                        format!("{:.0}%", 100.0 * v.top_share),
                        format!("{:.2}x", g / (best[k] * v.pooled)),
                    ),
                    _ => ("-".to_string(), "-".to_string(), "-".to_string()),
                };
                let name = path.file_name().unwrap_or_default().to_string_lossy();
                if variance[k].is_some_and(|v| v.top_share > OUTLIER_SHARE)
                    && !outlier_scenes.iter().any(|s| *s == name)
                {
                    outlier_scenes.push(name.to_string());
                }
                println!(
                    "{:<22} {:<14} {:<9} {:>9.1} {:>9.2}x {:>16} {:>10.2} {:>10.2} {:>10.2} {:>10.2} {:>10.3} {:>11.2} {:>10} {:>8} {:>10}  {}",
                    name,
                    estimator.name(),
                    majorant.name(),
                    ns,
                    global_ns / ns,
                    format!("{:.2}-{:.2}-{:.2}", paired.0, paired.1, paired.2),
                    (t.majorant_segments - t.shadow_segments) as f64 / n,
                    t.shadow_segments as f64 / n,
                    t.density_lookups as f64 / n,
                    t.emission_lookups as f64 / n,
                    t.real_collisions as f64 / n,
                    t.density_lookups as f64 / (t.real_collisions as f64).max(1.0),
                    var,
                    top,
                    eff,
                    if majorant == MajorantMode::Adaptive {
                        adaptive_walk.as_str()
                    } else {
                        majorant.name()
                    },
                );
            }
        }
    }
    if !outlier_scenes.is_empty() {
        println!(
            "{}: over {:.0}% of the per-pixel variance lies in 0.1% of the pixel values (a few \
             fireflies), so var/px and eff vs gl there are set by those outliers and move by \
             multiples with the seeds: rank those modes by time, or by var/px over many more rounds",
            outlier_scenes.join(", "),
            100.0 * OUTLIER_SHARE
        );
    }
    Ok(())
}

/// Above this share of the per-pixel variance in `stats::TOP_FRACTION` of the values, the
/// variance (and the efficiency from it) is a few outliers' and the table says so.
const OUTLIER_SHARE: f64 = 0.5;

/// The median of sorted `v` (NaN when empty): the `rounds` column's middle figure, which a
/// slow spell of a shared machine moves less than the ratio of the bests.
fn median(v: &[f64]) -> f64 {
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

/// The film's pixel means, row-major.
fn film_means(film: &brume::film::Film) -> Vec<[f32; 3]> {
    (0..film.height())
        .flat_map(|y| (0..film.width()).map(move |x| film.mean(x, y)))
        .collect()
}

/// Build time and memory of the adaptive hierarchy for a 1024^3-voxel grid (128^3 leaf
/// cells of random bounds: the build reads only the per-leaf bounds).
pub fn adaptive_build() -> Result<()> {
    use brume::volume::{AdaptiveMajorants, CellBounds, CostModel, LeafBounds};
    let n = 128u32;
    let mut rng = SplitMix64(1024);
    let cells: Vec<CellBounds> = (0..n * n * n)
        .map(|_| {
            let a = rng.range(0.0, 1.0) as f32;
            let b = rng.range(0.0, 1.0) as f32;
            CellBounds {
                min: a.min(b) * 0.2,
                max: a.max(b),
            }
        })
        .collect();
    let leaf = LeafBounds::from_cells(cells, [n; 3], [0; 3]);
    let a = AdaptiveMajorants::build(&leaf, 50.0, 100.0, CostModel::DEFAULT);
    println!();
    println!(
        "adaptive majorants of a 1024^3-voxel grid ({n}^3 leaf cells, {} threads): built in {:.3} s, {:.1} MiB",
        rayon::current_num_threads(),
        a.build_seconds,
        a.memory_bytes() as f64 / (1 << 20) as f64
    );
    Ok(())
}
