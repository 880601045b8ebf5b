//! One tile of one pass on the CPU, and the choice of the specialised version to run.
use std::time::Instant;

use glam::Vec2;

use super::features::{AllFeatures, Features, Variant};
use super::glow::Glows;
use super::path::{radiance, PathLimits, PathStats};
use super::path::{DATA_PASS_COUNT, LIGHT_PASS_COUNT};
use crate::film::{TileBuffer, TileRecord, TileRect};
use crate::render::light_groups::MAX_LIGHT_GROUPS;
use crate::render::media::TrackingConfig;
use crate::render::prepare::{FeatureFlags, RenderScene};
use crate::sampling::sobol::DIM_JITTER;
use crate::sampling::{Sampler, SamplerKind};

/// Everything a tile needs, shared by all tiles of a render.
pub struct TileContext<'a> {
    pub rs: &'a RenderScene<'a>,
    pub cfg: TrackingConfig,
    pub limits: PathLimits,
    pub width: u32,
    pub height: u32,
    pub seed: u32,
    pub sampler: SamplerKind,
    /// The passes kept beside the beauty (`RenderSettings::pass_names`).
    pub passes: Vec<String>,
    /// Under adaptive sampling, the pixels (row-major over the image) that still take
    /// samples this pass; `None`: all of them.
    pub noisy: Option<Vec<bool>>,
    /// Where the jitter is drawn towards lamps seen through media ([`Glows`]).
    pub glows: Glows,
}

const _: () = assert!(LIGHT_PASS_COUNT == crate::film::passes::LIGHT_PASSES.len());
const _: () = assert!(DATA_PASS_COUNT == crate::film::passes::DATA_PASSES.len());

/// A rendered tile: its samples, its log record and per-pixel density lookups (for the cost
/// map, in the tile's row-major order).
pub struct TileOutput {
    pub buffer: TileBuffer,
    pub record: TileRecord,
    pub lookups: Vec<u64>,
}

/// A specialised tile renderer.
pub type TileFn = fn(&TileContext, &TileRect, u32, u32, u32) -> TileOutput;

/// Renders samples `[s0, s0 + n)` of every pixel of `rect` in pass `pass`. Each (pixel,
/// sample) has its own random stream and its own Sobol points at its global sample index, so
/// the image depends neither on tiling, threads nor the split into passes.
pub fn render_tile<F: Features>(
    ctx: &TileContext,
    rect: &TileRect,
    pass: u32,
    s0: u32,
    n: u32,
) -> TileOutput {
    let start = Instant::now();
    let mut buffer = TileBuffer::with_passes(*rect, pass, &ctx.passes);
    let mut record = TileRecord::new(pass, rect);
    let mut lookups = vec![0u64; rect.pixel_count()];
    let mut total = PathStats::default();
    let aspect = ctx.width as f32 / ctx.height as f32;
    // One sampler for the tile, moved from pixel to pixel.
    let mut sampler = Sampler::for_pixel(ctx.sampler, 0, ctx.seed);
    let mut samples = 0u64;
    for y in rect.y0..rect.y1 {
        for x in rect.x0..rect.x1 {
            let pixel = y * ctx.width + x;
            if ctx
                .noisy
                .as_ref()
                .is_some_and(|noisy| !noisy[pixel as usize])
            {
                continue;
            }
            samples += n as u64;
            let before = total.media.tracking.lookups + total.media.emission_lookups;
            sampler.set_pixel(pixel);
            for s in s0..s0 + n {
                sampler.start(s);
                let (jitter, weight) = ctx.glows.jitter(x, y, sampler.get2d(DIM_JITTER));
                let film = Vec2::new(
                    (x as f32 + jitter.x) / ctx.width as f32,
                    (y as f32 + jitter.y) / ctx.height as f32,
                );
                let mut sample = radiance::<F>(
                    ctx.rs,
                    &ctx.cfg,
                    &ctx.limits,
                    film,
                    aspect,
                    &mut sampler,
                    &mut total,
                );
                if weight != 1.0 {
                    sample.scale(weight);
                }
                let limits = &ctx.limits;
                if limits.light_passes || limits.data_passes || limits.light_groups {
                    // Light passes, data passes, then light groups: `RenderSettings::pass_names`'
                    // order.
                    let light = sample.passes.iter().filter(|_| limits.light_passes);
                    let data = sample.data.iter().filter(|_| limits.data_passes);
                    let groups = &sample.groups[..ctx.rs.groups.as_ref().map_or(0, |g| g.len())];
                    let mut values =
                        [[0f32; 3]; LIGHT_PASS_COUNT + DATA_PASS_COUNT + MAX_LIGHT_GROUPS];
                    let mut k = 0;
                    for v in light.chain(data).chain(groups) {
                        values[k] = v.to_array();
                        k += 1;
                    }
                    buffer.add_sample_passes(x, y, sample.rgba(), &values[..k]);
                } else {
                    buffer.add_sample(x, y, sample.rgba());
                }
            }
            let i = ((y - rect.y0) * rect.width() + (x - rect.x0)) as usize;
            lookups[i] = total.media.tracking.lookups + total.media.emission_lookups - before;
        }
    }
    let t = &total.media.tracking;
    record.counters.samples = samples;
    record.counters.wall_ns = start.elapsed().as_nanos() as u64;
    record.counters.density_lookups = t.lookups;
    record.counters.null_collisions = t.null_collisions;
    record.counters.real_collisions = t.real_collisions + t.control_collisions;
    record.counters.shadow_lookups = total.media.shadow_lookups;
    record.counters.path_length_sum = total.depth;
    record.counters.guard_fired = total.guard_fired;
    record.counters.majorant_violations = t.majorant_violations;
    record.counters.emission_lookups = total.media.emission_lookups;
    record.counters.majorant_segments = t.segments;
    record.counters.shadow_segments = total.media.shadow_segments;
    TileOutput {
        buffer,
        record,
        lookups,
    }
}

/// `[render_tile::<Variant<B>>, ...]` for each bit set `B` listed.
macro_rules! variants {
    ($($bits:literal)*) => {
        [$(render_tile::<Variant<$bits>> as TileFn),*]
    };
}

/// The 64 variants without the mixture, indexed by the bits of `FeatureFlags::as_array`.
static SPECIALISED: [TileFn; 64] = variants![
    0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25 26 27 28 29 30 31
    32 33 34 35 36 37 38 39 40 41 42 43 44 45 46 47 48 49 50 51 52 53 54 55 56 57 58 59 60 61
    62 63
];

/// The tile renderer compiled for exactly `features` (the generic one when all are on). The
/// mixture of overlapping media (`F::MIX`) is compiled into the generic variant only: a scene
/// with `features.overlapping` runs the generic code (`backend::cpu` then reports every
/// feature on), every other scene a variant without the mixture, so the 64 specialised
/// variants do not double.
pub fn specialised(features: FeatureFlags) -> TileFn {
    if features.overlapping {
        return render_tile::<AllFeatures>;
    }
    let bits = features
        .as_array()
        .iter()
        .enumerate()
        .fold(0, |bits, (i, &on)| bits | usize::from(on) << i);
    SPECIALISED[bits]
}
