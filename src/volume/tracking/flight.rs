//! The flight every estimator shares around its collision rule, and the traits through which an
//! estimator plugs into it. The walk over majorant segments with its culling stages
//! ([`sample_free_flight`]), the emission hook of distance sampling, the counters, the weight's
//! update and its Russian roulette, the closed-form control factor and the event or estimate
//! that ends the flight are written here once, in [`sample_distance`] and [`transmittance`].
//! An estimator is a type whose value holds its parameters (the majorant scale `b`, ...): it
//! states its walk ([`Estimator`]) and the rule that turns one tentative collision into an
//! [`Outcome`] ([`DistanceEstimator`], [`TransmittanceEstimator`]).
use super::{
    roulette, sample_free_flight, scaled_majorant, voxel_stage, Collision, ControlDepthWalk, Event,
    Medium, MediumRgb, TrackingStats, ROULETTE_THRESHOLD,
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
    /// `s` times the weight.
    fn scale(self, s: f32) -> Self;
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
    #[inline]
    fn scale(self, s: f32) -> f32 {
        s * self
    }
}

impl Weight for Vec3 {
    const ZERO: Vec3 = Vec3::ZERO;
    const ONE: Vec3 = Vec3::ONE;
    #[inline]
    fn note(self, stats: &mut TrackingStats) {
        stats.note_weight(self.abs().max_element());
    }
    /// The roulette of `max |w|`: a survivor's channels are rescaled as its max was.
    #[inline]
    fn roulette(self, rng: &mut Rng, stats: &mut TrackingStats) -> Vec3 {
        let m = self.abs().max_element();
        let survivor = roulette(m, ROULETTE_THRESHOLD, rng, stats);
        if survivor == m {
            self
        } else if survivor == 0.0 {
            Vec3::ZERO
        } else {
            self * (survivor / m)
        }
    }
    #[inline]
    fn is_zero(self) -> bool {
        self == Vec3::ZERO
    }
    #[inline]
    fn scale(self, s: f32) -> Vec3 {
        s * self
    }
}

/// What the shared flight asks of a medium besides its lookups (which the rules make), in the
/// weight `W` of its estimators: grey [`Medium`]s fly with `f32`, RGB [`MediumRgb`]s with
/// `Vec3`.
pub trait FlightMedium<W> {
    /// [`Medium::cull_ratio`].
    fn cull_ratio(&self, t: f32) -> f32;
    /// [`Medium::on_collision`].
    fn on_collision(&self, t: f32, sigma_maj: f32, w: W);
    /// [`Medium::voxel_ratio`]. Default: no per-voxel stage.
    #[inline]
    fn voxel_ratio(&self, _t: f32, _seg: &MajorantSegment, _bound: f32) -> f32 {
        1.0
    }
    /// The control extinction over `seg` ([`Medium::control`]). Default: no control.
    #[inline]
    fn sigma_c(&self, _seg: &MajorantSegment) -> f32 {
        0.0
    }
}

impl<M: Medium + ?Sized> FlightMedium<f32> for M {
    #[inline]
    fn cull_ratio(&self, t: f32) -> f32 {
        Medium::cull_ratio(self, t)
    }
    #[inline]
    fn voxel_ratio(&self, t: f32, seg: &MajorantSegment, bound: f32) -> f32 {
        Medium::voxel_ratio(self, t, seg, bound)
    }
    #[inline]
    fn sigma_c(&self, seg: &MajorantSegment) -> f32 {
        self.control(seg).sigma_t()
    }
    #[inline]
    fn on_collision(&self, t: f32, sigma_maj: f32, w: f32) {
        Medium::on_collision(self, t, sigma_maj, w)
    }
}

impl<M: MediumRgb + ?Sized> FlightMedium<Vec3> for M {
    #[inline]
    fn cull_ratio(&self, t: f32) -> f32 {
        MediumRgb::cull_ratio(self, t)
    }
    #[inline]
    fn on_collision(&self, t: f32, sigma_maj: f32, w: Vec3) {
        MediumRgb::on_collision(self, t, sigma_maj, w)
    }
}

/// What a collision rule works with: the medium it looks up, the random numbers it draws, the
/// counters it updates, and `w`, the weight before the collision.
pub struct Tracker<'a, M: ?Sized, W> {
    pub medium: &'a M,
    pub rng: &'a mut Rng,
    pub stats: &'a mut TrackingStats,
    pub w: W,
}

/// A null-collision estimator: the walk it samples tentative collisions with, the same for
/// both of its functions unless [`TransmittanceEstimator::transmittance_majorant`] says
/// otherwise. Its value holds its parameters.
pub trait Estimator<M: ?Sized> {
    /// `f32` for a grey [`Medium`], `Vec3` for an RGB [`MediumRgb`].
    type Weight: Weight;
    /// Whether the extinction splits into a lookup-free control component
    /// ([`Medium::control`]) and a residual: the transmittance estimate is then the control's
    /// `exp(-int sigma_c)` in closed form times the walk's estimate of the residual, and the
    /// per-voxel stage thins only where the control is 0 ([`voxel_stage`]).
    const CONTROL: bool = false;
    /// Whether the walk takes the per-voxel stage ([`voxel_stage`]); `false` where it would
    /// raise the variance.
    const VOXEL_STAGE: bool = true;
    /// Whether Russian roulette ([`ROULETTE_THRESHOLD`]) follows every null collision, for
    /// estimators whose weights shrink there.
    const ROULETTE: bool = false;
    /// The majorant scale `b` (1: the bound itself).
    fn b(&self) -> f32 {
        1.0
    }
    /// The majorant over `seg`: [`scaled_majorant`] unless the estimator says otherwise.
    #[inline]
    fn majorant(&self, _medium: &M, seg: &MajorantSegment) -> f32 {
        scaled_majorant(self.b())(seg)
    }
}

/// An estimator that samples free-flight distances ([`sample_distance`]).
pub trait DistanceEstimator<M: ?Sized>: Estimator<M> {
    /// What tentative collision `c` is.
    fn distance_rule(
        &self,
        tr: &mut Tracker<'_, M, Self::Weight>,
        c: &Collision,
    ) -> Outcome<Self::Weight>;
}

/// An estimator of transmittance ([`transmittance`]).
pub trait TransmittanceEstimator<M: ?Sized>: Estimator<M> {
    /// The majorant of the transmittance walk over `seg`; with a control
    /// ([`Estimator::CONTROL`]), the residual's. Default: [`Estimator::majorant`].
    #[inline]
    fn transmittance_majorant(&self, medium: &M, seg: &MajorantSegment) -> f32 {
        self.majorant(medium, seg)
    }
    /// What tentative collision `c` is; a real collision zeroes the estimate.
    fn transmittance_rule(
        &self,
        tr: &mut Tracker<'_, M, Self::Weight>,
        c: &Collision,
    ) -> Outcome<Self::Weight>;
}

/// How a flight ended before `t_max`: a real or control event, or no weight left.
#[derive(Clone, Copy, Debug, PartialEq)]
enum End {
    Event(Real, f32),
    Dead(f32),
}

/// The shared flight: [`sample_free_flight`] over `majorant` and the medium's culling stages
/// (the per-voxel one as `estimator` says), the rule at each collision (after the emission hook
/// when `distance`), and the outcome's counters, weight update and roulette. `w` is the weight
/// the rule sees and updates; returns how the flight ended (`None`: it escaped).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn fly<E, I, M, Mj, C>(
    estimator: &E,
    segments: I,
    t_max: f32,
    medium: &M,
    majorant: Mj,
    distance: bool,
    rng: &mut Rng,
    stats: &mut TrackingStats,
    w: &mut E::Weight,
    mut rule: C,
) -> Option<End>
where
    E: Estimator<M>,
    I: IntoIterator<Item = MajorantSegment>,
    M: FlightMedium<E::Weight> + ?Sized,
    Mj: FnMut(&MajorantSegment) -> f32,
    C: FnMut(&mut Tracker<'_, M, E::Weight>, &Collision) -> Outcome<E::Weight>,
{
    let mut end = None;
    sample_free_flight(
        segments,
        t_max,
        majorant,
        |t| medium.cull_ratio(t),
        |t, seg, bound| {
            if E::VOXEL_STAGE {
                voxel_stage(medium, estimator.b(), E::CONTROL, t, seg, bound)
            } else {
                1.0
            }
        },
        rng,
        stats,
        |rng, stats, c| {
            if distance {
                medium.on_collision(c.t, c.sigma_maj, *w);
            }
            let mut tr = Tracker {
                medium,
                rng: &mut *rng,
                stats: &mut *stats,
                w: *w,
            };
            let outcome = rule(&mut tr, c);
            if let Outcome::Null(Some(f)) | Outcome::Real(_, Some(f)) = outcome {
                *w *= f;
                w.note(stats);
            }
            match outcome {
                Outcome::Null(_) => {
                    stats.null_collisions += 1;
                    if E::ROULETTE {
                        *w = w.roulette(rng, stats);
                        if w.is_zero() {
                            end = Some(End::Dead(c.t));
                            return false;
                        }
                    }
                    true
                }
                Outcome::Real(real, _) => {
                    stats.real_collisions += 1;
                    end = Some(End::Event(real, c.t));
                    false
                }
                Outcome::Control(real) => {
                    stats.control_collisions += 1;
                    end = Some(End::Event(real, c.t));
                    false
                }
                Outcome::Skip => true,
                Outcome::Dead => {
                    end = Some(End::Dead(c.t));
                    false
                }
            }
        },
    );
    end
}

/// Samples a free flight over `segments` clipped to `t_max` with `estimator`: the first real
/// collision and its weight, absorbed with weight 0 when no weight is left, or the escape with
/// its weight. Calls [`Medium::on_collision`] with the weight so far at every collision the
/// culling keeps.
pub fn sample_distance<E, I, M>(
    estimator: &E,
    segments: I,
    t_max: f32,
    medium: &M,
    rng: &mut Rng,
    stats: &mut TrackingStats,
) -> Event<E::Weight>
where
    E: DistanceEstimator<M>,
    I: IntoIterator<Item = MajorantSegment>,
    M: FlightMedium<E::Weight> + ?Sized,
{
    let mut w = E::Weight::ONE;
    let end = fly(
        estimator,
        segments,
        t_max,
        medium,
        |seg: &MajorantSegment| estimator.majorant(medium, seg),
        true,
        rng,
        stats,
        &mut w,
        |tr: &mut Tracker<'_, M, E::Weight>, c: &Collision| estimator.distance_rule(tr, c),
    );
    match end {
        None => Event::Escape { weight: w },
        Some(End::Event(Real::Absorb, t)) => Event::Absorb { t, weight: w },
        Some(End::Event(Real::Scatter, t)) => Event::Scatter { t, weight: w },
        Some(End::Dead(t)) => Event::Absorb {
            t,
            weight: E::Weight::ZERO,
        },
    }
}

/// Estimates the transmittance over `segments` clipped to `t_max` with `estimator`: the weight
/// on escape or once roulette zeroed it, 0 after a real collision. With a control
/// ([`Estimator::CONTROL`]) that is the residual's estimate, times `exp(-int sigma_c)` summed
/// in closed form in the same walk ([`ControlDepthWalk`]); a zero closed-form factor makes the
/// estimate 0 (the residual weight could overflow: 0 * inf = NaN), and a walk cut at the depth
/// where it underflows returns 0 too.
pub fn transmittance<E, I, M>(
    estimator: &E,
    segments: I,
    t_max: f32,
    medium: &M,
    rng: &mut Rng,
    stats: &mut TrackingStats,
) -> E::Weight
where
    E: TransmittanceEstimator<M>,
    I: IntoIterator<Item = MajorantSegment>,
    M: FlightMedium<E::Weight> + ?Sized,
{
    let majorant = |seg: &MajorantSegment| estimator.transmittance_majorant(medium, seg);
    let rule =
        |tr: &mut Tracker<'_, M, E::Weight>, c: &Collision| estimator.transmittance_rule(tr, c);
    let estimate = |end: Option<End>, w| match end {
        Some(End::Event(..)) => E::Weight::ZERO,
        None | Some(End::Dead(_)) => w,
    };
    let mut w = E::Weight::ONE;
    if !E::CONTROL {
        let end = fly(
            estimator, segments, t_max, medium, majorant, false, rng, stats, &mut w, rule,
        );
        return estimate(end, w);
    }
    let sigma_c = |seg: &MajorantSegment| medium.sigma_c(seg);
    let mut segments = ControlDepthWalk::new(segments.into_iter(), t_max, sigma_c);
    let end = fly(
        estimator,
        &mut segments,
        t_max,
        medium,
        majorant,
        false,
        rng,
        stats,
        &mut w,
        rule,
    );
    let t_control = segments.control_transmittance();
    if t_control == 0.0 {
        return E::Weight::ZERO;
    }
    estimate(end, w).scale(t_control)
}
