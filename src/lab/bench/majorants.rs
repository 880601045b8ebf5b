//! `brume bench render --majorants-only`: the majorant modes side by side, with the floor no
//! walk can pass, and the adaptive hierarchy's build on a 1024^3-voxel grid.
use std::path::PathBuf;

use crate::volume::check::SplitMix64;
use anyhow::Result;

use crate::lab::render_cpu;

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
/// walk each medium's hierarchy takes (`WalkPlan::of`, and in brackets its shadow rays'
/// where they differ: `WalkPlan::shadow`): where it is the global or
/// per-leaf walk for both kinds of flight, the two rows time the same code and differ by
/// noise only.
///
/// A scene whose media do not emit gets a `floor` row, timed in the same rounds: the global
/// walk through a copy of the scene with its VDB media made transparent
/// ([`transparent_scales`]). It keeps every ray, span search and walk entry and drops the
/// collisions and the rays they spawn, so no walk is faster: its `vs global` is the most any
/// majorant structure can gain on the scene, and the notes after the table say how much of
/// that gap the 1.2x mark needs and how much the adaptive mode takes
/// (`tools/bench/callgrind-majorants.sh --floor` counts the same floor in instructions).
pub fn majorant_modes(
    scenes: &[PathBuf],
    width: u32,
    height: u32,
    spp: u32,
    rounds: Rounds,
) -> Result<()> {
    use crate::render::{Estimator, MajorantMode, RenderSettings};
    let Rounds { runs, first_seed } = rounds;
    println!();
    println!(
        "majorant modes ({width}x{height}, {spp} spp, {} threads; time per sample = best of {runs} renders, modes in turn; \
         'rounds': global over mode within each round, lowest-median-highest; \
         'floor': the global walk through the media made transparent)",
        rayon::current_num_threads()
    );
    print_header();
    // Scenes whose variance a few pixels carry (the `top 0.1%` column), named after the table.
    let mut outlier_scenes: Vec<String> = Vec::new();
    let mut floors: Vec<Floor> = Vec::new();
    for path in scenes {
        let mut scene = crate::scene::load(path)?;
        if scene.vdb_media.is_empty() {
            continue;
        }
        let name = path.file_name().unwrap_or_default().to_string_lossy();
        let adaptive_walk = adaptive_walk_names(&scene)?;
        let floor_scales = transparent_scales(&scene);
        for estimator in [Estimator::Delta, Estimator::Decomposition] {
            let settings = MajorantMode::ALL.map(|majorant| RenderSettings {
                width,
                height,
                spp,
                estimator,
                majorant,
                ..RenderSettings::default()
            });
            let position = |mode| MajorantMode::ALL.iter().position(|&m| m == mode);
            let global_k = position(MajorantMode::Global).unwrap_or(0);
            let adaptive_k = position(MajorantMode::Adaptive).unwrap_or(0);
            let mut modes = MajorantMode::ALL.map(|_| Timed::new(runs));
            let mut floor = Timed::new(runs);
            for round in 0..runs {
                let seed = first_seed.wrapping_add(round as u32);
                for (k, s) in settings.iter().enumerate() {
                    let s = RenderSettings { seed, ..s.clone() };
                    modes[k].push(render_cpu(&scene, &s)?);
                }
                if let Some(scales) = &floor_scales {
                    let s = RenderSettings {
                        seed,
                        ..settings[global_k].clone()
                    };
                    floor.push(render_with_scales(&mut scene, scales, &s)?);
                }
            }
            let variance = modes.each_ref().map(|m| m.variance());
            let global_cost = variance[global_k].map(|v| modes[global_k].best * v.pooled);
            for (k, majorant) in MajorantMode::ALL.into_iter().enumerate() {
                if variance[k].is_some_and(|v| v.top_share > OUTLIER_SHARE)
                    && !outlier_scenes.iter().any(|s| *s == name)
                {
                    outlier_scenes.push(name.to_string());
                }
                let efficiency = match (variance[k], global_cost) {
                    (Some(v), Some(g)) => Some((v, g / (modes[k].best * v.pooled))),
                    _ => None,
                };
                let walk = if majorant == MajorantMode::Adaptive {
                    adaptive_walk.as_str()
                } else {
                    majorant.name()
                };
                let label = (&*name, estimator.name(), majorant.name(), walk);
                print_row(label, &modes[k], &modes[global_k], efficiency);
            }
            if floor_scales.is_some() {
                let walk = "global, media transparent: no walk costs less";
                let label = (&*name, estimator.name(), "floor", walk);
                print_row(label, &floor, &modes[global_k], None);
                floors.push(Floor {
                    scene: name.to_string(),
                    estimator: estimator.name(),
                    floor: floor.paired_with(&modes[global_k]).1,
                    adaptive: modes[adaptive_k].paired_with(&modes[global_k]).1,
                });
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
    print_floor_notes(&floors);
    Ok(())
}

/// The table's column heads.
fn print_header() {
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
}

/// A timed floor, against the global bound (median paired rounds) with the adaptive mode's.
struct Floor {
    scene: String,
    estimator: &'static str,
    /// Global time over the floor's, and over the adaptive mode's.
    floor: f64,
    adaptive: f64,
}

impl Floor {
    /// The share of the time between the global bound and the floor that a speed-up `r` over
    /// the global bound removes: `(1 - 1/r) / (1 - 1/floor)`.
    fn gap_share(&self, r: f64) -> f64 {
        (1.0 - 1.0 / r) / (1.0 - 1.0 / self.floor)
    }
}

/// What the floor rows say: for each, the share of the time between the global bound and the
/// floor that [`SPEEDUP_MARK`] needs, against the share the adaptive mode removes. Near or
/// past 100 %, only a walk that cost nothing and collided nowhere would reach the mark.
fn print_floor_notes(floors: &[Floor]) {
    if floors.is_empty() {
        return;
    }
    println!(
        "floor rows: every VDB medium's densityScale times {FLOOR_DENSITY_FACTOR:e}, under the \
         global walk: the same rays, span searches and walk entries with almost no tentative \
         collision, and none of the rays real collisions spawn, so 'vs global' there bounds what \
         any majorant structure can gain: tightly where real collisions are few, loosely where \
         they spawn most of the work (the clouds, the fogs); scenes whose media emit get no \
         floor, as their walks must still sample the emission. Of the time between global and \
         floor (median rounds), {SPEEDUP_MARK}x over global needs / adaptive removes:"
    );
    for f in floors {
        println!(
            "  {:<22} {:<14} floor {:.2}x: {SPEEDUP_MARK}x needs {:.0}%, adaptive ({:.2}x) removes {:.0}%",
            f.scene,
            f.estimator,
            f.floor,
            100.0 * f.gap_share(SPEEDUP_MARK),
            f.adaptive,
            100.0 * f.gap_share(f.adaptive),
        );
    }
}

/// The speed-up over the global bound asked of the adaptive mode wherever per-leaf bounds cut
/// the density lookups 3x or more (docs/estimators.md, "Majorants").
const SPEEDUP_MARK: f64 = 1.2;

/// The floor's density scale factor: small enough that almost no tentative collision happens,
/// not zero, so the media keep their walks (a medium of no density is not tracked at all).
const FLOOR_DENSITY_FACTOR: f32 = 1e-6;

/// Every VDB medium's `densityScale` made transparent ([`FLOOR_DENSITY_FACTOR`]), for the
/// floor rows; `None` when one of the media emits, as its walks must still sample the
/// emission, so a transparent copy would not bound their work.
fn transparent_scales(scene: &crate::scene::Scene) -> Option<Vec<f32>> {
    if scene.vdb_media.iter().any(|m| m.emits()) {
        return None;
    }
    Some(
        scene
            .vdb_media
            .iter()
            .map(|m| m.density_scale * FLOOR_DENSITY_FACTOR)
            .collect(),
    )
}

/// Renders `scene` with its VDB media's `densityScale`s swapped for `scales`, then swaps them
/// back: the floor renders the loaded scene instead of reading its grids a second time.
fn render_with_scales(
    scene: &mut crate::scene::Scene,
    scales: &[f32],
    settings: &crate::render::RenderSettings,
) -> Result<crate::backend::cpu::RenderOutput> {
    let swap = |scene: &mut crate::scene::Scene, scales: &mut Vec<f32>| {
        for (m, s) in scene.vdb_media.iter_mut().zip(scales.iter_mut()) {
            std::mem::swap(&mut m.density_scale, s);
        }
    };
    let mut scales = scales.to_vec();
    swap(scene, &mut scales);
    let out = render_cpu(scene, settings);
    swap(scene, &mut scales);
    out
}

/// The walks each VDB medium's adaptive hierarchy takes (`WalkPlan::of`, and in
/// brackets its shadow rays' where they differ), joined by `+`.
fn adaptive_walk_names(scene: &crate::scene::Scene) -> Result<String> {
    use crate::render::MajorantMode;
    let rs = crate::render::RenderScene::new(scene, false).map_err(|e| anyhow::anyhow!(e))?;
    Ok(rs
        .vdb
        .iter()
        .map(|m| {
            let (walk, shadow) = (
                m.walk(MajorantMode::Adaptive).free,
                m.walk(MajorantMode::Adaptive).shadow,
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
        .join("+"))
}

/// The renders of one row of the table, over the rounds.
struct Timed {
    best: f64,
    seconds: Vec<f64>,
    /// Every round's pixel means (seeds `first_seed`, `first_seed + 1`, ...).
    images: Vec<Vec<[f32; 3]>>,
    last: Option<crate::backend::cpu::RenderOutput>,
}

impl Timed {
    fn new(runs: usize) -> Self {
        Timed {
            best: f64::INFINITY,
            seconds: Vec::with_capacity(runs),
            images: Vec::with_capacity(runs),
            last: None,
        }
    }

    fn push(&mut self, out: crate::backend::cpu::RenderOutput) {
        self.best = self.best.min(out.seconds);
        self.seconds.push(out.seconds);
        self.images.push(film_means(&out.film));
        self.last = Some(out);
    }

    /// The per-pixel variance over the rounds' seeds (`None` under two rounds).
    fn variance(&self) -> Option<crate::study::stats::SeedVariance> {
        let views: Vec<&[[f32; 3]]> = self.images.iter().map(|v| v.as_slice()).collect();
        crate::study::stats::seed_variance_profile(&views, crate::study::stats::TOP_FRACTION).ok()
    }

    /// `global`'s time over this row's within each round: lowest, median and highest.
    fn paired_with(&self, global: &Timed) -> (f64, f64, f64) {
        let mut rounds: Vec<f64> = global
            .seconds
            .iter()
            .zip(&self.seconds)
            .map(|(g, m)| g / m)
            .collect();
        rounds.sort_by(f64::total_cmp);
        (
            rounds.first().copied().unwrap_or(f64::NAN),
            median(&rounds),
            rounds.last().copied().unwrap_or(f64::NAN),
        )
    }
}

/// One row: `label` is (scene, estimator, bounds, walk); `efficiency` the row's seed variance
/// and its efficiency over the global bound's, where known.
fn print_row(
    label: (&str, &str, &str, &str),
    row: &Timed,
    global: &Timed,
    efficiency: Option<(crate::study::stats::SeedVariance, f64)>,
) {
    let (scene, estimator, bounds, walk) = label;
    let t = row
        .last
        .as_ref()
        .map(|o| crate::film::totals(&o.records))
        .unwrap_or_default();
    let n = t.counters.samples.max(1) as f64;
    let ns = 1e9 * row.best / n;
    let global_ns = 1e9 * global.best / n;
    let paired = row.paired_with(global);
    // No real collision (the floor): the ratio has nothing to count.
    let lookups_per_real = if t.counters.real_collisions > 0 {
        format!(
            "{:.2}",
            t.counters.density_lookups as f64 / t.counters.real_collisions as f64
        )
    } else {
        "-".to_string()
    };
    let (var, top, eff) = match efficiency {
        Some((v, e)) => (
            format!("{:.3e}", v.pooled),
            format!("{:.0}%", 100.0 * v.top_share),
            format!("{e:.2}x"),
        ),
        None => ("-".to_string(), "-".to_string(), "-".to_string()),
    };
    println!(
        "{:<22} {:<14} {:<9} {:>9.1} {:>9.2}x {:>16} {:>10.2} {:>10.2} {:>10.2} {:>10.2} {:>10.3} {:>11} {:>10} {:>8} {:>10}  {}",
        scene,
        estimator,
        bounds,
        ns,
        global_ns / ns,
        format!("{:.2}-{:.2}-{:.2}", paired.0, paired.1, paired.2),
        (t.counters.majorant_segments - t.counters.shadow_segments) as f64 / n,
        t.counters.shadow_segments as f64 / n,
        t.counters.density_lookups as f64 / n,
        t.counters.emission_lookups as f64 / n,
        t.counters.real_collisions as f64 / n,
        lookups_per_real,
        var,
        top,
        eff,
        walk,
    );
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
fn film_means(film: &crate::film::Film) -> Vec<[f32; 3]> {
    (0..film.height())
        .flat_map(|y| (0..film.width()).map(move |x| film.mean(x, y)))
        .collect()
}

/// Build time and memory of the adaptive hierarchy for a 1024^3-voxel grid (128^3 leaf
/// cells of random bounds: the build reads only the per-leaf bounds).
pub fn adaptive_build() -> Result<()> {
    use crate::volume::{AdaptiveMajorants, CellBounds, CostModel, LeafBounds};
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

#[cfg(test)]
mod tests {
    use super::Floor;

    #[test]
    fn gap_share_is_zero_at_the_global_bound_and_whole_at_the_floor() {
        let f = Floor {
            scene: String::new(),
            estimator: "delta",
            floor: 1.25,
            adaptive: 1.1,
        };
        assert_eq!(f.gap_share(1.0), 0.0);
        assert_eq!(f.gap_share(1.25), 1.0);
        // 1/1.2 of global's time is 5/6 of it: a sixth over the floor's fifth.
        assert!((f.gap_share(1.2) - (1.0 / 6.0) / 0.2).abs() < 1e-12);
    }
}
