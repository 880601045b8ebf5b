//! Free flights through participating media on the CPU: heterogeneous VDB media (tracked with
//! the estimators of `volume::tracking` over majorant segments) and homogeneous media inside
//! closed meshes (sampled in closed form: `integrator::homogeneous`).
//!
//! One function per job: [`sample_vdb`] (free flight in a VDB medium), [`transmittance_vdb`]
//! (shadow rays); homogeneous media: `integrator::homogeneous`. The features type `F`
//! selects specialised code: `F::EMIT` (does any medium emit), `F::ABS` (does any medium
//! absorb), `F::CHROM` (is any extinction chromatic); a `false` removes the corresponding work
//! at compile time.
use glam::Vec3;

use super::features::{Features, NoFeatures};
pub use super::views::EmissionMis;
use super::views::{GreyView, RgbView};
use crate::math::Ray;
use crate::render::light_groups::{MAX_LIGHT_GROUPS, NO_GROUP};
use crate::render::media::{MediaStats, TrackingConfig, VdbMedium};
use crate::render::settings::{Absorption, Estimator, MajorantMode};
use crate::sampling::Rng;
use crate::volume::phases::Phase;
use crate::volume::tracking::{
    self, Decomposition, Delta, Event, Medium, Ratio, ResidualRatio, Spectral,
    SpectralProbabilities, TrackingStats, WeightedDecomposition, WeightedDelta,
};
use crate::volume::{AdaptiveMajorantIterator, DdaMajorantIterator};

/// A walk used through a mutable reference, with its `next` always inlined. The standard
/// `impl Iterator for &mut I` is only `#[inline]`, and in `sample_grey`, which holds a free-flight
/// loop per estimator and walk type, it stayed a call per segment (6.5 % of a cloud render).
struct WalkRef<'w, I>(&'w mut I);

impl<I: Iterator> Iterator for WalkRef<'_, I> {
    type Item = I::Item;

    #[inline(always)]
    fn next(&mut self) -> Option<I::Item> {
        self.0.next()
    }
}

/// Evaluates `$body` with `$segs` bound to the concrete walk that gives `$mode`'s segments
/// over `$m`'s majorants ([`crate::render::media::WalkPlan::of`]; in `$ray_i`'s index space over
/// `[$t0, $t1]`), through a [`WalkRef`]. The tracking loop is then instantiated once per walk
/// type and the walk's step inlines into it: through the [`Segments`] enum it was a call per
/// segment. The walk is used through a reference because its state is a few hundred bytes
/// that moving down the estimator's calls would copy.
macro_rules! with_walk {
    ($m:expr, $ray_i:expr, $t0:expr, $t1:expr, $mode:expr, |$segs:ident| $body:expr) => {{
        let m: &VdbMedium = $m;
        match m.walk($mode).free {
            MajorantMode::Adaptive => {
                let mut walk =
                    AdaptiveMajorantIterator::new(&m.adaptive, $ray_i, $t0, $t1, m.sigma_t_bound);
                let $segs = WalkRef(&mut walk);
                $body
            }
            mode => {
                let bounds = m.bounds();
                // The culled walk is the global one; the view culls its collisions.
                let mut walk = if mode == MajorantMode::Global || mode == MajorantMode::Culled {
                    DdaMajorantIterator::global(bounds, $ray_i, $t0, $t1, m.sigma_t_bound)
                } else {
                    DdaMajorantIterator::new(bounds, $ray_i, $t0, $t1, m.sigma_t_bound)
                };
                let $segs = WalkRef(&mut walk);
                $body
            }
        }
    }};
}

/// The majorant segments of `ray` (world) over `[t0, t1]` in `m`'s index space, for the
/// mixture of overlapping media (`integrator::mixture`). Its merged stream of several media's
/// segments has no single grid to cull by, so the culled walk is walked there as the
/// per-leaf DDA, whose collisions it samples (the GPU's `mixture.wgsl` does the same).
#[inline]
pub(super) fn segments<'a>(
    m: &'a VdbMedium,
    ray_i: &Ray,
    t0: f32,
    t1: f32,
    mode: MajorantMode,
) -> Segments<'a> {
    let bounds = m.bounds();
    match m.walk(mode).merged {
        MajorantMode::Leaf | MajorantMode::Culled => Segments::Dda(DdaMajorantIterator::new(
            bounds,
            ray_i,
            t0,
            t1,
            m.sigma_t_bound,
        )),
        MajorantMode::Global => Segments::Dda(DdaMajorantIterator::global(
            bounds,
            ray_i,
            t0,
            t1,
            m.sigma_t_bound,
        )),
        MajorantMode::Adaptive => Segments::Adaptive(AdaptiveMajorantIterator::new(
            &m.adaptive,
            ray_i,
            t0,
            t1,
            m.sigma_t_bound,
        )),
    }
}

/// The segment stream of one of the majorant modes (one branch per segment, not per
/// collision).
#[derive(Clone)]
pub enum Segments<'a> {
    Dda(DdaMajorantIterator<'a>),
    Adaptive(AdaptiveMajorantIterator<'a>),
    /// One segment of constant bounds: a homogeneous medium added to VDB media
    /// (`integrator::mixture`).
    Constant(Option<crate::volume::MajorantSegment>),
}

impl Iterator for Segments<'_> {
    type Item = crate::volume::MajorantSegment;

    // Inlined into the mixture's merge: a call per segment (and the segment returned through
    // memory) cost as much as the DDA step itself. The match is predictable within a flight.
    #[inline(always)]
    fn next(&mut self) -> Option<Self::Item> {
        match self {
            Segments::Dda(it) => it.next(),
            Segments::Adaptive(it) => it.next(),
            Segments::Constant(seg) => seg.take(),
        }
    }
}

/// What a free flight through a medium ended with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MediumEvent {
    /// Real scattering at `t`; multiply the throughput by `weight`.
    Scatter { t: f32, weight: Vec3 },
    /// Real absorption: the path ends.
    Absorb,
    /// No real collision before the end of the interval; multiply the throughput by `weight`.
    Escape { weight: Vec3 },
}

pub(super) fn from_grey(e: Event<f32>, albedo: Vec3) -> MediumEvent {
    match e {
        Event::Scatter { t, weight } => MediumEvent::Scatter {
            t,
            weight: albedo * weight,
        },
        Event::Absorb { .. } => MediumEvent::Absorb,
        Event::Escape { weight } => MediumEvent::Escape {
            weight: Vec3::splat(weight),
        },
    }
}

/// What the free flights of one path segment share besides the ray: the tracking settings, the
/// path's random numbers, the media statistics, and `l`, the radiance that emission met on the
/// way is added to (weighted by each flight's `beta`). Passed down through the media in turn
/// ([`sample_vdb_in_turn`]), their mixture (`integrator::mixture`) and the nested flights
/// (`integrator::nested`).
pub struct Flight<'f> {
    pub cfg: &'f TrackingConfig,
    pub rng: &'f mut Rng,
    pub stats: &'f mut MediaStats,
    pub l: Emitted<'f>,
}

/// Where the emission a flight meets goes: the path's radiance and, where light groups are
/// kept, the emitting medium's group; and, where emitting media are sampled as lights, what
/// its MIS weight needs.
pub struct Emitted<'f> {
    pub l: &'f mut Vec3,
    pub groups: Option<&'f mut [Vec3; MAX_LIGHT_GROUPS]>,
    pub mis: Option<EmissionMis<'f>>,
}

impl Emitted<'_> {
    /// Adds emission `e` (already weighted by `beta`) of a medium in light group `group`.
    #[inline(always)]
    pub fn add(&mut self, group: u8, e: Vec3) {
        *self.l += e;
        if let Some(g) = self.groups.as_deref_mut() {
            if group != NO_GROUP {
                g[group as usize] += e;
            }
        }
    }

    #[inline]
    fn reborrow(&mut self) -> Emitted<'_> {
        Emitted {
            l: &mut *self.l,
            groups: self.groups.as_deref_mut(),
            mis: self.mis,
        }
    }
}

impl Flight<'_> {
    /// The same flight context for one call that returns before this one is used again.
    #[inline]
    pub fn reborrow(&mut self) -> Flight<'_> {
        Flight {
            cfg: self.cfg,
            rng: &mut *self.rng,
            stats: &mut *self.stats,
            l: self.l.reborrow(),
        }
    }
}

/// Free flight through VDB medium `m` along world `ray` over `[t0, t1]`, with the configured
/// estimator. Emission met on the way is added to `f.l` (already weighted by `beta`).
#[inline]
pub fn sample_vdb<F: Features>(
    m: &VdbMedium,
    ray: &Ray,
    t0: f32,
    t1: f32,
    beta: Vec3,
    f: Flight,
) -> MediumEvent {
    let cfg = f.cfg;
    if F::CHROM && (!m.grey || cfg.force_spectral) {
        let Flight {
            rng, stats, mut l, ..
        } = f;
        let mut view = RgbView::<F>::new(m, ray, cfg.absorption, cfg.majorant, cfg.time, beta);
        view.mis = l.mis;
        let e = with_walk!(m, &view.ray_i, t0, t1, cfg.majorant, |segs| {
            let spectral = Spectral {
                b: cfg.b(),
                mode: SpectralProbabilities::HistoryAwareMax,
                beta,
            };
            tracking::sample_distance(&spectral, segs, t1, &view, rng, &mut stats.tracking)
        });
        l.add(m.light_group, view.emitted.get());
        stats.emission_lookups += view.emission_lookups.get();
        return match e {
            Event::Scatter { t, weight } => MediumEvent::Scatter {
                t,
                weight: weight * view.scatter_albedo,
            },
            Event::Absorb { .. } => MediumEvent::Absorb,
            Event::Escape { weight } => MediumEvent::Escape { weight },
        };
    }
    // With absorption as a weight the grey view has no absorption coefficient at all, so the
    // ABS = false view compiles it out of the lookups.
    match (F::ABS, cfg.absorption) {
        (true, Absorption::Event) => {
            let view = GreyView::<F, true>::new(m, ray, cfg, beta).with_mis(f.l.mis);
            sample_grey(view, t0, t1, f)
        }
        _ => {
            let view = GreyView::<F, false>::new(m, ray, cfg, beta).with_mis(f.l.mis);
            sample_grey(view, t0, t1, f)
        }
    }
}

/// The grey free-flight estimator `cfg` selects (delta, weighted delta, decomposition or
/// weighted decomposition tracking) over `segs`, for one medium or a mixture.
#[inline]
pub(super) fn grey_free_flight<I, M>(
    cfg: &TrackingConfig,
    segs: I,
    t1: f32,
    medium: &M,
    rng: &mut Rng,
    st: &mut TrackingStats,
) -> Event<f32>
where
    I: IntoIterator<Item = crate::volume::MajorantSegment>,
    M: Medium,
{
    match cfg.estimator {
        Estimator::Delta => tracking::sample_distance(&Delta, segs, t1, medium, rng, st),
        Estimator::WeightedDelta => {
            let weighted = WeightedDelta { b: cfg.b };
            tracking::sample_distance(&weighted, segs, t1, medium, rng, st)
        }
        Estimator::Decomposition => {
            tracking::sample_distance(&Decomposition, segs, t1, medium, rng, st)
        }
        Estimator::WeightedDecomposition => {
            let weighted = WeightedDecomposition { b: cfg.b };
            tracking::sample_distance(&weighted, segs, t1, medium, rng, st)
        }
    }
}

/// [`sample_vdb`] over `[t0, t1]` through `view`, a grey view of the medium (`sigma_t` equal
/// in every channel).
fn sample_grey<F: Features, const ABS: bool>(
    view: GreyView<F, ABS>,
    t0: f32,
    t1: f32,
    f: Flight,
) -> MediumEvent {
    let Flight {
        cfg,
        rng,
        stats,
        mut l,
    } = f;
    let e = with_walk!(view.m, &view.ray_i, t0, t1, cfg.majorant, |segs| {
        grey_free_flight(cfg, segs, t1, &view, rng, &mut stats.tracking)
    });
    if F::EMIT {
        l.add(view.m.light_group, view.emitted.get());
        stats.emission_lookups += view.emission_lookups.get();
    }
    from_grey(e, view.scatter_albedo())
}

/// Free flights through VDB media one after another along world `ray`: `spans` sorted and
/// not overlapping, each medium over its span cut at `t_end`. The first scattering or
/// absorption ends it, with the phase function of its medium and the weights of the media
/// passed before it; else every flight escaped, and the escape weight is their product.
/// Emission met on the way is added to `f.l` (weighted by `beta` and the weights so far).
#[inline]
pub fn sample_vdb_in_turn<'a, F: Features>(
    spans: impl IntoIterator<Item = (&'a VdbMedium, f32, f32)>,
    t_end: f32,
    ray: &Ray,
    beta: Vec3,
    mut f: Flight,
) -> (MediumEvent, Phase) {
    let mut weight = Vec3::ONE;
    for (m, a, b) in spans {
        if !(a < t_end) {
            break;
        }
        let b = b.min(t_end);
        match sample_vdb::<F>(m, ray, a, b, beta * weight, f.reborrow()) {
            MediumEvent::Escape { weight: w } => weight *= w,
            MediumEvent::Scatter { t, weight: w } => {
                return (
                    MediumEvent::Scatter {
                        t,
                        weight: weight * w,
                    },
                    m.phase,
                )
            }
            MediumEvent::Absorb => return (MediumEvent::Absorb, m.phase),
        }
    }
    (MediumEvent::Escape { weight }, Phase::hg(0.0))
}

/// Transmittance of VDB medium `m` along world `ray` over `[t0, t1]`: ratio or residual ratio
/// tracking (Novak et al. 2014) for grey media, spectral tracking's estimator for chromatic ones.
#[inline]
pub fn transmittance_vdb<F: Features>(
    m: &VdbMedium,
    ray: &Ray,
    t0: f32,
    t1: f32,
    cfg: &TrackingConfig,
    rng: &mut Rng,
    stats: &mut MediaStats,
) -> Vec3 {
    let before = stats.tracking.lookups;
    let segments_before = stats.tracking.segments;
    let cfg = &TrackingConfig {
        majorant: m.walk(cfg.majorant).shadow,
        ..*cfg
    };
    let tr = if F::CHROM && (!m.grey || cfg.force_spectral) {
        // Only sigma_t matters to a transmittance estimate.
        let view = RgbView::<NoFeatures>::new(
            m,
            ray,
            Absorption::Event,
            cfg.majorant,
            cfg.time,
            Vec3::ONE,
        );
        with_walk!(m, &view.ray_i, t0, t1, cfg.majorant, |segs| {
            let spectral = Spectral {
                b: cfg.b(),
                mode: SpectralProbabilities::HistoryAwareMax,
                beta: Vec3::ONE,
            };
            tracking::transmittance(&spectral, segs, t1, &view, rng, &mut stats.tracking)
        })
    } else {
        let view = GreyView::<NoFeatures, true>::new(m, ray, cfg, Vec3::ONE);
        let residual = cfg.residual_shadow();
        let t = with_walk!(m, &view.ray_i, t0, t1, cfg.majorant, |segs| {
            let st = &mut stats.tracking;
            if residual {
                tracking::transmittance(&ResidualRatio { b: cfg.b() }, segs, t1, &view, rng, st)
            } else {
                tracking::transmittance(&Ratio { b: cfg.b() }, segs, t1, &view, rng, st)
            }
        });
        Vec3::splat(t)
    };
    stats.shadow_lookups += stats.tracking.lookups - before;
    stats.shadow_segments += stats.tracking.segments - segments_before;
    tr
}
