//! The CPU backend: progressive passes over tiles, tiles in parallel with rayon, results
//! merged in tile order so that the image is the same bit for bit whatever the thread count.
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use rayon::prelude::*;

use crate::film::{tiles, Film, TileRecord, TileRect};
use crate::integrator::glow::{Glows, Lamps};
use crate::integrator::path::PathLimits;
use crate::integrator::tile::{specialised, TileContext, TileFn, TileOutput};
use crate::render::media::TrackingConfig;
use crate::render::{FeatureFlags, RenderScene, RenderSettings};

/// What a render produced.
pub struct RenderOutput {
    pub film: Film,
    /// One record per tile per pass, in pass then tile order.
    pub records: Vec<TileRecord>,
    /// Per-pixel density lookups over the whole render (row-major).
    pub lookups: Vec<u64>,
    /// Samples per pixel every pixel reached.
    pub spp: u32,
    pub seconds: f64,
    /// The features the specialised path was compiled for.
    pub features: FeatureFlags,
    /// Whether the render stopped early (time budget or interrupt).
    pub interrupted: bool,
}

/// Progress after each pass: (samples per pixel so far, target, seconds so far).
pub type Progress<'a> = &'a (dyn Fn(u32, u32, f64) + Sync);

/// Pass sizes: 1, 1, 2, 4, ... up to `max_pass_spp`, never past `spp`.
pub fn pass_sizes(spp: u32, max_pass_spp: u32) -> impl Iterator<Item = (u32, u32)> {
    let mut done = 0u32;
    let mut next = 1u32;
    std::iter::from_fn(move || {
        if done >= spp {
            return None;
        }
        let n = next.min(spp - done).min(max_pass_spp);
        let start = done;
        done += n;
        if start > 0 {
            next = (next * 2).min(max_pass_spp);
        }
        Some((start, n))
    })
}

/// The passes of samples `[start, end)`: the passes of the one global schedule
/// (`pass_sizes(u32::MAX, max_pass_spp)`: 1, 1, 2, 4, ... up to `max_pass_spp`, then
/// `max_pass_spp` each) clipped to the range, as `(pass index, first sample, count)`.
///
/// Every range, part or resume uses this same schedule, so a render of `[0, n)` has exactly
/// the passes it always had, a range split at pass boundaries of the schedule folds the very
/// same per-pass tile buffers in the same order (bit for bit), and a resume at a checkpoint
/// (always a pass boundary) continues the schedule of the uninterrupted render.
pub fn pass_schedule(
    start: u32,
    end: u32,
    max_pass_spp: u32,
) -> impl Iterator<Item = (u32, u32, u32)> {
    pass_sizes(u32::MAX, max_pass_spp)
        .enumerate()
        .map(|(pass, (s0, n))| (pass as u32, s0, s0.saturating_add(n)))
        .take_while(move |&(_, s0, _)| s0 < end)
        .filter_map(move |(pass, s0, s1)| {
            let (a, b) = (s0.max(start), s1.min(end));
            (a < b).then_some((pass, a, b - a))
        })
}

/// The tiles of the image, clipped to `region` (`[x0, y0, x1, y1)`, half-open) when given;
/// tiles outside it are dropped. Clipped tiles keep their index, so they merge in the same
/// order as in a whole-image render.
pub fn region_tiles(settings: &RenderSettings) -> Vec<TileRect> {
    let all = tiles(settings.width, settings.height, settings.tile_size);
    match settings.region {
        None => all,
        Some([x0, y0, x1, y1]) => all
            .into_iter()
            .filter_map(|t| {
                let r = TileRect {
                    x0: t.x0.max(x0),
                    y0: t.y0.max(y0),
                    x1: t.x1.min(x1),
                    y1: t.y1.min(y1),
                    index: t.index,
                };
                (r.x0 < r.x1 && r.y0 < r.y1).then_some(r)
            })
            .collect(),
    }
}

/// Where a resumed render picks up: the checkpoint's film and the sample index it reached
/// (every pixel of the region holds samples `[settings.sample_start, reached)`).
pub struct Resume {
    pub film: Film,
    pub reached: u32,
}

/// What [`render_observed`] shows its observer after each completed pass.
pub struct PassView<'a> {
    /// The film so far (whole passes only).
    pub film: &'a Film,
    /// Tile records so far, in pass then tile order.
    pub records: &'a [TileRecord],
    /// Samples per pixel so far.
    pub spp: u32,
    /// Seconds since the render started, at the end of this pass (before the observer runs).
    pub seconds: f64,
}

/// Prepares `scene` and renders it on the CPU to the end, with no observer: what a benchmark
/// or a comparison needs from one render. The error is the preparation's.
pub fn render_scene(
    scene: &crate::scene::Scene,
    settings: &RenderSettings,
) -> Result<RenderOutput, String> {
    let rs = RenderScene::prepare(scene, settings)?;
    Ok(render(
        &rs,
        settings,
        &AtomicBool::new(false),
        &|_, _, _| {},
    ))
}

/// Renders `rs` on the CPU. `stop` is polled between tiles: when set, the current pass is
/// abandoned and what earlier passes accumulated is returned.
pub fn render(
    rs: &RenderScene,
    settings: &RenderSettings,
    stop: &AtomicBool,
    progress: Progress,
) -> RenderOutput {
    render_observed(rs, settings, stop, progress, &mut |_| {})
}

/// [`render`], calling `observer` with the film after every completed pass (for convergence
/// studies). The observer's own time counts against `time_limit`: keep it short.
pub fn render_observed(
    rs: &RenderScene,
    settings: &RenderSettings,
    stop: &AtomicBool,
    progress: Progress,
    observer: &mut dyn FnMut(&PassView),
) -> RenderOutput {
    render_resumed(rs, settings, None, stop, progress, observer)
}

/// [`render_observed`] over samples `[settings.sample_start, settings.spp)` of the pixels in
/// `settings.region`, starting from a checkpoint when `resume` is given. `spp` in the output
/// and in the views counts the samples per pixel of the whole range so far (the checkpoint's
/// included).
pub fn render_resumed(
    rs: &RenderScene,
    settings: &RenderSettings,
    resume: Option<Resume>,
    stop: &AtomicBool,
    progress: Progress,
    observer: &mut dyn FnMut(&PassView),
) -> RenderOutput {
    let start = Instant::now();
    // Overlapping media run the generic variant (see `tile::specialised`): say so.
    let features = if settings.generic || rs.features.overlapping {
        FeatureFlags::ALL
    } else {
        rs.features
    };
    let tile_fn = specialised(features);
    let mut ctx = tile_context(rs, settings);
    let rects = region_tiles(settings);
    let (mut film, first) = match resume {
        Some(r) => (r.film, r.reached),
        None => (
            Film::with_passes(settings.width, settings.height, &settings.pass_names()),
            settings.sample_start,
        ),
    };
    let mut records = Vec::new();
    let mut lookups = vec![0u64; (settings.width * settings.height) as usize];
    // With only a time limit, passes continue until it runs out.
    let target = settings.sample_end();
    let mut spp = first - settings.sample_start;
    let mut interrupted = false;
    // Each tile's time per sample in the last pass: the next pass starts the dearest tiles
    // first (see `dearest_first`).
    let mut tile_ns = vec![0u64; rects.len()];
    for (pass, s0, n) in pass_schedule(first, target, settings.max_pass_spp) {
        if settings.must_stop(stop, start) {
            interrupted = true;
            break;
        }
        if let Some(e) = settings.noise_threshold.filter(|_| s0 >= settings.min_spp) {
            // Decided from the film at this pass boundary alone: the same on a resume.
            let noisy = crate::film::adaptive::noisy_pixels(&film, e as f64, settings.min_spp);
            let any = rects.iter().any(|r| {
                (r.y0..r.y1).any(|y| (r.x0..r.x1).any(|x| noisy[(y * settings.width + x) as usize]))
            });
            if !any {
                break;
            }
            ctx.noisy = Some(noisy);
        }
        let Some(outputs) = render_pass(&ctx, tile_fn, &rects, &mut tile_ns, (pass, s0, n), stop)
        else {
            // Interrupted mid-pass: keep the image consistent at whole passes.
            interrupted = true;
            break;
        };
        for out in outputs {
            film.merge_tile(&out.buffer);
            add_lookups(&mut lookups, settings.width, &out);
            records.push(out.record);
        }
        spp += n;
        let seconds = start.elapsed().as_secs_f64();
        progress(spp, settings.spp, seconds);
        observer(&PassView {
            film: &film,
            records: &records,
            spp,
            seconds,
        });
    }
    RenderOutput {
        film,
        records,
        lookups,
        spp,
        seconds: start.elapsed().as_secs_f64(),
        features,
        interrupted,
    }
}

/// The tile loop's context for a render of `rs` with `settings`.
fn tile_context<'a>(rs: &'a RenderScene<'a>, settings: &RenderSettings) -> TileContext<'a> {
    let cfg = TrackingConfig::from_settings(settings);
    let (width, height) = (settings.width, settings.height);
    let volume_sampling = rs.volume_sampling(settings);
    TileContext {
        rs,
        glows: Glows::of_scene(rs, volume_sampling, cfg.time, width, height),
        cfg,
        limits: PathLimits {
            max_depth: settings.max_depth,
            rr_depth: settings.rr_depth,
            rr_throughput: settings.rr_throughput,
            max_collisions: settings.max_collisions_per_path,
            guided_lights: settings.light_selection.guided(),
            continuation_albedo: settings
                .light_selection
                .continuation_albedo(rs.lights.continuation_albedo),
            film_transparent: settings.film_transparent,
            light_passes: settings.light_passes,
            data_passes: settings.data_passes,
            light_groups: !settings.light_groups.is_empty(),
            volume_sampling,
            lamps: Lamps::of_scene(rs, volume_sampling, cfg.time),
        },
        passes: settings.pass_names(),
        noisy: None,
        width,
        height,
        seed: settings.seed,
        sampler: settings.sampler,
    }
}

/// One pass (`pass`, samples `[s0, s0 + n)`) over every tile, dearest first, one job per tile
/// so an idle thread can always take the next one. Returns the tiles' outputs in tile order
/// (the film merges and the records keep that order) and sets each tile's time per sample in
/// `tile_ns`; `None` where `stop` left a tile unrendered.
fn render_pass(
    ctx: &TileContext,
    tile_fn: TileFn,
    rects: &[TileRect],
    tile_ns: &mut [u64],
    (pass, s0, n): (u32, u32, u32),
    stop: &AtomicBool,
) -> Option<Vec<TileOutput>> {
    let done: Vec<(usize, Option<TileOutput>)> = dearest_first(tile_ns)
        .into_par_iter()
        .with_max_len(1)
        .map(|i| {
            let out = (!stop.load(Ordering::Relaxed)).then(|| tile_fn(ctx, &rects[i], pass, s0, n));
            (i, out)
        })
        .collect();
    let mut outputs: Vec<Option<TileOutput>> = (0..rects.len()).map(|_| None).collect();
    for (i, out) in done {
        outputs[i] = out;
    }
    for (cost, out) in tile_ns.iter_mut().zip(&outputs) {
        if let Some(o) = out {
            // Per sample, so a pass of another size compares the same.
            *cost = o.record.counters.wall_ns / n.max(1) as u64;
        }
    }
    outputs.into_iter().collect()
}

/// Adds a tile's per-pixel lookup counts into the image's (`width` pixels a row).
fn add_lookups(lookups: &mut [u64], width: u32, out: &TileOutput) {
    let r = out.buffer.rect();
    for y in r.y0..r.y1 {
        for x in r.x0..r.x1 {
            let i = ((y - r.y0) * r.width() + (x - r.x0)) as usize;
            lookups[(y * width + x) as usize] += out.lookups[i];
        }
    }
}

/// Tile indices, dearest first by `cost` (ties, and the first pass where every cost is 0,
/// in tile order). Tiles differ in cost by 100x or more (the middle of a cloud against empty
/// sky), and rayon hands out work in halves of the list: in raster order a thread could be
/// left with a run of dear tiles while the others idled. Started dearest first, one job per
/// tile, the pass ends on cheap tiles (longest-processing-time-first scheduling, Graham 1969).
fn dearest_first(cost: &[u64]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..cost.len()).collect();
    order.sort_by_key(|&i| std::cmp::Reverse(cost[i]));
    order
}

#[cfg(test)]
mod tests {
    use super::{dearest_first, pass_schedule, pass_sizes};

    #[test]
    fn tiles_start_dearest_first_and_ties_keep_tile_order() {
        assert_eq!(dearest_first(&[0, 0, 0]), [0, 1, 2]);
        assert_eq!(dearest_first(&[5, 90, 5, 7]), [1, 3, 0, 2]);
    }

    #[test]
    fn the_schedule_of_0_n_is_the_old_one_and_ranges_clip_it() {
        for spp in [1, 2, 3, 7, 16, 100] {
            let old: Vec<_> = pass_sizes(spp, 16).collect();
            let new: Vec<_> = pass_schedule(0, spp, 16).map(|p| (p.1, p.2)).collect();
            assert_eq!(old, new);
        }
        assert_eq!(
            pass_schedule(3, 21, 8).collect::<Vec<_>>(),
            [(2, 3, 1), (3, 4, 4), (4, 8, 8), (5, 16, 5)]
        );
        assert_eq!(pass_schedule(5, 5, 8).count(), 0);
    }

    #[test]
    fn passes_cover_the_samples_exactly() {
        for spp in [1, 2, 3, 7, 16, 100] {
            let passes: Vec<_> = pass_sizes(spp, 16).collect();
            assert_eq!(passes.iter().map(|p| p.1).sum::<u32>(), spp);
            assert!(passes.windows(2).all(|w| w[0].0 + w[0].1 == w[1].0));
        }
        assert_eq!(
            pass_sizes(10, 4).collect::<Vec<_>>(),
            [(0, 1), (1, 1), (2, 2), (4, 4), (8, 2)]
        );
    }
}
