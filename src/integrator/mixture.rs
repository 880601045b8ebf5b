//! Free flight through overlapping media: several VDB media whose supports overlap along a
//! ray, and the homogeneous medium around or inside them (the top of the path's
//! [`MediumStack`](crate::render::stack::MediumStack)).
//!
//! Extinction, scattering, absorption and emission ADD where media overlap (the radiative
//! transfer equation is linear in them; Cycles, Mitsuba 3 and pbrt-v4's `MediumInterface`
//! users all sum coefficients). The free flight therefore tracks ONE medium whose coefficients
//! are the sums:
//!
//! ```text
//! sigma_a(x) = sum_k sigma_a,k(x)      sigma_s(x) = sum_k sigma_s,k(x)
//! Le(x)      = sum_k Le,k(x)           (emission grid and blackbody of every medium)
//! sigma_maj  = sum_k sigma_maj,k       (per piece of ray: volume::merge::MergedSegments)
//! sigma_c    = sum_k sigma_min,k       (decomposition's control: the summed minorants)
//! ```
//!
//! so every estimator of `volume::tracking` (delta, weighted delta, decomposition, weighted
//! decomposition, spectral) runs unchanged and stays unbiased: each only assumes a medium
//! with coefficients at a point and segments whose bounds hold, and the sums are such a
//! medium. A homogeneous medium is one more part with one constant segment whose minorant is
//! its extinction, so decomposition takes it entirely in closed form (no lookups).
//!
//! The choice at a tentative collision: EVALUATE EVERY MEDIUM AND SUM, rather than picking
//! one medium in proportion to its share of the majorant. Picking would be unbiased too, but
//! its null-collision probability is `1 - sigma_t,k / sigma_maj,k` for the PICKED medium, so
//! where one medium is dense and another thin it rejects many collisions the sum would accept;
//! worse, it has no single control for decomposition tracking and no sum to weigh emission
//! by. Summing costs one lookup per overlapping medium per collision, which is what the
//! summed majorant pays for anyway.
//!
//! A real scattering event of the sum then picks WHICH medium scattered, to use its phase
//! function and RGB albedo: the standard mixture `sum_k sigma_s,k(x) p_k / sigma_s(x)`,
//! sampled by choosing `k` with probability `q_k` proportional to its scattering coefficient
//! at `x` (one extra uniform and one lookup per medium, at scattering events only) and
//! weighting by `sigma_s,k / (q_k sigma_s(x))`, which is medium `k`'s own albedo factor for
//! grey media and the per-channel correction for RGB ones. Next-event estimation and the next
//! direction both use the chosen medium's phase function: a one-sample estimator of the
//! mixture, unbiased with MIS inside the chosen lobe. Control (lookup-free) scattering events
//! also pick by lookup at `x`: the event's position is distributed as the sum's, whatever
//! component produced it.
//!
//! The control's split into absorption and scattering: each medium's control has its own
//! albedo `alpha_k`; the merged stream only knows `sigma_c = sum_k c_k`, so the control used is
//! `(sigma_a, sigma_s) = ((1 - alpha_max) sigma_c, alpha_min sigma_c)`, which is below
//! `sum_k ((1 - alpha_k) c_k, alpha_k c_k)` component by component, as analog decomposition
//! requires (exact when the albedos agree, e.g. absorption as a weight: every albedo 1).
//!
//! VDB media side by side inside a homogeneous medium need none of it either where
//! `integrator::nested` applies: the homogeneous collision, drawn in closed form, cuts each VDB
//! medium's own flight short. The sum here serves overlapping VDB media and the cases nested
//! flights leave (chromatic extinction around emitting media, absorption events).
//!
//! Shadow rays need none of this: the transmittance of a sum is the product of
//! transmittances, so `next_event::trace_shadow` multiplies independent per-medium estimates
//! (unbiased, and cheaper than tracking the sum: medium `k` is looked up at its own rate).
use std::cell::Cell;
use std::ops::AddAssign;

use glam::Vec3;

use super::features::Features;
use super::media::{from_grey, segments, Flight, MediumEvent, Segments};
use super::views::{GreyView, RgbView};
use crate::math::Ray;
use crate::render::media::{HomogeneousMedium, VdbMedium};
use crate::render::settings::Absorption;
use crate::sampling::{sample_discrete, DiscreteSample};
use crate::volume::merge::MergedSegments;
use crate::volume::phases::Phase;
use crate::volume::tracking::{
    self, Coeffs, CoeffsRgb, ControlExtinction, Event, Medium, MediumRgb, Spectral,
    SpectralProbabilities,
};
use crate::volume::MajorantSegment;

/// The VDB media along one ray: each with the part `[a, b]` of the ray it may touch.
pub type VdbSpan<'a> = (&'a VdbMedium, f32, f32);

/// The media one stretch `[t0, t1]` of world `ray` crosses: VDB media, each over its span,
/// and the homogeneous medium around them, if any, over all of it.
#[derive(Clone, Copy)]
pub struct RayMedia<'a> {
    pub vdb: &'a [VdbSpan<'a>],
    pub hom: Option<&'a HomogeneousMedium>,
    pub ray: &'a Ray,
    pub t0: f32,
    pub t1: f32,
}

/// Free flight through the sum of `media`. Returns the event and, for a scattering event, the
/// phase function of the medium that scattered. Emission met on the way is added to `l`
/// (already weighted by `beta`).
pub fn sample_mixture<F: Features>(media: RayMedia, beta: Vec3, f: Flight) -> (MediumEvent, Phase) {
    let (vdb, hom) = (media.vdb, media.hom);
    let cfg = f.cfg;
    let chromatic_hom = hom.is_some_and(|h| {
        let s = h.sigma_t();
        s.x != s.y || s.y != s.z
    });
    if F::CHROM && (cfg.force_spectral || chromatic_hom || vdb.iter().any(|v| !v.0.grey)) {
        return sample_rgb::<F>(media, beta, f);
    }
    match (F::ABS, cfg.absorption) {
        (true, Absorption::Event) => sample_grey::<F, true>(media, beta, f),
        _ => sample_grey::<F, false>(media, beta, f),
    }
}

/// One constant segment: a homogeneous medium's bounds over `[t0, t1]`.
fn constant(t0: f32, t1: f32, sigma_maj: f32, sigma_min: f32) -> Segments<'static> {
    Segments::Constant(Some(MajorantSegment {
        t_min: t0,
        t_max: t1,
        sigma_maj,
        sigma_min,
    }))
}

/// The coefficients of the sum, grey or RGB: `sum` (the homogeneous part's, or zero) plus
/// each view's `coeffs`, in order. Adds the lookups beyond the one per `coeffs` call the
/// trackers count to `extra_lookups`.
#[inline(always)]
fn sum_parts<C: AddAssign, V>(
    mut sum: C,
    views: &[V],
    coeffs: impl Fn(&V) -> C,
    extra_lookups: &Cell<u64>,
) -> C {
    for v in views {
        sum += coeffs(v);
    }
    let n = views.len() as u64;
    extra_lookups.set(extra_lookups.get() + n.saturating_sub(1));
    sum
}

/// A homogeneous medium as the grey trackers see it (as `GreyView` sees a VDB medium).
struct HomGrey {
    sigma_a: f32,
    sigma_s: f32,
    /// RGB factor of a scattering event: `sigma_s / grey sigma_s`.
    albedo: Vec3,
    phase: Phase,
}

impl HomGrey {
    fn new(h: &HomogeneousMedium, absorption: Absorption, abs: bool) -> HomGrey {
        let sigma_t = h.sigma_t().max_element();
        let sigma_s = match absorption {
            Absorption::Weight => sigma_t,
            Absorption::Event => h.sigma_s.element_sum() / 3.0,
        };
        HomGrey {
            sigma_a: if abs {
                (sigma_t - sigma_s).max(0.0)
            } else {
                0.0
            },
            sigma_s,
            albedo: if sigma_s > 0.0 {
                h.sigma_s / sigma_s
            } else {
                Vec3::ZERO
            },
            phase: h.phase,
        }
    }
}

/// The sum of grey views (see the module doc).
struct GreyMix<'a, F: Features, const ABS: bool> {
    views: Vec<GreyView<'a, F, ABS>>,
    hom: Option<HomGrey>,
    control: ControlExtinction,
    /// Smallest and largest control albedo of the parts.
    alpha_min: f32,
    alpha_max: f32,
    /// Lookups beyond the one per `coeffs` call the trackers count.
    extra_lookups: Cell<u64>,
}

impl<F: Features, const ABS: bool> Medium for GreyMix<'_, F, ABS> {
    #[inline]
    fn coeffs(&self, t: f32) -> Coeffs {
        let hom = self.hom.as_ref().map_or(Coeffs::ZERO, |h| Coeffs {
            sigma_a: h.sigma_a,
            sigma_s: h.sigma_s,
        });
        sum_parts(hom, &self.views, |v| v.coeffs(t), &self.extra_lookups)
    }

    #[inline]
    fn control(&self, seg: &MajorantSegment) -> Coeffs {
        let sigma_c = self.control.sigma_c(seg);
        Coeffs {
            sigma_a: (1.0 - self.alpha_max) * sigma_c,
            sigma_s: self.alpha_min * sigma_c,
        }
    }

    #[inline]
    fn on_collision(&self, t: f32, sigma_maj: f32, w: f32) {
        if F::EMIT {
            for v in &self.views {
                v.on_collision(t, sigma_maj, w);
            }
        }
    }
}

fn sample_grey<F: Features, const ABS: bool>(
    media: RayMedia,
    beta: Vec3,
    f: Flight,
) -> (MediumEvent, Phase) {
    let (vdb, ray, t0, t1) = (media.vdb, media.ray, media.t0, media.t1);
    let Flight {
        cfg,
        rng,
        stats,
        mut l,
    } = f;
    let views: Vec<GreyView<F, ABS>> = media
        .vdb
        .iter()
        .map(|(m, _, _)| GreyView::new(m, ray, cfg, beta).with_mis(l.mis))
        .collect();
    let hom = media.hom.map(|h| HomGrey::new(h, cfg.absorption, ABS));
    let albedos = views.iter().map(|v| v.control_albedo).chain(
        hom.as_ref()
            .map(|h| h.sigma_s / (h.sigma_a + h.sigma_s).max(f32::MIN_POSITIVE)),
    );
    let (alpha_min, alpha_max) =
        albedos.fold((1.0f32, 0.0f32), |(lo, hi), a| (lo.min(a), hi.max(a)));
    let mut streams: Vec<Segments> = views
        .iter()
        .zip(vdb)
        .map(|(v, &(m, a, b))| segments(m, &v.ray_i, a, b, cfg.majorant))
        .collect();
    if let Some(h) = &hom {
        let sigma_t = h.sigma_a + h.sigma_s;
        streams.push(constant(t0, t1, sigma_t, sigma_t));
    }
    let mix = GreyMix {
        views,
        hom,
        control: cfg.control(),
        alpha_min,
        alpha_max,
        extra_lookups: Cell::new(0),
    };
    let segs = MergedSegments::new(streams);
    let e = super::media::grey_free_flight(cfg, segs, t1, &mix, rng, &mut stats.tracking);
    if F::EMIT {
        for v in &mix.views {
            l.add(v.m.light_group, v.emitted.get());
            stats.emission_lookups += v.emission_lookups.get();
        }
    }
    let mut phase = Phase::hg(0.0);
    let e = match e {
        Event::Scatter { t, weight } => {
            // Which medium scattered: in proportion to its grey sigma_s at t.
            let mut w: Vec<f32> = mix.views.iter().map(|v| v.coeffs(t).sigma_s).collect();
            stats.tracking.lookups += mix.views.len() as u64;
            w.extend(mix.hom.as_ref().map(|h| h.sigma_s));
            match sample_discrete(&w, rng.uniform_f32()) {
                Some(d) if d.index < mix.views.len() => {
                    phase = mix.views[d.index].m.phase;
                    from_grey(
                        Event::Scatter { t, weight },
                        mix.views[d.index].scatter_albedo(),
                    )
                }
                Some(_) => {
                    let h = mix
                        .hom
                        .as_ref()
                        .expect("the last part is the homogeneous one");
                    phase = h.phase;
                    from_grey(Event::Scatter { t, weight }, h.albedo)
                }
                // No medium scatters at t (only a majorant violation gets here): the event
                // carries no light.
                None => MediumEvent::Absorb,
            }
        }
        other => from_grey(other, Vec3::ZERO),
    };
    stats.tracking.lookups += mix.extra_lookups.get();
    (e, phase)
}

/// A homogeneous medium as spectral tracking sees it (as `RgbView` sees a VDB medium).
struct HomRgb {
    /// The tracker's coefficients: the medium's, or `(0, sigma_t)` with absorption as a weight.
    sigma_a: Vec3,
    sigma_s: Vec3,
    h: HomogeneousMedium,
}

/// The sum of RGB views (see the module doc).
struct RgbMix<'a, F: Features> {
    views: Vec<RgbView<'a, F>>,
    hom: Option<HomRgb>,
    extra_lookups: Cell<u64>,
}

impl<F: Features> MediumRgb for RgbMix<'_, F> {
    #[inline]
    fn coeffs(&self, t: f32) -> CoeffsRgb {
        let hom = self.hom.as_ref().map_or(CoeffsRgb::default(), |h| {
            CoeffsRgb::new(h.sigma_a, h.sigma_s)
        });
        sum_parts(hom, &self.views, |v| v.coeffs(t), &self.extra_lookups)
    }

    #[inline]
    fn on_collision(&self, t: f32, sigma_maj: f32, w: Vec3) {
        if F::EMIT {
            for v in &self.views {
                v.on_collision(t, sigma_maj, w);
            }
        }
    }
}

fn sample_rgb<F: Features>(media: RayMedia, beta: Vec3, f: Flight) -> (MediumEvent, Phase) {
    let (vdb, ray, t0, t1) = (media.vdb, media.ray, media.t0, media.t1);
    let Flight {
        cfg,
        rng,
        stats,
        mut l,
    } = f;
    let views: Vec<RgbView<F>> = media
        .vdb
        .iter()
        .map(|(m, _, _)| {
            let mut view = RgbView::new(m, ray, cfg.absorption, cfg.majorant, cfg.time, beta);
            view.mis = l.mis;
            view
        })
        .collect();
    let hom = media.hom.map(|h| {
        let (sigma_a, sigma_s) = match cfg.absorption {
            Absorption::Event => (h.sigma_a, h.sigma_s),
            Absorption::Weight => (Vec3::ZERO, h.sigma_t()),
        };
        HomRgb {
            sigma_a,
            sigma_s,
            h: *h,
        }
    });
    let mut streams: Vec<Segments> = views
        .iter()
        .zip(vdb)
        .map(|(v, &(m, a, b))| segments(m, &v.ray_i, a, b, cfg.majorant))
        .collect();
    if let Some(h) = &hom {
        let sigma_t = h.sigma_a + h.sigma_s;
        streams.push(constant(
            t0,
            t1,
            sigma_t.max_element(),
            sigma_t.min_element(),
        ));
    }
    let mix = RgbMix {
        views,
        hom,
        extra_lookups: Cell::new(0),
    };
    let spectral = Spectral {
        b: cfg.b(),
        mode: SpectralProbabilities::HistoryAwareMax,
        beta,
    };
    let e = tracking::sample_distance(
        &spectral,
        MergedSegments::new(streams),
        t1,
        &mix,
        rng,
        &mut stats.tracking,
    );
    if F::EMIT {
        for v in &mix.views {
            l.add(v.m.light_group, v.emitted.get());
            stats.emission_lookups += v.emission_lookups.get();
        }
    }
    let mut phase = Phase::hg(0.0);
    let e = match e {
        Event::Scatter { t, weight } => {
            // Per part at t: the true sigma_s (RGB) and the tracker's sigma_s (the same, or
            // sigma_t with absorption as a weight).
            let mut s_true: Vec<Vec3> = Vec::with_capacity(mix.views.len() + 1);
            let mut s_view = Vec3::ZERO;
            for v in &mix.views {
                let d = v.density(t);
                s_true.push(v.m.sigma_s * d);
                s_view += v.sigma_s * d;
            }
            stats.tracking.lookups += mix.views.len() as u64;
            if let Some(h) = &mix.hom {
                s_true.push(h.h.sigma_s);
                s_view += h.sigma_s;
            }
            let q: Vec<f32> = s_true.iter().map(|s| s.element_sum()).collect();
            match sample_discrete(&q, rng.uniform_f32()) {
                Some(DiscreteSample {
                    index: k, pmf: q_k, ..
                }) => {
                    phase = if k < mix.views.len() {
                        mix.views[k].m.phase
                    } else {
                        mix.hom.as_ref().expect("the last part").h.phase
                    };
                    let den = s_view * q_k;
                    let f = Vec3::select(den.cmpgt(Vec3::ZERO), s_true[k] / den, Vec3::ZERO);
                    MediumEvent::Scatter {
                        t,
                        weight: weight * f,
                    }
                }
                None => MediumEvent::Absorb,
            }
        }
        Event::Absorb { .. } => MediumEvent::Absorb,
        Event::Escape { weight } => MediumEvent::Escape { weight },
    };
    stats.tracking.lookups += mix.extra_lookups.get();
    (e, phase)
}
