//! One tile of one pass on the CPU, and the choice of the specialised version to run.
use std::time::Instant;

use glam::Vec2;

use super::path::{radiance, PathLimits, PathStats};
use crate::film::{TileBuffer, TileRecord, TileRect};
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
}

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
pub fn render_tile<
    const SURF: bool,
    const HET: bool,
    const HOM: bool,
    const EMIT: bool,
    const ABS: bool,
    const CHROM: bool,
    const MIX: bool,
>(
    ctx: &TileContext,
    rect: &TileRect,
    pass: u32,
    s0: u32,
    n: u32,
) -> TileOutput {
    let start = Instant::now();
    let mut buffer = TileBuffer::for_pass(*rect, pass);
    let mut record = TileRecord::new(pass, rect);
    let mut lookups = vec![0u64; rect.pixel_count()];
    let mut total = PathStats::default();
    let aspect = ctx.width as f32 / ctx.height as f32;
    // One sampler for the tile, moved from pixel to pixel.
    let mut sampler = Sampler::for_pixel(ctx.sampler, 0, ctx.seed);
    for y in rect.y0..rect.y1 {
        for x in rect.x0..rect.x1 {
            let pixel = y * ctx.width + x;
            let before = total.media.tracking.lookups + total.media.emission_lookups;
            sampler.set_pixel(pixel);
            for s in s0..s0 + n {
                sampler.start(s);
                let jitter = sampler.get2d(DIM_JITTER);
                let film = Vec2::new(
                    (x as f32 + jitter.x) / ctx.width as f32,
                    (y as f32 + jitter.y) / ctx.height as f32,
                );
                let l = radiance::<SURF, HET, HOM, EMIT, ABS, CHROM, MIX>(
                    ctx.rs,
                    &ctx.cfg,
                    &ctx.limits,
                    film,
                    aspect,
                    &mut sampler,
                    &mut total,
                );
                buffer.add_sample(x, y, l.to_array());
            }
            let i = ((y - rect.y0) * rect.width() + (x - rect.x0)) as usize;
            lookups[i] = total.media.tracking.lookups + total.media.emission_lookups - before;
        }
    }
    let t = &total.media.tracking;
    record.counters.samples = rect.pixel_count() as u64 * n as u64;
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

macro_rules! pick_next {
    ($name:ident, $next:ident, $idx:expr, [$($c:ident),*]) => {
        fn $name<$(const $c: bool),*>(f: &[bool; 6]) -> TileFn {
            if f[$idx] { $next::<$($c,)* true>(f) } else { $next::<$($c,)* false>(f) }
        }
    };
}
pick_next!(pick0, pick1, 0, []);
pick_next!(pick1, pick2, 1, [A]);
pick_next!(pick2, pick3, 2, [A, B]);
pick_next!(pick3, pick4, 3, [A, B, C]);
pick_next!(pick4, pick5, 4, [A, B, C, D]);

fn pick5<const A: bool, const B: bool, const C: bool, const D: bool, const E: bool>(
    f: &[bool; 6],
) -> TileFn {
    if f[5] {
        render_tile::<A, B, C, D, E, true, false>
    } else {
        render_tile::<A, B, C, D, E, false, false>
    }
}

/// The tile renderer compiled for exactly `features` (the generic one when all are on). The
/// mixture of overlapping media (`MIX`) is compiled into the generic variant only: a scene
/// with `features.overlapping` runs the generic code (`backend::cpu` then reports every
/// feature on), every other scene a variant without the mixture, so the 64 specialised
/// variants do not double.
pub fn specialised(features: FeatureFlags) -> TileFn {
    if features.overlapping {
        return render_tile::<true, true, true, true, true, true, true>;
    }
    pick0(&features.as_array())
}
