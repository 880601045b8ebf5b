//! One path's state between the stages of the CPU path tracer (`integrator::path`): its
//! ray, media, throughput and radiance, what the MIS weights of its next emission and escape
//! need, and the light passes, data passes and light groups it fills.
use glam::Vec3;

use super::equiangular::Segment;
use super::next_event::EnvChoice;
use crate::math::Ray;
use crate::render::light_groups::{MAX_LIGHT_GROUPS, NO_GROUP};
use crate::render::lights::LightSource;
use crate::render::prepare::RenderScene;
use crate::render::settings::VolumeSampling;
use crate::render::stack::MediumStack;

/// Limits of one path.
#[derive(Clone, Copy, Debug)]
pub struct PathLimits {
    pub max_depth: u32,
    pub rr_depth: u32,
    /// Roulette also before `rr_depth`, from the third event on, once `max(beta)` falls
    /// below this (0: never).
    pub rr_throughput: f32,
    pub max_collisions: u64,
    /// Guided light selection at medium events (`LightSelection::guided`).
    pub guided_lights: bool,
    /// The share of a constant sky left to the continuation ray there
    /// (`LightSelection::continuation_albedo`).
    pub continuation_albedo: f32,
    /// A transparent film: the environment seen straight through by the camera path is left
    /// out of its radiance (`RenderSettings::film_transparent`).
    pub film_transparent: bool,
    /// Split the radiance into the light passes (`film::passes::LIGHT_PASSES`) as well.
    pub light_passes: bool,
    /// Record the data passes (`film::passes::DATA_PASSES`) as well.
    pub data_passes: bool,
    /// Split the radiance into the light groups (`RenderScene::groups`) as well.
    pub light_groups: bool,
    /// How scattering distances towards point and spot lights are sampled
    /// (`integrator::equiangular`); `Distance` where the scene has no such light.
    pub volume_sampling: VolumeSampling,
    /// The lamps inside media that medium scattering events draw part of their directions
    /// towards (`glow::Lamps`; none under distance-only sampling).
    pub lamps: super::glow::Lamps,
}

/// One path between stages: the ray and where its next flight starts, the medium stack, the
/// throughput, the radiance gathered so far, and what the MIS weights of emission and of the
/// escape need of the last event (the CPU's `GpuPathState`).
pub(super) struct PathState {
    pub(super) ray: Ray,
    pub(super) t0: f32,
    pub(super) media: MediumStack,
    pub(super) beta: Vec3,
    pub(super) l: Vec3,
    pub(super) depth: u32,
    /// Whether this bounce's free flight has drawn its sampler point (DIM_DISTANCE).
    pub(super) flight_started: bool,
    /// Whether the last direction was chosen by a delta distribution (no MIS), and its pdf.
    pub(super) specular: bool,
    pub(super) prev_pdf: f32,
    /// How the last event chose the environment (the escape's MIS weight).
    pub(super) prev_env: EnvChoice,
    /// The camera path's transmittance to the background, the mean of `beta`'s channels where
    /// it escapes before any scattering event, else 0: the sample's coverage is 1 minus it.
    pub(super) background: f32,
    /// The radiance split into the light passes (`PathLimits::light_passes`), and whether the
    /// path's first scattering event was in a medium (else at a surface).
    pub(super) passes: [Vec3; LIGHT_PASS_COUNT],
    pub(super) first_in_medium: bool,
    /// The data passes (`PathLimits::data_passes`): albedo and normal, once recorded at the
    /// first event that is not a smooth dielectric; depth, once the camera ray meets a surface,
    /// scatters or escapes.
    pub(super) data: [Vec3; DATA_PASS_COUNT],
    pub(super) albedo_seen: bool,
    pub(super) depth_seen: bool,
    /// The radiance by light group (`PathLimits::light_groups`).
    pub(super) groups: [Vec3; MAX_LIGHT_GROUPS],
    /// The last flight's segment where equiangular sampling weighed it (the MIS weight of a
    /// scattering event's next-event estimate there).
    pub(super) segment: Option<Segment>,
}

/// Number of data passes, and each one's index (`film::passes::DATA_PASSES` order).
pub const DATA_PASS_COUNT: usize = 3;
pub(super) const ALBEDO: usize = 0;
pub(super) const NORMAL: usize = 1;
pub(super) const DEPTH: usize = 2;
/// The depth pass of a camera ray that escapes (Cycles' Z of the background).
pub const BACKGROUND_DEPTH: f32 = 1e10;

/// Number of light passes, and each one's index (`film::passes::LIGHT_PASSES` order).
pub const LIGHT_PASS_COUNT: usize = 6;
pub(super) const EMISSION: usize = 0;
pub(super) const BACKGROUND: usize = 1;
pub(super) const VOLUME_DIRECT: usize = 2;
pub(super) const SURFACE_DIRECT: usize = 4;

impl PathState {
    /// Adds `x` to the radiance and, where asked, to its light pass: `seen` (emission or
    /// background) before any scattering event; after it, the first event's kind, direct at
    /// that event (its next-event estimate and what the ray leaving it meets), indirect later;
    /// and to light group `group`, the source's.
    #[inline(always)]
    pub(super) fn gather(&mut self, limits: &PathLimits, x: Vec3, seen: usize, group: u8) {
        self.l += x;
        if limits.light_passes {
            self.passes[self.pass_of(seen)] += x;
        }
        if limits.light_groups && group != NO_GROUP {
            self.groups[group as usize] += x;
        }
    }

    /// Adds `x`, a next-event estimate at a scattering event of the flight that follows
    /// (depth `depth + 1`), as [`Self::gather`] would there.
    #[inline(always)]
    pub(super) fn gather_next(&mut self, limits: &PathLimits, x: Vec3, group: u8) {
        // The event is the path's first only if it is at depth 1; the path itself may still
        // meet a surface first.
        let first_in_medium = self.first_in_medium;
        self.depth += 1;
        if self.depth == 1 {
            self.first_in_medium = true;
        }
        self.gather(limits, x, EMISSION, group);
        self.depth -= 1;
        self.first_in_medium = first_in_medium;
    }

    #[inline(always)]
    pub(super) fn pass_of(&self, seen: usize) -> usize {
        let first = if self.first_in_medium {
            VOLUME_DIRECT
        } else {
            SURFACE_DIRECT
        };
        match self.depth {
            0 => seen,
            1 => first,
            _ => first + 1,
        }
    }
}

/// The light group of a light `source` (none without one, or without groups kept).
#[inline(always)]
pub(super) fn group_of(rs: &RenderScene, source: Option<LightSource>) -> u8 {
    source.map_or(NO_GROUP, |s| rs.light_group(s))
}
