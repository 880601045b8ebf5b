//! The media of a prepared render as data both backends read: heterogeneous VDB media
//! ([`VdbMedium`], with the walk each flight takes over its majorants), homogeneous media
//! inside closed meshes ([`HomogeneousMedium`]), the estimator settings every flight shares
//! ([`TrackingConfig`]) and the counters of the media walks ([`MediaStats`]). The CPU's flights
//! through them are `integrator::media`; the GPU's are `shaders/common/media.wgsl`.
use std::sync::Arc;

use glam::Vec3;

use super::settings::{Absorption, Estimator, MajorantMode, RenderSettings, ShadowEstimator};
use crate::math::{Aabb, Ray};
use crate::scene::motion::FrameMotion;
use crate::volume::phases::Phase;
use crate::volume::tracking::{ControlExtinction, TrackingStats};
use crate::volume::{
    AdaptiveMajorants, AdaptiveShape, Advection, LeafBounds, LeafCulling, VoxelCulling,
};

pub use super::emission::{Blackbody, Emission, EmissionRegion, GridField};

/// A homogeneous medium (`KHR_materials_volume`), coefficients in m^-1.
#[derive(Clone, Copy, Debug)]
pub struct HomogeneousMedium {
    pub sigma_a: Vec3,
    pub sigma_s: Vec3,
    pub phase: Phase,
}

impl HomogeneousMedium {
    pub fn sigma_t(&self) -> Vec3 {
        self.sigma_a + self.sigma_s
    }
}

/// A heterogeneous medium from `BRUME_medium_vdb`, ready to track.
#[derive(Clone)]
pub struct VdbMedium {
    /// The light group its emission gathers into (`render::light_groups`; `NO_GROUP` where
    /// none is kept).
    pub light_group: u8,
    /// Its slot in `RenderScene::media_lights`, where it emits and is sampled as a light.
    pub emitter: Option<u32>,
    pub density: GridField,
    /// World bounds of the density's support.
    pub world_bounds: Aabb,
    /// Coefficients per unit density, m^-1.
    pub sigma_a: Vec3,
    pub sigma_s: Vec3,
    /// Largest channel of `sigma_a + sigma_s`: scales density bounds into majorants.
    pub sigma_t_bound: f32,
    /// The adaptive majorant hierarchy of the density grid, built for this medium's
    /// `sigma_t_bound` and voxel size (`--majorant adaptive`).
    pub adaptive: Arc<AdaptiveMajorants>,
    /// `sigma_t` equal in every channel (grey tracking suffices).
    pub grey: bool,
    pub phase: Phase,
    pub emission: Option<Emission>,
    /// The bounds its walks take where they differ from the density's own: an emitting
    /// medium's, raised wherever it may emit ([`super::emission_bounds`]). `None`: the
    /// density's bounds ([`Self::bounds`]).
    pub walk_bounds: Option<Arc<LeafBounds>>,
    /// Whether its per-leaf and culled walks thin by the per-voxel bounds: where the model
    /// says that pays (`volume::voxel_bounds::voxel_culling_pays`, decided when the render is
    /// prepared).
    pub voxel_culling_pays: bool,
    /// What [`LeafCulling::accepts`] and [`VoxelCulling::accepts`] say of this medium's bounds
    /// ([`Self::bounds`], its grid's cells and `sigma_t_bound`): answered once, where the
    /// render is prepared, rather than at every flight's set-up.
    pub culling_sound: CullingSound,
    /// How its flights walk under each majorant mode ([`Self::walk`]), resolved once where the
    /// render is prepared ([`WalkPlan::of`]).
    pub walks: [WalkPlan; 4],
    /// Velocity motion blur, where the medium has a velocity grid and the shutter is open: its
    /// lookups are then advected, and [`Self::walk_bounds`] and `world_bounds` are dilated to
    /// bound them over the whole shutter.
    pub blur: Option<Arc<VelocityBlur>>,
    /// The node's motion across the shutter, where an animation moves the medium then: a
    /// sample at time offset `dt` sees it at that pose ([`Self::rest_ray`]), and
    /// `world_bounds` covers every pose.
    pub motion: Option<Arc<FrameMotion>>,
}

/// A medium's velocity motion blur: a lookup at density index point `p` by a sample at time
/// offset `dt` (frames from the frame) reads the density, emission and temperature at
/// `advection.source(p, dt * factor)`.
#[derive(Clone, Debug)]
pub struct VelocityBlur {
    pub advection: Advection,
    /// Displacement per frame per unit of velocity (`scene::VelocityDesc::factor`).
    pub factor: f32,
    /// The density's `world_from_index`: where emission, read at world points, is looked up.
    pub world_from_index: glam::Affine3A,
}

impl VelocityBlur {
    /// The density index point read for `p_index` by a sample at time offset `dt`.
    #[inline]
    pub fn source(&self, p_index: Vec3, dt: f32) -> Vec3 {
        self.advection
            .source(p_index.as_dvec3(), dt as f64 * self.factor as f64)
            .as_vec3()
    }

    /// The world point read for density index point `p_index` at time offset `dt`.
    #[inline]
    pub fn source_world(&self, p_index: Vec3, dt: f32) -> Vec3 {
        self.world_from_index
            .transform_point3(self.source(p_index, dt))
    }
}

/// How one medium's flights walk its majorants under one majorant mode: resolved once per
/// medium where the render is prepared, and read by every flight, the GPU upload, `brume info`
/// and the benches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WalkPlan {
    /// The walk of free flights.
    pub free: MajorantMode,
    /// The walk of transmittance (shadow) flights.
    pub shadow: MajorantMode,
    /// The walk of free flights among overlapping media, whose merged stream has no single
    /// grid to cull by.
    pub merged: MajorantMode,
    /// Free flights cull their tentative collisions by the per-leaf bounds.
    pub leaf_culling: bool,
    /// Free flights thin their tentative collisions by the per-voxel bounds.
    pub voxel_culling: bool,
}

/// What [`LeafCulling::accepts`] and [`VoxelCulling::accepts`] answer for one medium.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CullingSound {
    pub leaf: bool,
    pub voxel: bool,
}

impl CullingSound {
    pub fn of(bounds: &LeafBounds, entries: &[u32], sigma_t_bound: f32) -> Self {
        CullingSound {
            leaf: LeafCulling::accepts(bounds),
            voxel: VoxelCulling::accepts(bounds, entries, sigma_t_bound),
        }
    }
}

impl WalkPlan {
    /// A placeholder until [`WalkPlan::of`] has the medium to plan for.
    pub const UNPLANNED: WalkPlan = WalkPlan {
        free: MajorantMode::Global,
        shadow: MajorantMode::Global,
        merged: MajorantMode::Global,
        leaf_culling: false,
        voxel_culling: false,
    };

    /// The plan of medium `m` under `mode`.
    ///
    /// Free flights: an adaptive hierarchy that is one node or all leaf cells is walked as the
    /// global bound or the per-leaf DDA, which give its segments bit for bit
    /// ([`AdaptiveShape`]); one built as the culled global walk is that walk, except in an
    /// emitting medium. An emitting medium's free flights walk the per-leaf DDA where the
    /// model chose the culled walk: its emission is estimated at every tentative collision, and
    /// a culled walk spends a camera ray's first, stratified (Sobol) draw on the global
    /// bound's first collision, not on its first emission sample; the DDA maps that draw to
    /// optical depth under the same cell bounds, so on the example fire its per-pixel variance
    /// is about two thirds of the culled walk's for a few per cent more time (`brume bench
    /// render --majorants-only scenes/fire.gltf`).
    ///
    /// Shadow flights, which estimate no emission, take the culled global walk where the
    /// adaptive hierarchy is every leaf cell and prices it close enough
    /// (`AdaptiveMajorants::shadow_culled`) or is the culled walk itself; else the free walk.
    /// Among overlapping media the culled walk is walked as the per-leaf DDA. Only the culled
    /// walk culls by the leaf bounds, where [`LeafCulling::accepts`] them; the per-leaf DDA and
    /// the culled walk thin by the voxel bounds where that pays and [`VoxelCulling::accepts`]
    /// them.
    pub fn of(m: &VdbMedium, mode: MajorantMode) -> WalkPlan {
        let free = match (mode, m.adaptive.shape) {
            (MajorantMode::Adaptive, AdaptiveShape::OneNode) => MajorantMode::Global,
            (MajorantMode::Adaptive, AdaptiveShape::AllLeaves) => MajorantMode::Leaf,
            (MajorantMode::Adaptive, AdaptiveShape::Culled) if m.emission.is_some() => {
                MajorantMode::Leaf
            }
            (MajorantMode::Adaptive, AdaptiveShape::Culled) => MajorantMode::Culled,
            _ => mode,
        };
        let shadow = if mode == MajorantMode::Adaptive
            && (m.adaptive.shadow_culled || m.adaptive.shape == AdaptiveShape::Culled)
        {
            MajorantMode::Culled
        } else {
            free
        };
        let merged = match free {
            MajorantMode::Culled => MajorantMode::Leaf,
            walk => walk,
        };
        WalkPlan {
            free,
            shadow,
            merged,
            leaf_culling: m.culling_sound.leaf && free == MajorantMode::Culled,
            voxel_culling: m.voxel_culling_pays
                && m.culling_sound.voxel
                && matches!(free, MajorantMode::Leaf | MajorantMode::Culled),
        }
    }
}

impl VdbMedium {
    /// Plans every majorant mode's walks ([`Self::walks`]) once the medium is complete.
    pub fn plan_walks(&mut self) {
        self.walks = MajorantMode::ALL.map(|mode| WalkPlan::of(self, mode));
    }

    /// `ray` (world space, at time offset `time`) carried to where the medium's fields are
    /// placed: itself unless the medium's node moves. The ray parameter is unchanged.
    #[inline]
    pub fn rest_ray(&self, ray: &Ray, time: f32) -> Ray {
        match &self.motion {
            None => *ray,
            Some(m) => {
                let f = m.rest_from_world(time);
                Ray::new(f.transform_point3(ray.o), f.transform_vector3(ray.d))
            }
        }
    }

    /// The plan of this medium's flights under `mode`.
    #[inline]
    pub fn walk(&self, mode: MajorantMode) -> &WalkPlan {
        &self.walks[mode as usize]
    }

    /// The per-leaf bounds (and per-voxel bounds) every walk of this medium takes: the
    /// density's, or [`Self::walk_bounds`] where they differ.
    #[inline]
    pub fn bounds(&self) -> &LeafBounds {
        self.walk_bounds
            .as_deref()
            .unwrap_or(&self.density.grid.bounds)
    }

    /// The per-leaf culling of this medium's free flights under `mode`, where planned.
    #[inline]
    pub fn culling(&self, mode: MajorantMode) -> Option<LeafCulling<'_>> {
        self.walk(mode)
            .leaf_culling
            .then(|| LeafCulling::accepted(self.bounds()))
    }

    /// The per-voxel culling of this medium's free flights under `mode`, where planned.
    #[inline]
    pub fn voxel_culling(&self, mode: MajorantMode) -> Option<VoxelCulling<'_>> {
        self.walk(mode).voxel_culling.then(|| {
            VoxelCulling::accepted(
                self.bounds(),
                &self.density.grid.grid.cells,
                self.sigma_t_bound,
            )
        })
    }

    /// The hierarchy when `mode`'s free flights walk it (a mixed adaptive hierarchy).
    pub fn walked_hierarchy(&self, mode: MajorantMode) -> Option<&AdaptiveMajorants> {
        (self.walk(mode).free == MajorantMode::Adaptive).then_some(&*self.adaptive)
    }
}

/// Estimator choice and parameters, shared by every flight of a render.
#[derive(Clone, Copy, Debug)]
pub struct TrackingConfig {
    pub estimator: Estimator,
    pub b: f32,
    pub m: Option<f32>,
    pub majorant: MajorantMode,
    pub shadow: ShadowEstimator,
    pub force_spectral: bool,
    pub absorption: Absorption,
    /// The time offset, in frames from the frame's time, of the camera sample the flights
    /// belong to ([`Self::at_time`]): what blurred media advect their lookups by. 0 without
    /// a shutter.
    pub time: f32,
}

impl TrackingConfig {
    /// The same settings for the flights of a camera sample at time offset `time`.
    #[inline]
    pub fn at_time(&self, time: f32) -> TrackingConfig {
        TrackingConfig { time, ..*self }
    }

    /// The tracking part of a render's settings (the same for every backend).
    pub fn from_settings(s: &RenderSettings) -> Self {
        TrackingConfig {
            estimator: s.estimator,
            b: s.b,
            m: s.m,
            majorant: s.majorant,
            shadow: s.shadow,
            force_spectral: s.force_spectral,
            absorption: s.absorption,
            time: 0.0,
        }
    }

    /// The control extinction of decomposition tracking and residual ratio tracking. With
    /// local bounds (per-leaf or adaptive) it is the segment's minorant for every estimator:
    /// a true minorant, so no residual is negative, and where a segment is uniform (tiles,
    /// the inside of a fog) the residual vanishes and the control is the whole answer. The
    /// delta-type distance samplers never look at it. With the global bound it is `m * bound`,
    /// capped by the global minorant for analog decomposition (which must not exceed
    /// `sigma_t`) and uncapped for the weighted estimator (signed weights where the control
    /// exceeds the density); none for the delta-type estimators.
    pub fn control(&self) -> ControlExtinction {
        match (self.estimator, self.majorant.is_local(), self.m) {
            (_, true, _) => ControlExtinction::SegmentMinorant,
            (Estimator::Decomposition, false, Some(m)) => {
                ControlExtinction::FractionOfBoundCapped(m)
            }
            (Estimator::Decomposition, false, None) => ControlExtinction::SegmentMinorant,
            (Estimator::WeightedDecomposition, false, m) => {
                ControlExtinction::FractionOfBound(m.unwrap_or(super::settings::DEFAULT_WEIGHTED_M))
            }
            _ => ControlExtinction::None,
        }
    }

    /// Whether shadow rays use residual ratio tracking (Novak et al. 2014) rather than ratio
    /// tracking: `--shadow auto` takes it whenever there is a control. With the local
    /// minorant as control it never costs more lookups than ratio tracking (its residual
    /// majorant `sigma_maj - sigma_min` is at most `sigma_maj`) and is exact, with no lookup,
    /// across uniform segments, where ratio tracking's first collision would zero the estimate.
    pub fn residual_shadow(&self) -> bool {
        match self.shadow {
            ShadowEstimator::Ratio => false,
            ShadowEstimator::ResidualRatio => true,
            ShadowEstimator::Auto => self.control() != ControlExtinction::None,
        }
    }

    /// Majorant scale: the analog estimators always use the bound itself.
    pub fn b(&self) -> f32 {
        match self.estimator {
            Estimator::WeightedDelta | Estimator::WeightedDecomposition => self.b,
            Estimator::Delta | Estimator::Decomposition => 1.0,
        }
    }
}

/// Counters of one path (or tile), beyond what the trackers count.
#[derive(Clone, Copy, Debug, Default)]
pub struct MediaStats {
    pub tracking: TrackingStats,
    /// Lookups made by shadow-ray transmittance (also included in `tracking.lookups`).
    pub shadow_lookups: u64,
    /// Majorant segments walked by shadow rays (also included in `tracking.segments`).
    pub shadow_segments: u64,
    pub emission_lookups: u64,
}
