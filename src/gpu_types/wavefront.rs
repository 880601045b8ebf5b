//! The wavefront integrator's path state, shadow rays, queues, counters and per-iteration
//! parameters, and the VDB medium's emission uniform.
use bytemuck::{Pod, Zeroable};
use std::mem::size_of;

use super::{GpuCameraMotion, GpuGridInfo, GpuPhase, GpuTrackingParams, GpuVelocityBlur};

/// The state of one path of the wavefront integrator, one slot per path in flight: what
/// `integrator::path::radiance` keeps in local variables between loop iterations. Kept as
/// small as the stages allow (Cycles' `state_template.h` rule): it is read and written by every
/// stage.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuPathState {
    /// Ray origin, world space, metres (after a medium scattering event: the event's point).
    pub o: [f32; 3],
    /// Start of the ray's parameter interval, metres (camera near plane, past a null
    /// interface, else 0).
    pub t0: f32,
    /// Unit ray direction, world space.
    pub d: [f32; 3],
    /// Solid-angle density (sr^-1) with which `d` was sampled; 0 for the camera ray.
    pub prev_pdf: f32,
    /// Path throughput `beta` per RGB channel (dimensionless).
    pub beta: [f32; 3],
    /// Index of this camera sample within the batch (`pixel - pixel0) * spp_batch + s`.
    pub sample_id: u32,
    /// Radiance gathered so far, W m^-2 sr^-1 per RGB channel.
    pub l: [f32; 3],
    /// Scattering events so far (media and surfaces).
    pub depth: u32,
    /// `Rng::state` of the path's stream `Rng::new(pixel, sample, seed)`.
    pub rng_state: u32,
    /// `Rng::inc` of the same stream (odd).
    pub rng_inc: u32,
    /// `PATH_FLAG_*` bits.
    pub flags: u32,
    /// Tentative collisions (null, real, control) of every free flight and shadow ray of the
    /// path, for the `max_collisions_per_path` guard.
    pub collisions: u32,
    /// Density and emission lookups of the path (its pixel's cost-map entry).
    pub lookups: u32,
    /// The homogeneous medium (`KHR_materials_volume`) the path is in, as an index into the
    /// homogeneous media, or `NO_INDEX` (`radiance`'s `medium`).
    pub medium: u32,
    /// The surface the current ray hits first: its slot in the BVH's triangle order
    /// ([`GpuTriangle`]), `NO_INDEX` when it hits none (set by the intersect stage).
    pub hit_prim: u32,
    /// Ray parameter (metres, the direction being unit) of that hit.
    pub hit_t: f32,
    /// Barycentric weight of the hit triangle's second vertex.
    pub hit_b1: f32,
    /// Barycentric weight of its third vertex.
    pub hit_b2: f32,
    /// The media below `medium` on the path's medium stack (`render::stack`), 16 bits
    /// each: the next one down in the low half, the one below it in the high half,
    /// [`STACK_NONE`] where there is none (the GPU stack holds three entries).
    pub outer: u32,
    /// Henyey-Greenstein `g` of the medium that scattered last (the mixture variant records
    /// it at every medium event: with overlapping media the phase function belongs to the
    /// medium a scattering event picked, `integrator::mixture`).
    pub phase_g: f32,
    /// The camera sample's time offset, frames from the frame's time (`TrackingConfig::time`:
    /// what its camera pose and every blurred lookup of the path, shadow rays included, use);
    /// 0 without a shutter.
    pub time: f32,
    /// The light group of the pending shadow ray's light (`LightSample::source`, through
    /// `LightGroups::of_source`): where the shadow stage gathers its estimate. Set only by the
    /// light-group variant.
    pub shadow_group: u32,
    /// The VDB medium whose phase function applies at the path's scattering event
    /// ([`GpuWavefrontParams::phases`]), `NO_INDEX` where it is the homogeneous medium's the
    /// path is in (set by the mixture variant, as `phase_g` is).
    pub phase_medium: u32,
    /// The last flight's segment in media as the equiangular strategy saw it
    /// (`integrator::equiangular::Segment`), where [`PATH_FLAG_SEGMENT`] is set: its ends
    /// relative to the scattering event the flight ended in, m (`seg_b` may be infinite)...
    pub seg_a: f32,
    pub seg_b: f32,
    /// ...the largest extinction of its media, m^-1...
    pub seg_sigma_max: f32,
    /// ...and the mean extinction at the event, m^-1 (the free-flight density's, for the
    /// scattering stage's MIS weight without a lookup).
    pub seg_sigma_t: f32,
    pub _pad2: u32,
    /// The base colour (textures applied) of the opaque surface the path stopped at, as the
    /// surface stage found it: the media lights' stage evaluates the BSDF with it
    /// (`Principled::new`) without binding the textures.
    pub surface_color: [f32; 3],
    /// The solid-angle density (sr^-1) with which `d` was sampled, as drawn (`prev_pdf`
    /// before guided selection rescales it): the flights' emission is weighed against the
    /// media lights with it (`EmissionMis::pdf_dir`).
    pub dir_pdf: f32,
}
const _: () = assert!(size_of::<GpuPathState>() == 160);

/// An empty 16-bit half of [`GpuPathState::outer`] and [`GpuShadowRay::outer`].
pub const STACK_NONE: u32 = 0xFFFF;
/// Media a GPU path can be inside at once: `medium` and the two halves of `outer`.
pub const GPU_MAX_NESTED_MEDIA: usize = 3;

/// [`GpuPathState::flags`] bit: the last direction was chosen by a delta distribution (the
/// camera, a smooth dielectric), so no MIS applies when it meets an emitter.
pub const PATH_FLAG_SPECULAR: u32 = 1;
/// [`GpuPathState::flags`] bit: the path stopped at an opaque surface (its hit fields
/// describe it) and the next direction is to be sampled from the BSDF, not the phase function.
pub const PATH_FLAG_SURFACE: u32 = 2;
/// [`GpuPathState::flags`] bit: the free flight of the current bounce has drawn its sampler
/// point (`radiance`'s `flight_started`); cleared at every scattering event.
pub const PATH_FLAG_FLIGHT_STARTED: u32 = 4;
/// [`GpuPathState::flags`] bit: the last event sampled the (constant) environment by its
/// phase function (`Selection::env_by_phase`); `prev_pdf` then holds `P_env`. Otherwise,
/// with guided light selection, `prev_pdf` holds the direction's density over the event's
/// environment selection probability (the power heuristic is invariant to scaling both
/// densities, so the escape weighs it against the bare environment density).
pub const PATH_FLAG_ENV_BY_PHASE: u32 = 8;
/// [`GpuPathState::flags`] bit: the path ended by escaping the scene (`escape`); with depth 0
/// its throughput is the camera ray's transmittance to the background.
pub const PATH_FLAG_ESCAPED: u32 = 16;
/// [`GpuPathState::flags`] bit: the path's first scattering event was in a medium, else at a
/// surface (`PathState::first_in_medium`): the light it gathers from then on goes to the
/// volume passes, else to the surface ones. Set only by the light-pass variant.
pub const PATH_FLAG_FIRST_IN_MEDIUM: u32 = 32;

/// [`GpuPathState::flags`] bit: the path has recorded its data passes' albedo and normal
/// (`PathState::albedo_seen`). Set only by the data-pass variant.
pub const PATH_FLAG_ALBEDO_SEEN: u32 = 64;
/// [`GpuPathState::flags`] bit: the path has recorded its depth pass, or its camera ray
/// scattered before meeting a surface (`PathState::depth_seen`). Set only by the data-pass
/// variant.
pub const PATH_FLAG_DEPTH_SEEN: u32 = 128;
/// [`GpuPathState::flags`] bit: the last flight had a segment in media that the equiangular
/// strategy sampled (`PathState::segment`): the scattering event's next-event estimate of a
/// point or spot light takes the free-flight MIS weight.
pub const PATH_FLAG_SEGMENT: u32 = 256;

/// Light passes a path fills (`film::passes::LIGHT_PASSES`, `integrator::path::LIGHT_PASS_COUNT`):
/// the light-pass variant keeps one RGB accumulator per pass and path slot, and one per pass
/// and camera sample, each a `vec4` (w unused) at `index * GPU_LIGHT_PASSES + pass`.
pub const GPU_LIGHT_PASSES: u32 = 6;
const _: () = assert!(GPU_LIGHT_PASSES as usize == crate::integrator::path::LIGHT_PASS_COUNT);
/// Bytes of one path slot's or camera sample's light passes (each light group, beside them in
/// the same buffer, takes one such `vec4` more).
pub const GPU_LIGHT_PASS_BYTES: u64 = GPU_LIGHT_PASSES as u64 * 16;
/// The passes `PathState::pass_of` routes to by name, as indices into `LIGHT_PASSES`: what the
/// camera sees before any event (emission, background), and the first direct pass of each
/// first-event kind (its indirect pass follows it).
pub const PASS_EMISSION: u32 = 0;
pub const PASS_BACKGROUND: u32 = 1;
pub const PASS_VOLUME_DIRECT: u32 = 2;
pub const PASS_SURFACE_DIRECT: u32 = 4;

/// The data passes of one path (`PathState::data`, `film::passes::DATA_PASSES`): the
/// data-pass variant keeps one per path slot, beside the path state, and one per camera sample
/// of the batch, which the host reads back with the samples.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuDataPasses {
    /// The throughput times the base colour at the first surface that is not a smooth
    /// dielectric, past the albedo at a first medium event, or times the sky where the path
    /// escapes (per RGB channel).
    pub albedo: [f32; 3],
    /// The camera-space Z of the camera ray's first surface, metres (`BACKGROUND_DEPTH` where
    /// it escapes, 0 where it scatters first).
    pub depth: f32,
    /// The shading normal where the albedo was taken, world space (the view direction in a
    /// medium, zero for the sky).
    pub normal: [f32; 3],
    pub _pad0: u32,
}
const _: () = assert!(size_of::<GpuDataPasses>() == 32);
/// Bytes of one path slot's or camera sample's data passes.
pub const GPU_DATA_PASS_BYTES: u64 = size_of::<GpuDataPasses>() as u64;

impl GpuDataPasses {
    /// The passes in `DATA_PASSES` order, three values each, as the CPU's `CameraSample::data`
    /// holds them (the depth in every channel).
    pub fn values(&self) -> [[f32; 3]; crate::integrator::path::DATA_PASS_COUNT] {
        [self.albedo, self.normal, [self.depth; 3]]
    }
}

/// What one finished camera sample brings its pixel (`CameraSample`): an entry of the batch's
/// sample buffer, which the host adds to the film in pixel and sample order.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuSample {
    /// Radiance, W m^-2 sr^-1 per RGB channel.
    pub l: [f32; 3],
    /// Density and emission lookups of the path (its pixel's cost-map entry).
    pub lookups: u32,
    /// Coverage: 1 minus the camera ray's transmittance to the background.
    pub alpha: f32,
    pub _pad0: u32,
    pub _pad1: u32,
    pub _pad2: u32,
}
const _: () = assert!(size_of::<GpuSample>() == 32);

/// A shadow ray of next-event estimation, one slot per path (a path has at most one pending).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuShadowRay {
    /// Origin, world space, metres.
    pub o: [f32; 3],
    /// Distance to the light, metres (`+inf` for directional and environment light).
    pub dist: f32,
    /// Unit direction towards the light.
    pub wi: [f32; 3],
    /// The homogeneous medium at the origin (`NO_INDEX`: none).
    pub medium: u32,
    /// `beta * L_i * f * w_mis / pdf` per RGB channel: added to the path's radiance times the
    /// transmittance the ray finds.
    pub contribution: [f32; 3],
    /// The media below `medium` on the path's stack ([`GpuPathState::outer`]).
    pub outer: u32,
}
const _: () = assert!(size_of::<GpuShadowRay>() == 48);

wgsl_enum! {
    /// The work queues of the wavefront integrator; `GpuWavefrontCounters::queue_count` index.
    /// Each queue holds path slot indices. The medium and done queues are double-buffered by
    /// iteration parity (`GpuWavefrontParams::parity`): a stage reads `X0 + parity` and appends
    /// to `X0 + 1 - parity` what the next iteration consumes.
    pub enum GpuQueue {
        /// Paths whose current ray must be tracked through the media (parity 0).
        Medium0 = 0 => "QUEUE_MEDIUM0",
        /// The same, parity 1.
        Medium1 = 1 => "QUEUE_MEDIUM1",
        /// Finished paths (accumulated, then regenerated next iteration), parity 0.
        Done0 = 2 => "QUEUE_DONE0",
        /// The same, parity 1.
        Done1 = 3 => "QUEUE_DONE1",
        /// Paths that scattered in a medium (next-event estimation pending).
        Scatter = 4 => "QUEUE_SCATTER",
        /// Paths with a shadow ray to trace.
        Shadow = 5 => "QUEUE_SHADOW",
        /// Paths whose next direction is to be sampled from the phase function.
        Phase = 6 => "QUEUE_PHASE",
        /// Paths whose ray left the scene.
        Escape = 7 => "QUEUE_ESCAPE",
        /// Paths whose ray reached the surface it hits (no medium event before it).
        Surface = 8 => "QUEUE_SURFACE",
    }
}

impl GpuQueue {
    pub const COUNT: usize = GpuQueue::ALL.len();
}

wgsl_enum! {
    /// 64-bit counters of [`GpuWavefrontCounters::wide`]: pair `2k` (low word), `2k + 1` (high).
    pub enum GpuWideCounter {
        Lookups = 0 => "WIDE_LOOKUPS",
        NullCollisions = 1 => "WIDE_NULL_COLLISIONS",
        RealCollisions = 2 => "WIDE_REAL_COLLISIONS",
        ControlCollisions = 3 => "WIDE_CONTROL_COLLISIONS",
        ShadowLookups = 4 => "WIDE_SHADOW_LOOKUPS",
        DepthSum = 5 => "WIDE_DEPTH_SUM",
        /// Emission and temperature grid reads (`MediaStats::emission_lookups`).
        EmissionLookups = 6 => "WIDE_EMISSION_LOOKUPS",
        /// Majorant segments walked (`TrackingStats::segments`).
        Segments = 7 => "WIDE_SEGMENTS",
        /// Majorant segments walked by shadow rays (`MediaStats::shadow_segments`).
        ShadowSegments = 8 => "WIDE_SHADOW_SEGMENTS",
    }
}

/// Queue lengths, the sample dispenser and the render's counters, all atomics in WGSL.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuWavefrontCounters {
    /// Entries in each [`GpuQueue`].
    pub queue_count: [u32; 9],
    /// Next camera sample of the batch to start (may overshoot `total_samples`).
    pub next_sample: u32,
    /// Paths started and not yet accumulated.
    pub live: u32,
    /// Paths ended by the `max_collisions_per_path` guard.
    pub guard_fired: u32,
    /// `TrackingStats::majorant_violations`.
    pub majorant_violations: u32,
    /// `TrackingStats::invalid_majorants`.
    pub invalid_majorants: u32,
    /// `TrackingStats::collision_cap_hits`.
    pub collision_cap_hits: u32,
    /// Pushes the kernels refused because the queue already held `path_count` entries (a
    /// scheduling bug; the render fails on any).
    pub queue_overflows: u32,
    /// [`GpuWideCounter`] pairs (low, high) of 64-bit totals.
    pub wide: [u32; 18],
    /// Padding to a 16-byte row.
    pub _pad1: u32,
    /// Padding to a 16-byte row.
    pub _pad2: u32,
}
const _: () = assert!(size_of::<GpuWavefrontCounters>() == 144);

impl GpuWavefrontCounters {
    pub fn wide(&self, c: GpuWideCounter) -> u64 {
        let k = 2 * c as usize;
        self.wide[k] as u64 | (self.wide[k + 1] as u64) << 32
    }
}

/// Everything the wavefront stages read: camera, batch, lights, limits and the medium. One
/// uniform per iteration parity.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuWavefrontParams {
    /// Rows of `Camera::world_from_camera` (rigid; column 3 is the pinhole).
    pub camera: [[f32; 4]; 3],
    /// `tan(yfov / 2)`.
    pub tan_half: f32,
    /// Image width / height.
    pub aspect: f32,
    /// Near distance, metres.
    pub znear: f32,
    /// Seed of the RNG streams.
    pub seed: u32,
    /// Unit viewing direction (`Camera::forward`).
    pub forward: [f32; 3],
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// First pixel (row-major index) of the batch.
    pub pixel0: u32,
    /// First sample index of the batch (the pass's first sample).
    pub s0: u32,
    /// Samples per pixel in the batch.
    pub spp_batch: u32,
    /// Camera samples in the batch (pixels * spp_batch).
    pub total_samples: u32,
    /// Wavefront size: path slots.
    pub path_count: u32,
    /// Number of punctual lights.
    pub light_count: u32,
    /// Iteration parity (0 or 1): which medium/done queues are read.
    pub parity: u32,
    /// Constant environment radiance (0 when absent).
    pub env: [f32; 3],
    /// `Lights::pdf_environment`.
    pub env_pdf: f32,
    /// `PathLimits::max_depth`.
    pub max_depth: u32,
    /// `PathLimits::rr_depth`.
    pub rr_depth: u32,
    /// `PathLimits::max_collisions` (clamped to u32).
    pub max_collisions: u32,
    /// 1 when the scene has an environment light.
    pub has_env: u32,
    /// World bounds of the VDB medium, minimum corner.
    pub medium_lo: [f32; 3],
    /// Henyey-Greenstein `g` of the medium.
    pub phase_g: f32,
    /// World bounds of the VDB medium, maximum corner.
    pub medium_hi: [f32; 3],
    /// 1 when the scene has a VDB medium.
    pub has_medium: u32,
    /// `GreyView::scatter_albedo`: RGB factor of a grey scattering event.
    pub scatter_albedo: [f32; 3],
    /// 1 when the medium is tracked spectrally (`ESTIMATOR_SPECTRAL`).
    pub spectral: u32,
    /// Per-channel `sigma_s / sigma_t` (spectral lookups).
    pub albedo_rgb: [f32; 3],
    /// The [`GpuEstimator`] of shadow rays (ratio, residual ratio or spectral).
    pub shadow_estimator: u32,
    /// The free-flight estimator and its knobs, the medium's grey optics.
    pub tracking: GpuTrackingParams,
    /// The homogeneous medium around the camera (`RenderScene::camera_medium`), `NO_INDEX`
    /// when none.
    pub camera_medium: u32,
    /// Entries of the area lights' CDF (0: no area lights).
    pub area_count: u32,
    /// `PathLimits::rr_throughput`: roulette before `rr_depth` below this throughput.
    pub rr_throughput: f32,
    /// 1 when absorption is a weight (`Absorption::Weight`): grey homogeneous media scatter
    /// at every real collision with the RGB albedo as weight.
    pub absorption_weight: u32,
    /// The media below `camera_medium` around the camera ([`GpuPathState::outer`]).
    pub camera_outer: u32,
    /// VDB media in the `vdb_media` array (the mixture variant; 0 otherwise).
    pub vdb_count: u32,
    /// `WF_FLAG_*` bits.
    pub flags: u32,
    /// The grey free-flight [`GpuEstimator`] of a mixture of grey media (a chromatic member
    /// makes the flight spectral).
    pub mix_estimator: u32,
    /// `Lights::continuation_albedo`: the share of a constant environment's guided selection
    /// left to the continuation ray.
    pub continuation_albedo: f32,
    /// The [`GpuMajorantMode`] of the VDB medium's shadow rays (`WalkPlan::shadow`;
    /// `tracking.majorant_mode` is its free flights').
    pub shadow_majorant_mode: u32,
    /// The light groups (`LightGroups::environment`, `LightGroups::surfaces`): the
    /// environment's and the emissive surfaces' group, `NO_GROUP` where none (the light-group
    /// variant reads them).
    pub environment_group: u32,
    pub surfaces_group: u32,
    /// The group of each punctual light (`LightGroups::punctual`), one byte each: light `k` in
    /// byte `k % 4` of word `k / 4` (a render keeps at most `MAX_LIGHT_GROUPS` groups, so at
    /// most 16 punctual lights).
    pub punctual_groups: [u32; 4],
    /// The VDB medium's scattering coefficient per unit of the extinction its tracker reads
    /// (`sigma_s / sigma_t_bound`), for the equiangular estimate's in-scattering...
    pub medium_sigma_s: [f32; 3],
    /// ...its mean extinction per unit of the same (`mean(sigma_s + sigma_a) / sigma_t_bound`)...
    pub medium_sigma_t: f32,
    /// ...and its largest extinction (the global majorant), m^-1 (`Segment::sigma_max`).
    pub medium_sigma_max: f32,
    /// `VolumeSampling` of the render: 0 distance, 1 equiangular, 2 mis (`VOLUME_SAMPLING_*`);
    /// distance where the scene has no point or spot light.
    pub volume_sampling: u32,
    /// The point and spot lights among the punctual ones (`Lights::positional`).
    pub positional_count: u32,
    /// Lamps inside media that medium events draw part of their directions towards
    /// (`Lamps::count`; 0: none).
    pub lamp_count: u32,
    /// The velocity blur of the VDB medium (a scene with one; the mixture's are in
    /// [`GpuVdbMedium::blur`]).
    pub blur: GpuVelocityBlur,
    /// The shutter and the camera's poses across it.
    pub motion: GpuCameraMotion,
    /// The phase function of each VDB medium, in `vdb_media` order (the variant with
    /// `FEATURE_PHASES` reads them; the others the Henyey-Greenstein `phase_g`).
    pub phases: [GpuPhase; GPU_MAX_VDB_MEDIA],
    /// The cells the emitting media are sampled from as lights (`MediaLights::cells`; 0:
    /// none, or `--media-lights off`), their table in `backend::gpu::media_lights`.
    pub media_light_cells: u32,
    /// The word of their table at which the light tree's nodes start.
    pub media_light_nodes: u32,
    /// Lamps inside media whose film points draw pixel jitter (`Glows::count`; 0: none).
    pub glow_count: u32,
    /// Placements the GPU keeps instancing with (`GpuPlacement`s; 0: the triangles are flat,
    /// in world space).
    pub placement_count: u32,
    /// Their film points in pixels (`Glows::centres`), two to a row: glow `k` in `xy` (even
    /// `k`) or `zw` (odd `k`) of row `k / 2`.
    pub glows: [[f32; 4]; 2],
    /// The positions of the `lamp_count` lamps, world space (`Lamps::positions`; `w` unused).
    pub lamps: [[f32; 4]; 4],
    /// Boxes of the media that emitting media light, which surface events draw part of their
    /// directions towards (`LitMedia::count`; 0: none).
    pub lit_count: u32,
    pub _lit_pad0: u32,
    pub _lit_pad1: u32,
    pub _lit_pad2: u32,
    /// Their world corners (`LitMedia::boxes`): box `k`'s lowest in row `2 k`, its highest in
    /// row `2 k + 1` (`w` unused).
    pub lit_boxes: [[f32; 4]; 8],
}
const _: () = assert!(
    size_of::<GpuWavefrontParams>()
        == 624
            + size_of::<GpuVelocityBlur>()
            + size_of::<GpuCameraMotion>()
            + GPU_MAX_VDB_MEDIA * size_of::<GpuPhase>()
);

/// [`GpuWavefrontParams::flags`] bit: medium events choose lights by contribution
/// (`Lights::guided`, `Lights::phase_selection`).
pub const WF_FLAG_GUIDED_LIGHTS: u32 = 4;
/// [`GpuWavefrontParams::flags`] bit: some medium absorbs (`FeatureFlags::absorption`,
/// the CPU's `ABS`): grey views and homogeneous parts of a mixture keep their `sigma_a`.
pub const WF_FLAG_ABSORPTION: u32 = 1;
/// [`GpuWavefrontParams::flags`] bit: spectral tracking forced on grey media.
pub const WF_FLAG_FORCE_SPECTRAL: u32 = 2;
/// [`GpuWavefrontParams::flags`] bit: a transparent film (`PathLimits::film_transparent`):
/// the environment a camera ray sees unscattered is left out of its radiance.
pub const WF_FLAG_FILM_TRANSPARENT: u32 = 8;
/// [`GpuWavefrontParams::volume_sampling`]: free-flight distances only, the equiangular
/// strategy alone, or both weighed by MIS (`VolumeSampling`).
pub const VOLUME_SAMPLING_DISTANCE: u32 = 0;
pub const VOLUME_SAMPLING_EQUIANGULAR: u32 = 1;
pub const VOLUME_SAMPLING_MIS: u32 = 2;
/// VDB media the GPU binds at most (the mixture variant walks up to this many majorant
/// streams per ray at once).
pub const GPU_MAX_VDB_MEDIA: usize = 8;

/// One VDB medium of the mixture variant (`integrator::media::VdbMedium` as every view of it
/// needs it): an entry of the `vdb_media` storage array. Its grids live in the shared grid
/// buffers ([`GpuGridInfo::cell_offset`]); its bounds from `bounds_base` in the bounds buffer,
/// laid out as one medium's bounds are (`global_bounds_index` relative to `bounds_base`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuVdbMedium {
    /// The density grid, `density_scale` = `sigma_t_bound`.
    pub grid: GpuGridInfo,
    /// The medium's own free-flight and shadow-ray tracking parameters (as
    /// `GpuWavefrontParams::tracking` is for a scene with one medium).
    pub tracking: GpuTrackingParams,
    /// Its emission (`has_grid`, `has_blackbody` and `strength_color` zero without).
    pub emission: GpuEmissionParams,
    /// World bounds of the density's support, minimum corner.
    pub lo: [f32; 3],
    /// Henyey-Greenstein `g`.
    pub phase_g: f32,
    /// World bounds, maximum corner.
    pub hi: [f32; 3],
    /// 1 when tracked spectrally on its own (chromatic, or spectral tracking forced).
    pub spectral: u32,
    /// `GreyView::scatter_albedo` (grey tracking) or `RgbView::scatter_albedo` (spectral).
    pub scatter_albedo: [f32; 3],
    /// The [`GpuEstimator`] of its shadow rays.
    pub shadow_estimator: u32,
    /// Per-channel `sigma_s / sigma_t` (`GpuWavefrontParams::albedo_rgb`).
    pub albedo_rgb: [f32; 3],
    /// `GreyView::sigma_a` per unit density (0 unless some medium absorbs).
    pub grey_sigma_a: f32,
    /// `RgbView::sigma_a` per unit density.
    pub rgb_sigma_a: [f32; 3],
    /// `GreyView::sigma_s` per unit density.
    pub grey_sigma_s: f32,
    /// `RgbView::sigma_s` per unit density.
    pub rgb_sigma_s: [f32; 3],
    /// First entry of the medium's bounds in the bounds buffer.
    pub bounds_base: u32,
    /// The medium's true `sigma_s` per unit density (the spectral mixture's choice of the
    /// medium that scattered).
    pub sigma_s: [f32; 3],
    /// `GreyView::control_albedo`.
    pub control_albedo: f32,
    /// 1 where its per-leaf and culled walks thin by its per-voxel bounds
    /// (`VdbMedium::voxel_culling`): its table is then in the per-voxel binding at its
    /// bricks' place (the bricks of every density grid lie at the start of the shared
    /// bricks buffer, in medium order).
    pub voxel_table: u32,
    /// As [`GpuWavefrontParams::shadow_majorant_mode`], for this medium.
    pub shadow_majorant_mode: u32,
    /// Its mean extinction per unit density (`mean(sigma_s + sigma_a)`) and its largest
    /// extinction (the global majorant), m^-1: the equiangular strategy's free-flight density
    /// and segment bound (`integrator::equiangular`).
    pub sigma_t_mean: f32,
    pub sigma_max: f32,
    /// Its velocity blur (`factor` 0: none).
    pub blur: GpuVelocityBlur,
}
const _: () =
    assert!(size_of::<GpuVdbMedium>() == 96 + 64 + 320 + 8 * 16 + size_of::<GpuVelocityBlur>());

/// Volume emission of the VDB medium (`integrator::media::Emission`), one uniform of a
/// wavefront render. The grids' headers point into the density grid's buffers
/// ([`GpuGridInfo::cell_offset`]); their `index_from_world` maps world points to each grid's
/// own index space (`GridField::index_from_world`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuEmissionParams {
    /// The emission grid that scales `strength_color` (`emissionGrid`, e.g. `flame`).
    pub grid: GpuGridInfo,
    /// The temperature grid of the blackbody term (`temperatureGrid`).
    pub temperature: GpuGridInfo,
    /// `emissionStrength * emissionColor`, radiance per metre (W m^-3 sr^-1), not multiplied
    /// by density.
    pub strength_color: [f32; 3],
    /// 1 when `grid` is present (else the grid factor is 1).
    pub has_grid: u32,
    /// `blackbodyTint` (RGB multiplier of the blackbody term).
    pub tint: [f32; 3],
    /// 1 when the blackbody term is present.
    pub has_blackbody: u32,
    /// Kelvin per unit of the temperature grid (`temperatureScale`).
    pub temperature_scale: f32,
    /// Kelvin added (`temperatureOffset`).
    pub temperature_offset: f32,
    /// `blackbodyIntensity` `I`: radiance `(sigma_SB 1e-6 / pi) ((1 - I) + I T^4) C(T)`.
    pub intensity: f32,
    /// The medium's light group (`VdbMedium::light_group`; `NO_GROUP` where none is kept):
    /// where the light-group variant gathers this emission.
    pub light_group: u32,
    /// Rows of the density grid's world -> index map, the space of the emission region
    /// (`integrator::media::EmissionRegion`).
    pub region_from_world: [[f32; 4]; 3],
    /// The region's box in that space (half-open); nothing is emitted outside it.
    pub region_min: [f32; 3],
    /// 1 when the region applies (else the emission is not confined).
    pub has_region: u32,
    pub region_max: [f32; 3],
    pub _pad1: u32,
}
const _: () = assert!(size_of::<GpuEmissionParams>() == 320);
