//! The wavefront path tracer on wgpu: the same physics as `integrator::path::radiance`,
//! scheduled as a graph of kernels over queues of paths (Laine et al. 2013, "Megakernels
//! considered harmful"; pbrt-v4's and Cycles' GPU integrators).
//!
//! The stages are named once, in [`Stage`]; each is one WGSL entry point in its own file under
//! `shaders/stages/`, opening with a comment that names the Rust code it mirrors. A fixed number
//! of path slots ([`WAVEFRONT_SIZE`]) holds [`GpuPathState`]s; a stage consumes the slots in its
//! input queue and appends each to the queue of the stage that handles it next. Queue lengths
//! live in atomic counters and become `dispatch_workgroups_indirect` arguments on the GPU
//! (`kernels/queues.wgsl`), so the host only reads two counters per iteration to know when a
//! batch is finished. Finished slots are regenerated with the batch's next camera sample until
//! every pixel of the batch has its samples.
//!
//! One iteration (parity `p` picks the double-buffered medium and done queues):
//!
//! ```text
//! reset -> Generate -> Intersect -> SampleMedium -> ScatterMedium -> ShadeSurface
//!       -> TraceShadow -> Emitters -> SamplePhase -> Escape -> Accumulate
//! ```
//!
//! Each path keeps its own stream `Rng::new(pixel, sample, seed)` and draws from it in the
//! CPU's order (the shadow stage, then the media lights' stage, run before the direction stage
//! for that reason). The
//! fixed-layout decisions (jitter, light selection and sample, lobe, direction, roulette) come
//! from `shaders/common/sobol.wgsl` by dimension block when `settings.sampler` is Sobol (the
//! `SAMPLER_SOBOL` specialisation), the path's pixel and sample index following from its batch
//! entry, so the path state does not grow. Results agree
//! with the CPU statistically, and with the same seed nearly bit for bit (rounding of WGSL's
//! transcendentals may flip a rare decision).
//!
//! What runs: everything the CPU integrator does for VDB media (every estimator, every
//! majorant mode, spectral tracking of chromatic media, volume emission, emitting media
//! sampled as lights (`render::media_lights`, the `Emitters` stage); several media,
//! overlapping or inside homogeneous ones, in the mixture variant, `mixture.wgsl`),
//! homogeneous media in closed meshes (grey and chromatic, nested up to three deep on a
//! per-path medium stack), opaque, dielectric and null-interface surfaces over obvhs' CWBVH,
//! punctual, environment and area lights with NEE and MIS, Russian roulette and the collision
//! guard, velocity and camera motion blur (a time per path, advected lookups, the camera posed
//! at each sample's time: `advection.wgsl`), the light passes (`RenderSettings::light_passes`:
//! the `FEATURE_LIGHT_PASSES` variant routes every contribution to its pass as
//! `PathState::gather` does, into per-slot accumulators beside the path state, read back per
//! camera sample with the batch) and the data passes (`RenderSettings::data_passes`: the
//! `FEATURE_DATA_PASSES` variant records albedo, normal and depth where `PathState::data`
//! takes them, in a `GpuDataPasses` per slot read back the same way) and the light groups
//! (`RenderSettings::light_groups`: the `FEATURE_LIGHT_GROUPS` variant gathers each
//! contribution into its source's group, after the light passes in the same per-slot
//! accumulators, read back with them). [`supports`] refuses,
//! with a one-line reason, more than [`crate::gpu_types::GPU_MAX_VDB_MEDIA`] VDB media and media meshes nested
//! deeper than three; [`supports_with`] also refuses emitting media sampled as lights
//! (`RenderSettings::media_lights`), which render on the CPU only.
//! The scene's [`FeatureFlags`] choose the stages ([`Stage::for_features`]) and the WGSL
//! variant ([`variant_name`]): the code of a missing feature is cut at assembly.
//!
//! Timing: one compute pass per stage dispatch. With timestamp queries
//! ([`GpuContext::timestamp_queries`]) each pass records its GPU start and end
//! ([`TimingSource::TimestampQueries`]); without them every stage is submitted alone and timed
//! on the host's clock ([`TimingSource::WallClock`]).
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use super::buffers::{kernel, Buffers};
use super::device::{byte_size, GpuContext, GpuGrid};
use super::dispatch::{BatchSamples, Wavefront};
pub use super::error::GpuRenderError;
use super::geometry::Geometry;
use super::graph::specs;
pub use super::graph::{gpu_features, variant_name, variant_name_with_passes, Passes, Stage};
use super::params::wavefront_params;
use super::shader;
pub use super::support::{supports, supports_with};
use super::upload::{env_map_upload, upload_grid, Textures};
use crate::backend::cpu::{pass_schedule, Progress, RenderOutput};
use crate::film::passes::PassLayers;
use crate::film::{Film, TileRecord, TileRect};
use crate::gpu_types::{
    GpuDataPasses, GpuPathState, GpuSample, GpuWavefrontCounters, GpuWideCounter,
    GPU_DATA_PASS_BYTES, GPU_LIGHT_PASSES,
};
use crate::integrator::path::DATA_PASS_COUNT;
use crate::render::light_groups::MAX_LIGHT_GROUPS;
use crate::render::media::TrackingConfig;
use crate::render::{FeatureFlags, RenderScene, RenderSettings};

/// Path slots in flight at most: enough to fill a large GPU's resident threads (with fewer,
/// one iteration's kernels take less time than the host's round trip), and 2^18 paths take
/// 32 MiB of path state.
pub const WAVEFRONT_SIZE: u32 = 1 << 18;

/// Camera samples per batch at most (one [`crate::gpu_types::GpuSample`] of 32 bytes each, and
/// with the passes `16 * Passes::light_entries` and [`GPU_DATA_PASS_BYTES`] more).
pub const MAX_BATCH_SAMPLES: u64 = 1 << 22;

/// How [`GpuTimings`] were measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimingSource {
    /// GPU timestamps at the start and end of each stage's compute pass.
    TimestampQueries,
    /// Host clock around each stage submitted alone and waited for.
    WallClock,
}

/// Per-stage GPU time of one batch.
#[derive(Clone, Debug, PartialEq)]
pub struct BatchTimings {
    /// Index into [`RenderOutput::records`].
    pub record: usize,
    /// Wavefront iterations the batch took.
    pub iterations: u32,
    /// Nanoseconds per stage, in [`Stage::ALL`] order (0 for stages not dispatched).
    pub stage_ns: [u64; Stage::COUNT],
    /// Host wall time of the wavefront iterations (kernels and the host's round trip after
    /// each iteration), of reading the batch's samples back, and of merging them into the
    /// film (ns): where a render's time goes beyond its kernels.
    pub loop_ns: u64,
    pub readback_ns: u64,
    pub merge_ns: u64,
}

/// Timings of a GPU render, per batch and stage.
#[derive(Clone, Debug, PartialEq)]
pub struct GpuTimings {
    pub source: TimingSource,
    pub batches: Vec<BatchTimings>,
    /// The WGSL variant: the features the kernels were specialised for.
    pub variant: String,
    pub adapter: String,
    /// The surfaces as uploaded: bytes, and triangles stored and placed.
    pub geometry: String,
}

impl GpuTimings {
    /// Nanoseconds per stage over the whole render.
    pub fn stage_totals(&self) -> [u64; Stage::COUNT] {
        let mut t = [0u64; Stage::COUNT];
        for b in &self.batches {
            for (a, x) in t.iter_mut().zip(b.stage_ns) {
                *a += x;
            }
        }
        t
    }
}

/// Renders `rs` on the GPU; see [`render_with_timings`].
pub fn render(
    ctx: &GpuContext,
    rs: &RenderScene,
    settings: &RenderSettings,
    stop: &AtomicBool,
    progress: Progress,
) -> Result<RenderOutput, GpuRenderError> {
    render_with_timings(ctx, rs, settings, stop, progress).map(|(out, _)| out)
}

/// Renders `rs` on the GPU in the CPU backend's passes (1, 1, 2, 4, ... samples per pixel),
/// each pass in batches of whole rows (one [`TileRecord`] per batch, its rectangle the rows,
/// `wall_ns` the batch's host time). Returns per-stage timings alongside.
pub fn render_with_timings(
    ctx: &GpuContext,
    rs: &RenderScene,
    settings: &RenderSettings,
    stop: &AtomicBool,
    progress: Progress,
) -> Result<(RenderOutput, GpuTimings), GpuRenderError> {
    render_observed(ctx, rs, settings, stop, progress, &mut |_, _| {})
}

/// What a render shows of itself after each pass: the film and, where it keeps passes, their
/// statistics so far (a viewer's image).
pub type PassObserver<'a> = &'a mut dyn FnMut(&Film, Option<&PassLayers>);

/// [`render_with_timings`], handing the film to `observer` after every pass.
pub fn render_observed(
    ctx: &GpuContext,
    rs: &RenderScene,
    settings: &RenderSettings,
    stop: &AtomicBool,
    progress: Progress,
    observer: PassObserver,
) -> Result<(RenderOutput, GpuTimings), GpuRenderError> {
    let start = Instant::now();
    check_supported(rs, settings)?;
    let (scene_features, features) = variant_features(rs, settings);
    let cfg = TrackingConfig::from_settings(settings);
    let (w, h) = (settings.width, settings.height);
    let limit = ctx.limits.max_storage_buffer_binding_size;
    let uploaded = upload_grid(ctx, rs, features, &cfg)?;
    let (grid, emission, vdb_media) = (uploaded.grid, uploaded.emission, uploaded.media);
    let passes = Passes::of(settings);
    let plan = BatchPlan::new(settings, limit)?;
    let slots = slot_count(limit, &plan, passes);
    let mut params = wavefront_params(rs, settings, &cfg, features, slots);
    params.blur = uploaded.blur;
    if let Some(lights) = &rs.media_lights {
        params.media_light_cells = lights.cells() as u32;
        params.media_light_nodes = super::media_lights::media_light_nodes(lights);
    }
    let geometry = Geometry::new(rs, limit).map_err(GpuRenderError::Limits)?;
    params.placement_count = geometry.placement_count;
    let textures = Textures::new(rs.scene, limit).map_err(GpuRenderError::Unsupported)?;
    let env_map = env_map_upload(rs, settings, limit).map_err(GpuRenderError::Limits)?;

    let timestamps = ctx.timestamp_queries;
    let bufs = Buffers::new(
        ctx,
        rs,
        &params,
        slots,
        plan.largest,
        passes,
        &emission,
        &geometry,
        &textures,
        &env_map,
        &vdb_media,
    );
    let mut wave = wavefront(ctx, &bufs, grid.as_ref(), features, settings, slots)?;
    let names = settings.pass_names();
    let mut film = Film::with_passes(w, h, &names);
    // The film's passes while batches merge into them (the film hands out no mutable view of
    // its own); they become the film's when the render ends.
    let mut layers = passes
        .any()
        .then(|| PassLayers::new(&names, (w * h) as usize));
    let mut records = Vec::new();
    let mut batches = Vec::new();
    let mut lookups = vec![0u64; (w * h) as usize];
    let mut spp = 0u32;
    let mut interrupted = false;
    // Samples [sample_start, spp) in the CPU's pass schedule, so GPU parts merge with CPU ones.
    for (pass, s0, n) in pass_schedule(settings.sample_start, plan.target, settings.max_pass_spp) {
        if settings.must_stop(stop, start) {
            interrupted = true;
            break;
        }
        let rows = (plan.max_samples(w, h, n) / (w as u64 * n as u64)) as u32;
        let Some(pending) = run_pass(&mut wave, &mut params, (pass, s0, n), (w, h), rows, stop)?
        else {
            interrupted = true;
            break;
        };
        // The pass is complete: merge it (an interrupted pass is dropped, as on the CPU).
        for (r, iterations, stage_ns, samples, (loop_ns, readback_ns)) in pending {
            let merge_start = Instant::now();
            if let Some(layers) = &mut layers {
                // Before the beauty's counts change: the merge takes the counts before it.
                merge_batch_passes(layers, &film, &r, (n, passes), &samples);
            }
            merge_batch(&mut film, &mut lookups, w, &r, n, &samples.samples);
            batches.push(BatchTimings {
                record: records.len(),
                iterations,
                stage_ns,
                loop_ns,
                readback_ns,
                merge_ns: merge_start.elapsed().as_nanos() as u64,
            });
            records.push(r);
        }
        spp += n;
        progress(spp, settings.spp, start.elapsed().as_secs_f64());
        observer(&film, layers.as_ref());
    }
    if let Some(layers) = layers {
        film.set_passes(layers);
    }
    let out = RenderOutput {
        film,
        records,
        lookups,
        spp,
        seconds: start.elapsed().as_secs_f64(),
        features: scene_features,
        interrupted,
    };
    let timings = GpuTimings {
        source: if timestamps {
            TimingSource::TimestampQueries
        } else {
            TimingSource::WallClock
        },
        batches,
        variant: variant_name_with_passes(features, passes),
        adapter: ctx.adapter_name().to_string(),
        geometry: geometry.describe(),
    };
    Ok((out, timings))
}

/// The flags the output reports and those the kernels are specialised for. As on the CPU,
/// the generic variant has every feature on; the variant's flags also count disjoint VDB media
/// as a mixture (`gpu_features`), and distance sampling alone carries no equiangular code.
fn variant_features(rs: &RenderScene, settings: &RenderSettings) -> (FeatureFlags, FeatureFlags) {
    if settings.generic {
        return (FeatureFlags::ALL, FeatureFlags::ALL);
    }
    let f = super::graph::gpu_features(rs);
    let equiangular =
        f.equiangular && settings.volume_sampling != crate::render::VolumeSampling::Distance;
    (rs.features, FeatureFlags { equiangular, ..f })
}

/// The stages' kernels for `features`, compiled for `settings`' sampler and passes, over
/// `bufs`, `slots` path slots wide.
fn wavefront<'a>(
    ctx: &'a GpuContext,
    bufs: &'a Buffers,
    grid: Option<&GpuGrid>,
    features: FeatureFlags,
    settings: &RenderSettings,
    slots: u32,
) -> Result<Wavefront<'a>, GpuRenderError> {
    let passes = Passes::of(settings);
    let sp = specs(features, settings.sampler, passes);
    let mut kernels = Vec::new();
    for s in Stage::for_features(features) {
        kernels.push((s, kernel(ctx, &s.module(), &sp, bufs, grid)?));
    }
    Ok(Wavefront {
        ctx,
        bufs,
        kernels,
        reset: kernel(ctx, &shader::QUEUE_RESET_MODULE, &sp, bufs, grid)?,
        args: kernel(ctx, &shader::QUEUE_ARGS_MODULE, &sp, bufs, grid)?,
        slots,
        period_ns: ctx.queue.get_timestamp_period() as f64,
        passes,
    })
}

/// Refuses what the GPU integrator does not render as the CPU would, before any upload.
fn check_supported(rs: &RenderScene, settings: &RenderSettings) -> Result<(), GpuRenderError> {
    supports_with(rs, settings).map_err(GpuRenderError::Unsupported)?;
    settings.validate().map_err(GpuRenderError::Unsupported)?;
    let groups = rs.groups.as_ref().map_or(&[][..], |g| &g.names[..]);
    if groups != settings.light_groups.as_slice() {
        // The kernels take each source's group from the render scene (`RenderScene::prepare`).
        return Err(GpuRenderError::Unsupported(format!(
            "the light groups asked for ({}) are not the render scene's ({})",
            settings.light_groups.join(", "),
            groups.join(", ")
        )));
    }
    if settings.noise_threshold.is_some() {
        return Err(GpuRenderError::Unsupported(
            "adaptive sampling renders on the CPU backend only".into(),
        ));
    }
    if settings.region.is_some() {
        // Batches are whole rows of the image; a region split is a CPU feature.
        return Err(GpuRenderError::Unsupported(
            "--region renders on the CPU backend only (--samples works on both)".into(),
        ));
    }
    Ok(())
}

/// Bytes of the largest pass binding entry, a path slot's or a camera sample's: the light
/// passes' and groups' (one buffer) or the data passes' where kept, else 0.
fn pass_entry_bytes(passes: Passes) -> u64 {
    let light = passes.light_entries() as u64 * 16;
    let data = if passes.data { GPU_DATA_PASS_BYTES } else { 0 };
    light.max(data)
}

/// Wavefront slots: the path state is the largest per-slot binding (the passes' are smaller),
/// so a device that binds less than `limit` bytes gets fewer slots (a power of two, so whole
/// workgroups), never a binding error.
fn slot_count(limit: u64, plan: &BatchPlan, passes: Passes) -> u32 {
    let path_bytes = std::mem::size_of::<GpuPathState>() as u64;
    let fit = (limit / path_bytes.max(pass_entry_bytes(passes))).max(64);
    (WAVEFRONT_SIZE as u64)
        .min(1 << fit.ilog2())
        .min(plan.largest) as u32
}

/// A batch of a pass run, with its record and what its timings need.
type PendingBatch = (
    TileRecord,
    u32,
    [u64; Stage::COUNT],
    BatchSamples,
    (u64, u64),
);

/// Runs pass `pass` (samples `[s0, s0 + n)`) of a `w` x `h` image in batches of `rows` whole
/// rows; `None` where `stop` interrupted it.
fn run_pass(
    wave: &mut Wavefront,
    params: &mut crate::gpu_types::GpuWavefrontParams,
    (pass, s0, n): (u32, u32, u32),
    (w, h): (u32, u32),
    rows: u32,
    stop: &AtomicBool,
) -> Result<Option<Vec<PendingBatch>>, GpuRenderError> {
    let mut pending = Vec::new();
    let mut y0 = 0;
    while y0 < h {
        let y1 = (y0 + rows).min(h);
        let batch_start = Instant::now();
        params.pixel0 = y0 * w;
        params.s0 = s0;
        params.spp_batch = n;
        params.total_samples = (y1 - y0) * w * n;
        let Some((counters, iterations, stage_ns, samples, host_ns)) =
            wave.run_batch(params, stop)?
        else {
            return Ok(None);
        };
        let rect = TileRect {
            x0: 0,
            y0,
            x1: w,
            y1,
            index: pending.len() as u32,
        };
        let mut r = batch_record(pass, &rect, &counters);
        r.counters.samples = params.total_samples as u64;
        r.counters.wall_ns = batch_start.elapsed().as_nanos() as u64;
        pending.push((r, iterations, stage_ns, samples, host_ns));
        y0 = y1;
    }
    Ok(Some(pending))
}

/// How a render's passes are cut into batches: whole rows, at most [`MAX_BATCH_SAMPLES`]
/// samples, and each per-sample buffer (the samples, and the light passes where kept) within
/// one storage binding.
struct BatchPlan {
    /// Samples per pixel to render (`u32::MAX` for "until stopped").
    target: u32,
    /// Samples a batch may hold at most.
    max_batch: u64,
    /// The largest batch of any pass: the sample buffer's length.
    largest: u64,
}

impl BatchPlan {
    fn new(settings: &RenderSettings, limit: u64) -> Result<BatchPlan, GpuRenderError> {
        let (w, h) = (settings.width, settings.height);
        let target = settings.sample_end();
        // The largest per-sample binding: the sample entries, or the passes beside them.
        let entry =
            (std::mem::size_of::<GpuSample>() as u64).max(pass_entry_bytes(Passes::of(settings)));
        let mut plan = BatchPlan {
            target,
            max_batch: MAX_BATCH_SAMPLES.min(limit / entry).max(1),
            largest: 1,
        };
        plan.largest = pass_schedule(
            settings.sample_start,
            target.min(1 << 16),
            settings.max_pass_spp,
        )
        .map(|(_, _, n)| plan.max_samples(w, h, n))
        .max()
        .unwrap_or(1);
        if plan.largest * entry > limit {
            return Err(GpuRenderError::Limits(format!(
                "one row of {w} pixels at {} samples per pass needs {} of sample buffer; the device binds {}",
                settings.max_pass_spp,
                byte_size(plan.largest * entry),
                byte_size(limit)
            )));
        }
        Ok(plan)
    }

    /// Samples in a batch of whole rows at `n` samples per pixel.
    fn max_samples(&self, w: u32, h: u32, n: u32) -> u64 {
        let rows = (self.max_batch / (w as u64 * n as u64)).clamp(1, h as u64);
        rows * w as u64 * n as u64
    }
}

/// The tile record of one batch from the wavefront's counters after it.
fn batch_record(pass: u32, rect: &TileRect, counters: &GpuWavefrontCounters) -> TileRecord {
    let mut r = TileRecord::new(pass, rect);
    r.counters.density_lookups = counters.wide(GpuWideCounter::Lookups);
    r.counters.null_collisions = counters.wide(GpuWideCounter::NullCollisions);
    r.counters.real_collisions = counters.wide(GpuWideCounter::RealCollisions)
        + counters.wide(GpuWideCounter::ControlCollisions);
    r.counters.shadow_lookups = counters.wide(GpuWideCounter::ShadowLookups);
    r.counters.path_length_sum = counters.wide(GpuWideCounter::DepthSum);
    r.counters.emission_lookups = counters.wide(GpuWideCounter::EmissionLookups);
    r.counters.majorant_segments = counters.wide(GpuWideCounter::Segments);
    r.counters.shadow_segments = counters.wide(GpuWideCounter::ShadowSegments);
    r.counters.guard_fired = counters.guard_fired as u64;
    r.counters.majorant_violations = counters.majorant_violations as u64;
    r
}

/// Adds a batch's samples (radiance, coverage and lookup count, `n` per pixel in row order over
/// the record's rows) to the film and the per-pixel lookup counts. Pixels are independent and
/// each takes its samples in order, so the rows run in parallel and the film is the same bit
/// for bit as a sequential merge.
fn merge_batch(
    film: &mut Film,
    lookups: &mut [u64],
    w: u32,
    r: &TileRecord,
    n: u32,
    samples: &[GpuSample],
) {
    use rayon::prelude::*;
    let (w, n) = (w as usize, n as usize);
    let rows = r.y0 as usize * w..r.y1 as usize * w;
    debug_assert_eq!(
        samples.len(),
        rows.len() * n,
        "a batch holds n samples a pixel"
    );
    film.rows_mut(r.y0, r.y1)
        .par_iter_mut()
        .zip(lookups[rows].par_iter_mut())
        .zip(samples.par_chunks(n))
        .for_each(|((pixel, count), s)| {
            for s in s {
                pixel.add([s.l[0], s.l[1], s.l[2], s.alpha]);
                *count += s.lookups as u64;
            }
        });
}

/// Adds a batch's passes to the render's `layers`, as the CPU does a tile's: each sample's
/// light passes (`GPU_LIGHT_PASSES` entries a sample, where kept), then its data passes (one
/// `GpuDataPasses`, where kept), then its light groups (`kept.groups` entries after its light
/// passes), the order of `RenderSettings::pass_names`; each row's `n` samples a pixel into
/// fresh statistics in sample order (`TileBuffer::add_sample_passes`), then merged with the
/// pixel's earlier samples (`Film::merge_tile`, the counts taken from `film` before the
/// batch's beauty is added). The rows run in parallel; the merge is sequential and cheap.
fn merge_batch_passes(
    layers: &mut PassLayers,
    film: &Film,
    r: &TileRecord,
    (n, kept): (u32, Passes),
    batch: &BatchSamples,
) {
    use rayon::prelude::*;
    let (w, n) = (film.width() as usize, n as usize);
    let count = (r.y1 - r.y0) as usize * w * n;
    let k = kept.light_entries() as usize;
    let p = kept.light as usize * GPU_LIGHT_PASSES as usize;
    let (light, data) = (&batch.passes, &batch.data);
    debug_assert!(
        light.len() == count * k && data.len() == kept.data as usize * count,
        "a batch holds n samples a pixel, each with its passes"
    );
    let per_sample = k + kept.data as usize * DATA_PASS_COUNT;
    debug_assert_eq!(per_sample, layers.names().len());
    let rows: Vec<PassLayers> = (0..(r.y1 - r.y0) as usize)
        .into_par_iter()
        .map(|row| {
            let mut stats = PassLayers::new(layers.names(), w);
            let mut values =
                [[0f32; 3]; GPU_LIGHT_PASSES as usize + DATA_PASS_COUNT + MAX_LIGHT_GROUPS];
            for x in 0..w {
                for j in 0..n {
                    let s = (row * w + x) * n + j;
                    let (passes, groups) = light[s * k..(s + 1) * k].split_at(p);
                    let data = data.get(s).map(GpuDataPasses::values);
                    let rgb = |v: &[f32; 4]| [v[0], v[1], v[2]];
                    let all = passes
                        .iter()
                        .map(rgb)
                        .chain(data.into_iter().flatten())
                        .chain(groups.iter().map(rgb));
                    for (slot, v) in values.iter_mut().zip(all) {
                        *slot = v;
                    }
                    stats.add(x, j as u32 + 1, &values[..per_sample]);
                }
            }
            stats
        })
        .collect();
    for (y, row) in (r.y0 as usize..).zip(&rows) {
        for x in 0..w {
            let i = y * w + x;
            layers.merge(i, film.pixels()[i].count, row, x, n as u32);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::rng::Rng;

    /// The parallel merge gives the film a sequential merge gives, bit for bit, and adds the
    /// lookup counts of exactly the batch's rows.
    #[test]
    fn a_batch_merges_as_its_samples_added_in_order() {
        let (w, h, n) = (7u32, 5u32, 3u32);
        let record = TileRecord {
            y0: 1,
            y1: 4,
            ..TileRecord::default()
        };
        let mut rng = Rng::new(3, 0, 11);
        let samples: Vec<GpuSample> = (0..(record.y1 - record.y0) * w * n)
            .map(|k| {
                let v = rng.uniform_f32() * 10.0;
                GpuSample {
                    l: [v, v * v, -v],
                    lookups: k,
                    alpha: v / 10.0,
                    ..Default::default()
                }
            })
            .collect();
        let mut film = Film::new(w, h);
        let mut lookups = vec![0u64; (w * h) as usize];
        merge_batch(&mut film, &mut lookups, w, &record, n, &samples);
        let mut expected = Film::new(w, h);
        let mut expected_lookups = vec![0u64; (w * h) as usize];
        let mut k = 0;
        for y in record.y0..record.y1 {
            for x in 0..w {
                for _ in 0..n {
                    let s = samples[k];
                    expected.add_sample(x, y, [s.l[0], s.l[1], s.l[2], s.alpha]);
                    expected_lookups[(y * w + x) as usize] += k as u64;
                    k += 1;
                }
            }
        }
        assert_eq!(lookups, expected_lookups);
        for y in 0..h {
            for x in 0..w {
                assert_eq!(film.pixel(x, y), expected.pixel(x, y), "pixel ({x}, {y})");
            }
        }
    }

    /// A batch's passes merge into the render's as the CPU merges a tile's: the same
    /// statistics, bit for bit, as `TileBuffer::add_sample_passes` then `Film::merge_tile`,
    /// over two passes of the same rows, with the light passes, the data passes, the light
    /// groups, and each with the others.
    #[test]
    fn a_batchs_passes_merge_as_the_cpus_tile() {
        let kinds = [
            (true, false, 0),
            (false, true, 0),
            (true, true, 0),
            (false, false, 3),
        ];
        for (light, data, groups) in kinds.into_iter().chain([(true, true, 2), (false, true, 1)]) {
            batch_passes_merge_as_the_cpus_tile(Passes {
                light,
                data,
                groups,
            });
        }
    }

    fn batch_passes_merge_as_the_cpus_tile(kept: Passes) {
        use crate::film::passes::{DATA_PASSES, LIGHT_PASSES};
        use crate::film::TileBuffer;
        let (w, h, n) = (5u32, 4u32, 3u32);
        let light_names = LIGHT_PASSES.iter().filter(|_| kept.light);
        let data_names = DATA_PASSES.iter().filter(|_| kept.data);
        let group_names = (0..kept.groups).map(|g| format!("light.l{g}"));
        let names: Vec<String> = light_names
            .chain(data_names)
            .map(|s| s.to_string())
            .chain(group_names)
            .collect();
        let k = kept.light_entries() as usize;
        let p = kept.light as usize * GPU_LIGHT_PASSES as usize;
        let rect = TileRect {
            x0: 0,
            y0: 1,
            x1: w,
            y1: 3,
            index: 0,
        };
        let record = TileRecord {
            y0: rect.y0,
            y1: rect.y1,
            ..TileRecord::default()
        };
        let mut rng = Rng::new(5, 0, 17);
        let mut u = || rng.uniform_f32();
        let mut film = Film::new(w, h);
        let mut layers = PassLayers::new(&names, (w * h) as usize);
        let mut expected = Film::with_passes(w, h, &names);
        for pass in 0..2 {
            let count = ((rect.y1 - rect.y0) * w * n) as usize;
            let passes: Vec<[f32; 4]> = (0..count * k).map(|_| [u(), u(), -u(), 0.0]).collect();
            let data: Vec<GpuDataPasses> = (0..count * kept.data as usize)
                .map(|_| GpuDataPasses {
                    albedo: [u(), u(), u()],
                    depth: 10.0 * u(),
                    normal: [u(), -u(), u()],
                    _pad0: 0,
                })
                .collect();
            let samples: Vec<GpuSample> = (0..count)
                .map(|_| GpuSample {
                    l: [u(), u(), u()],
                    ..Default::default()
                })
                .collect();
            let batch = BatchSamples {
                samples,
                passes,
                data,
            };
            merge_batch_passes(&mut layers, &film, &record, (n, kept), &batch);
            let mut lookups = vec![0u64; (w * h) as usize];
            merge_batch(&mut film, &mut lookups, w, &record, n, &batch.samples);
            let mut tile = TileBuffer::with_passes(rect, pass, &names);
            let mut s = 0;
            for y in rect.y0..rect.y1 {
                for x in 0..w {
                    for _ in 0..n {
                        // Light passes, data passes, then light groups, as `render_tile`
                        // lists them.
                        let entries: Vec<[f32; 3]> = batch.passes[s * k..(s + 1) * k]
                            .iter()
                            .map(|v| [v[0], v[1], v[2]])
                            .collect();
                        let mut rgb = entries[..p].to_vec();
                        if let Some(d) = batch.data.get(s) {
                            rgb.extend([d.albedo, d.normal, [d.depth; 3]]);
                        }
                        rgb.extend(&entries[p..]);
                        let l = batch.samples[s].l;
                        tile.add_sample_passes(x, y, [l[0], l[1], l[2], 0.0], &rgb);
                        s += 1;
                    }
                }
            }
            expected.merge_tile(&tile);
        }
        assert_eq!(Some(&layers), expected.passes(), "{kept:?}");
    }
}
