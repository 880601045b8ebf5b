//! The flight every estimator shares around its collision rule: the walk over majorant
//! segments with its culling stages ([`sample_free_flight`]), the emission hook of distance
//! sampling, the counters, the weight's update and its Russian roulette, and the event that
//! ends the flight. An estimator writes only its majorant ([`Walk`]) and a rule that turns one
//! tentative collision into an [`Outcome`].
use super::{
    roulette, sample_free_flight, voxel_stage, Collision, ControlDepthWalk, Event, Medium,
    MediumRgb, TrackingStats, ROULETTE_THRESHOLD,
};
use crate::sampling::Rng;
use crate::volume::MajorantSegment;
use glam::Vec3;
use std::ops::MulAssign;

/// Which real event a collision is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Real {
    Absorb,
    Scatter,
}

/// What an estimator's collision rule decided at one tentative collision. `factor` multiplies
/// the weight (`None`: the weight is unchanged and not recorded, as in the analog trackers).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Outcome<W> {
    /// A null collision: counted, the weight takes `factor`, and the walk goes on unless the
    /// estimator's roulette then ends it.
    Null(Option<W>),
    /// A real collision decided from a lookup: counted, the weight takes `factor`, and the
    /// walk ends (a transmittance estimate is then 0).
    Real(Real, Option<W>),
    /// A collision with the lookup-free control component: counted, the walk ends.
    Control(Real),
    /// Nothing counted, the walk goes on (rounding at the top of an event CDF).
    Skip,
    /// Nothing counted, the walk ends absorbed with weight 0 (no history left to carry).
    Dead,
}

/// The weight of an estimator: `f32` for grey media, `Vec3` for spectral tracking.
pub trait Weight: Copy + MulAssign {
    const ZERO: Self;
    const ONE: Self;
    /// Records the weight in [`TrackingStats::max_abs_weight`].
    fn note(self, stats: &mut TrackingStats);
    /// Unbiased Russian roulette at [`ROULETTE_THRESHOLD`]: the new weight, 0 when killed.
    fn roulette(self, rng: &mut Rng, stats: &mut TrackingStats) -> Self;
    fn is_zero(self) -> bool;
}

impl Weight for f32 {
    const ZERO: f32 = 0.0;
    const ONE: f32 = 1.0;
    #[inline]
    fn note(self, stats: &mut TrackingStats) {
        stats.note_weight(self);
    }
    #[inline]
    fn roulette(self, rng: &mut Rng, stats: &mut TrackingStats) -> f32 {
        roulette(self, ROULETTE_THRESHOLD, rng, stats)
    }
    #[inline]
    fn is_zero(self) -> bool {
        self == 0.0
    }
}

impl Weight for Vec3 {
    const ZERO: Vec3 = Vec3::ZERO;
    const ONE: Vec3 = Vec3::ONE;
    #[inline]
    fn note(self, stats: &mut TrackingStats) {
        stats.note_weight(self.abs().max_element());
    }
    /// Roulette on `max |w|`, rescaling every channel when the path survives.
    #[inline]
    fn roulette(self, rng: &mut Rng, stats: &mut TrackingStats) -> Vec3 {
        let m = self.abs().max_element();
        if m >= ROULETTE_THRESHOLD || m == 0.0 {
            return self;
        }
        if rng.uniform_f32() < m / ROULETTE_THRESHOLD {
            self * (ROULETTE_THRESHOLD / m)
        } else {
            stats.roulette_kills += 1;
            Vec3::ZERO
        }
    }
    #[inline]
    fn is_zero(self) -> bool {
        self == Vec3::ZERO
    }
}

/// What the shared flight asks of a medium besides its lookups (which the rules make): its
/// culling, its per-voxel stage and its emission hook, in the weight of its estimators.
pub trait FlightMedium {
    type Weight: Weight;
    /// [`Medium::cull_ratio`].
    fn cull_ratio(&self, t: f32) -> f32;
    /// [`voxel_stage`] with majorant scale `b` and `with_control`.
    fn voxel_ratio(
        &self,
        b: f32,
        with_control: bool,
        t: f32,
        seg: &MajorantSegment,
        bound: f32,
    ) -> f32;
    /// [`Medium::on_collision`].
    fn on_collision(&self, t: f32, sigma_maj: f32, w: Self::Weight);
}

/// A grey [`Medium`] as the shared flight sees it.
pub struct Grey<'m, M: ?Sized>(pub &'m M);

/// An RGB [`MediumRgb`] as the shared flight sees it: no per-voxel stage.
pub struct Rgb<'m, M: ?Sized>(pub &'m M);

impl<M: Medium + ?Sized> FlightMedium for Grey<'_, M> {
    type Weight = f32;
    #[inline]
    fn cull_ratio(&self, t: f32) -> f32 {
        self.0.cull_ratio(t)
    }
    #[inline]
    fn voxel_ratio(
        &self,
        b: f32,
        with_control: bool,
        t: f32,
        seg: &MajorantSegment,
        bound: f32,
    ) -> f32 {
        voxel_stage(self.0, b, with_control, t, seg, bound)
    }
    #[inline]
    fn on_collision(&self, t: f32, sigma_maj: f32, w: f32) {
        self.0.on_collision(t, sigma_maj, w)
    }
}

impl<M: MediumRgb + ?Sized> FlightMedium for Rgb<'_, M> {
    type Weight = Vec3;
    #[inline]
    fn cull_ratio(&self, t: f32) -> f32 {
        self.0.cull_ratio(t)
    }
    #[inline]
    fn voxel_ratio(&self, _: f32, _: bool, _: f32, _: &MajorantSegment, _: f32) -> f32 {
        1.0
    }
    #[inline]
    fn on_collision(&self, t: f32, sigma_maj: f32, w: Vec3) {
        self.0.on_collision(t, sigma_maj, w)
    }
}

/// An estimator's walk: the majorant it samples tentative collisions with over a segment,
/// whether it takes the per-voxel stage ([`voxel_stage`]'s `b` and `with_control`; `None`
/// where it would raise the variance), and whether Russian roulette follows its null
/// collisions.
pub struct Walk<Mj> {
    pub majorant: Mj,
    pub voxel: Option<(f32, bool)>,
    pub roulette: bool,
}

/// How a flight ended before `t_max`: a real or control event, or no weight left.
#[derive(Clone, Copy, Debug, PartialEq)]
enum End {
    Event(Real, f32),
    Dead(f32),
}

/// The shared flight: [`sample_free_flight`] over `walk`'s majorant and the medium's culling
/// stages, the rule at each collision (after the emission hook when `distance`), and the
/// outcome's counters, weight update and roulette. `w` is the weight the rule sees and
/// updates; returns how the flight ended (`None`: it escaped).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn fly<I, F, Mj, C>(
    segments: I,
    t_max: f32,
    medium: &F,
    walk: Walk<Mj>,
    distance: bool,
    rng: &mut Rng,
    stats: &mut TrackingStats,
    w: &mut F::Weight,
    mut rule: C,
) -> Option<End>
where
    I: IntoIterator<Item = MajorantSegment>,
    F: FlightMedium + ?Sized,
    Mj: FnMut(&MajorantSegment) -> f32,
    C: FnMut(&mut Rng, &mut TrackingStats, &Collision, F::Weight) -> Outcome<F::Weight>,
{
    let Walk {
        majorant,
        voxel,
        roulette,
    } = walk;
    let mut end = None;
    sample_free_flight(
        segments,
        t_max,
        majorant,
        |t| medium.cull_ratio(t),
        |t, seg, bound| match voxel {
            Some((b, with_control)) => medium.voxel_ratio(b, with_control, t, seg, bound),
            None => 1.0,
        },
        rng,
        stats,
        |rng, stats, c| {
            if distance {
                medium.on_collision(c.t, c.sigma_maj, *w);
            }
            let (real, factor) = match rule(rng, stats, c, *w) {
                Outcome::Null(factor) => {
                    stats.null_collisions += 1;
                    if let Some(f) = factor {
                        *w *= f;
                        w.note(stats);
                    }
                    if roulette {
                        *w = w.roulette(rng, stats);
                        if w.is_zero() {
                            end = Some(End::Dead(c.t));
                            return false;
                        }
                    }
                    return true;
                }
                Outcome::Real(real, factor) => (real, factor),
                Outcome::Control(real) => {
                    stats.control_collisions += 1;
                    end = Some(End::Event(real, c.t));
                    return false;
                }
                Outcome::Skip => return true,
                Outcome::Dead => {
                    end = Some(End::Dead(c.t));
                    return false;
                }
            };
            if let Some(f) = factor {
                *w *= f;
                w.note(stats);
            }
            stats.real_collisions += 1;
            end = Some(End::Event(real, c.t));
            false
        },
    );
    end
}

/// A `sample_distance` from its walk and collision rule: the flight calls
/// [`Medium::on_collision`] with the weight so far at every collision the culling keeps, and
/// ends in the rule's event with the weight after it, absorbed with weight 0 when no weight is
/// left, or escaping with the weight.
#[inline(always)]
pub fn distance<I, F, Mj, C>(
    segments: I,
    t_max: f32,
    medium: F,
    walk: Walk<Mj>,
    rng: &mut Rng,
    stats: &mut TrackingStats,
    rule: C,
) -> Event<F::Weight>
where
    I: IntoIterator<Item = MajorantSegment>,
    F: FlightMedium,
    Mj: FnMut(&MajorantSegment) -> f32,
    C: FnMut(&mut Rng, &mut TrackingStats, &Collision, F::Weight) -> Outcome<F::Weight>,
{
    let mut w = F::Weight::ONE;
    let end = fly(
        segments, t_max, &medium, walk, true, rng, stats, &mut w, rule,
    );
    match end {
        None => Event::Escape { weight: w },
        Some(End::Event(Real::Absorb, t)) => Event::Absorb { t, weight: w },
        Some(End::Event(Real::Scatter, t)) => Event::Scatter { t, weight: w },
        Some(End::Dead(t)) => Event::Absorb {
            t,
            weight: F::Weight::ZERO,
        },
    }
}

/// A `transmittance` from its walk and collision rule: the weight on escape or once roulette
/// zeroed it, 0 after a real collision.
#[inline(always)]
pub fn transmittance<I, F, Mj, C>(
    segments: I,
    t_max: f32,
    medium: F,
    walk: Walk<Mj>,
    rng: &mut Rng,
    stats: &mut TrackingStats,
    rule: C,
) -> F::Weight
where
    I: IntoIterator<Item = MajorantSegment>,
    F: FlightMedium,
    Mj: FnMut(&MajorantSegment) -> f32,
    C: FnMut(&mut Rng, &mut TrackingStats, &Collision, F::Weight) -> Outcome<F::Weight>,
{
    let mut w = F::Weight::ONE;
    match fly(
        segments, t_max, &medium, walk, false, rng, stats, &mut w, rule,
    ) {
        Some(End::Event(..)) => F::Weight::ZERO,
        None | Some(End::Dead(_)) => w,
    }
}

/// The transmittance of the control-based estimators (decomposition, weighted decomposition,
/// residual ratio tracking): `exp(-int sigma_c)` in closed form, summed in the same walk
/// ([`ControlDepthWalk`]), times [`transmittance`] of the residual. A zero closed-form factor
/// makes the estimate 0 (the residual weight could overflow: 0 * inf = NaN), and a walk cut
/// at the depth where it underflows returns 0 too.
#[inline(always)]
pub fn control_transmittance<I, M, Mj, C>(
    segments: I,
    t_max: f32,
    medium: &M,
    walk: Walk<Mj>,
    rng: &mut Rng,
    stats: &mut TrackingStats,
    rule: C,
) -> f32
where
    I: IntoIterator<Item = MajorantSegment>,
    M: Medium + ?Sized,
    Mj: FnMut(&MajorantSegment) -> f32,
    C: FnMut(&mut Rng, &mut TrackingStats, &Collision, f32) -> Outcome<f32>,
{
    let mut segments = ControlDepthWalk::new(segments.into_iter(), t_max, medium);
    let w = transmittance(&mut segments, t_max, Grey(medium), walk, rng, stats, rule);
    let t_control = segments.control_transmittance();
    if t_control == 0.0 {
        return 0.0;
    }
    t_control * w
}
