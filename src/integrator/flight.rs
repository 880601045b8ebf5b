//! One path segment's free flight through every medium it crosses: the homogeneous medium the
//! path is in, the VDB media along the ray, and their mixture or nesting where they overlap.
//! The CPU half of `Stage::SampleMedium`.
use glam::Vec3;

use super::features::Features;
use super::homogeneous::sample_homogeneous;
use super::media::{sample_vdb_in_turn, Flight, MediumEvent};
use super::mixture::{sample_mixture, RayMedia, VdbSpan};
use super::nested::{nested_applies, sample_nested};
use crate::math::Ray;
use crate::render::prepare::RenderScene;
use crate::volume::phases::Phase;

/// VDB media along one ray kept without allocating. Small on purpose: the spans are built,
/// zeroed and moved for every flight and shadow ray (with 16 that was 256 bytes a time, a few
/// percent of a sample), and scenes rarely cross more than a few media on one ray.
const INLINE_SPANS: usize = 4;

/// The VDB media along a ray: `(medium, t_min, t_max)` sorted by `t_min`; up to
/// [`INLINE_SPANS`] inline (no allocation on the hot path), any number on the heap. (The size
/// difference is the point: the inline variant lives on the stack of one flight.)
#[allow(clippy::large_enum_variant)]
pub(super) enum Spans<'a> {
    Inline([VdbSpan<'a>; INLINE_SPANS], usize),
    Heap(Vec<VdbSpan<'a>>),
}

impl<'a> std::ops::Deref for Spans<'a> {
    type Target = [VdbSpan<'a>];
    fn deref(&self) -> &Self::Target {
        match self {
            Spans::Inline(a, n) => &a[..*n],
            Spans::Heap(v) => v,
        }
    }
}

/// The intervals of every VDB medium whose bounds `ray` crosses within `[t0, t1]`, with the
/// medium, sorted by start (disjoint unless media overlap).
pub(super) fn vdb_intervals<'a>(rs: &'a RenderScene, ray: &Ray, t0: f32, t1: f32) -> Spans<'a> {
    // `1 / d` once for every medium (`intersect_inv` is `intersect` bit for bit).
    let inv_d = [0, 1, 2].map(|a| 1.0 / ray.d[a]);
    let mut hits = rs.vdb.iter().filter_map(|m| {
        let (a, b) = m.world_bounds.intersect_inv(ray.o, inv_d, t0, t1)?;
        // NaN ends are skipped too.
        (b > a).then_some((m, a, b))
    });
    // Most rays of a scene miss its media (nine in ten of the smoke tank's): an empty `Vec`
    // costs nothing to build or return, where filling the inline slots cost a fifth of the
    // call (callgrind).
    let Some(first) = hits.next() else {
        return Spans::Heap(Vec::new());
    };
    let mut out = Spans::Inline([first; INLINE_SPANS], 1);
    for span in hits {
        match &mut out {
            Spans::Inline(arr, n) if *n < arr.len() => {
                arr[*n] = span;
                *n += 1;
            }
            Spans::Inline(arr, n) => {
                let mut v = arr[..*n].to_vec();
                v.push(span);
                out = Spans::Heap(v);
            }
            Spans::Heap(v) => v.push(span),
        }
    }
    match &mut out {
        Spans::Inline(arr, n) if *n > 1 => arr[..*n].sort_unstable_by(|x, y| x.1.total_cmp(&y.1)),
        Spans::Inline(..) => {}
        Spans::Heap(v) => v.sort_unstable_by(|x, y| x.1.total_cmp(&y.1)),
    }
    out
}

/// Whether sorted intervals overlap one another.
fn intervals_overlap(iv: &[VdbSpan]) -> bool {
    iv.windows(2).any(|w| w[1].1 < w[0].2)
}

/// The free flight along `ray` over `[t0, t1]` through whatever media lie there: the
/// homogeneous medium the path is in, the VDB media the ray crosses, or, with `F::MIX` (a scene
/// with overlapping or nested media), VDB media side by side inside the homogeneous medium by
/// its closed-form flight cutting theirs short (`nested`), else their sum where they overlap
/// (`mixture`).
#[inline]
pub(super) fn media_flight<F: Features>(
    rs: &RenderScene,
    ray: &Ray,
    t0: f32,
    t1: f32,
    medium: Option<u32>,
    beta: Vec3,
    f: Flight,
) -> (MediumEvent, Phase) {
    let cfg = f.cfg;
    // The VDB spans, found once: the mixture test's are the flights' in turn below.
    let mut spans = None;
    if F::MIX && F::HET {
        let iv = spans.insert(vdb_intervals(rs, ray, t0, t1));
        let n = iv.len();
        let hom = medium
            .filter(|_| F::HOM)
            .map(|h| &rs.homogeneous[h as usize]);
        let overlap = intervals_overlap(iv);
        if (hom.is_some() && n > 0) || overlap {
            // VDB media side by side inside the homogeneous one: its closed-form flight cuts
            // theirs short (`nested`); overlapping VDB media need the merged sum.
            let media = RayMedia {
                vdb: iv,
                hom,
                ray,
                t0,
                t1,
            };
            if hom.is_some_and(|h| !overlap && nested_applies(iv, h, cfg.absorption)) {
                return sample_nested::<F>(media, beta, f);
            }
            return sample_mixture::<F>(media, beta, f);
        }
    }
    if F::HOM {
        if let Some(h) = medium {
            let h = &rs.homogeneous[h as usize];
            let ev = match sample_homogeneous::<F>(h, t1 - t0, cfg.absorption, f.rng) {
                MediumEvent::Scatter { t, weight } => MediumEvent::Scatter { t: t0 + t, weight },
                other => other,
            };
            return (ev, h.phase);
        }
    }
    if F::HET {
        let spans = spans.unwrap_or_else(|| vdb_intervals(rs, ray, t0, t1));
        return sample_vdb_in_turn::<F>(spans.iter().copied(), t1, ray, beta, f);
    }
    (MediumEvent::Escape { weight: Vec3::ONE }, Phase::hg(0.0))
}
