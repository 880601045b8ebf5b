//! The only home of the structs shared by the host and the WGSL shaders.
//!
//! Rust is the source of truth: every struct here is `#[repr(C)]` + `bytemuck::Pod`, built from
//! 16-byte rows (a `vec3` plus one scalar, a `vec4`, or four scalars) so that the WGSL layout
//! rules (`vec3` aligned to 16) add no hidden padding, with any padding named. The WGSL mirrors
//! live in `shaders/common/types.wgsl`; `tests/gpu_wgsl.rs` parses that file with naga and
//! compares every struct's size and member offsets against [`SHARED_STRUCTS`].
//!
//! Enumerations shared with WGSL ([`GpuEstimator`], ...) are emitted as WGSL `const`s by
//! `backend::gpu::shader`, so their values are written once, here.
use bytemuck::{Pod, Zeroable};
use std::mem::{offset_of, size_of};

pub use crate::volume::CellBounds;

/// A [`SparseGrid`](crate::volume::SparseGrid) header: everything a shader needs besides the
/// flat `cells`, `bricks`, `constants` and per-cell bounds buffers.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuGridInfo {
    /// Cell counts `[nx, ny, nz]` of the dense cell index (leaf resolution, 8 voxels a cell).
    pub dims: [u32; 3],
    /// Number of 512-float bricks in the `bricks` buffer.
    pub brick_count: u32,
    /// Cell coordinate (voxel coordinate / 8, floored) of `cells[0]`.
    pub cell_origin: [i32; 3],
    /// Number of entries in the `constants` buffer (entry 0 is the background).
    pub constant_count: u32,
    /// Rows of the 3x4 affine map from world space to index space (voxel centres at integer
    /// points): `index = (dot(row0, (w, 1)), dot(row1, (w, 1)), dot(row2, (w, 1)))`.
    pub index_from_world: [[f32; 4]; 3],
    /// Value outside the cell box.
    pub background: f32,
    /// Extinction per unit of grid value: `sigma_t = density_scale * value` (per unit `t`
    /// of an index-space ray).
    pub density_scale: f32,
    /// Index of the global [`CellBounds`] in the bounds buffer: it follows the per-cell
    /// bounds, so this equals the cell count.
    pub global_bounds_index: u32,
    /// First entry of this grid in the cells buffer: 0 for the density grid; the emission
    /// grids of a wavefront render follow it in the same buffers (their brick and constant
    /// indices already offset), so one set of bindings serves every grid.
    pub cell_offset: u32,
}
const _: () = assert!(size_of::<GpuGridInfo>() == 96);

/// A ray `o + t d` with its parameter interval (index space for the tracking kernels).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuRay {
    /// Origin.
    pub o: [f32; 3],
    /// Start of the parameter interval.
    pub t_min: f32,
    /// Direction (not necessarily unit length; `t` is measured in its units).
    pub d: [f32; 3],
    /// End of the parameter interval (may be `f32::INFINITY`).
    pub t_max: f32,
}
const _: () = assert!(size_of::<GpuRay>() == 32);

/// Mirror of [`MajorantSegment`](crate::volume::MajorantSegment).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuMajorantSegment {
    /// Start of the segment (ray parameter).
    pub t_min: f32,
    /// End of the segment (ray parameter).
    pub t_max: f32,
    /// Upper bound of `sigma_t` over the segment, per unit `t`.
    pub sigma_maj: f32,
    /// Lower bound of `sigma_t` over the segment, per unit `t`.
    pub sigma_min: f32,
}
const _: () = assert!(size_of::<GpuMajorantSegment>() == 16);

impl From<crate::volume::MajorantSegment> for GpuMajorantSegment {
    fn from(s: crate::volume::MajorantSegment) -> Self {
        GpuMajorantSegment {
            t_min: s.t_min,
            t_max: s.t_max,
            sigma_maj: s.sigma_maj,
            sigma_min: s.sigma_min,
        }
    }
}

/// Which tracking estimator a kernel runs; values of [`GpuTrackingParams::estimator`].
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GpuEstimator {
    /// `tracking::delta`.
    Delta = 0,
    /// `tracking::weighted_delta` with majorant scale `b`.
    WeightedDelta = 1,
    /// `tracking::decomposition`.
    Decomposition = 2,
    /// `tracking::weighted_decomposition` with residual majorant scale `b`.
    WeightedDecomposition = 3,
    /// `tracking::ratio` with majorant scale `b`.
    Ratio = 4,
    /// `tracking::residual_ratio` with residual majorant scale `b`.
    ResidualRatio = 5,
    /// `tracking::spectral` (RGB) with majorant scale `b`.
    Spectral = 6,
}

impl GpuEstimator {
    pub const ALL: [GpuEstimator; 7] = [
        GpuEstimator::Delta,
        GpuEstimator::WeightedDelta,
        GpuEstimator::Decomposition,
        GpuEstimator::WeightedDecomposition,
        GpuEstimator::Ratio,
        GpuEstimator::ResidualRatio,
        GpuEstimator::Spectral,
    ];

    /// The WGSL constant name (`ESTIMATOR_DELTA`, ...).
    pub fn wgsl_name(self) -> &'static str {
        match self {
            GpuEstimator::Delta => "ESTIMATOR_DELTA",
            GpuEstimator::WeightedDelta => "ESTIMATOR_WEIGHTED_DELTA",
            GpuEstimator::Decomposition => "ESTIMATOR_DECOMPOSITION",
            GpuEstimator::WeightedDecomposition => "ESTIMATOR_WEIGHTED_DECOMPOSITION",
            GpuEstimator::Ratio => "ESTIMATOR_RATIO",
            GpuEstimator::ResidualRatio => "ESTIMATOR_RESIDUAL_RATIO",
            GpuEstimator::Spectral => "ESTIMATOR_SPECTRAL",
        }
    }
}

/// Where the majorant segments come from; values of [`GpuTrackingParams::majorant_mode`].
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GpuMajorantMode {
    /// `DdaMajorantIterator::new`: one segment per cell of the leaf bounds.
    PerCell = 0,
    /// `DdaMajorantIterator::global`: one segment with the global bounds.
    Global = 1,
    /// `AdaptiveMajorantIterator`: one segment per merged node of the adaptive hierarchy.
    Adaptive = 2,
}

/// Mirror of [`ControlExtinction`](crate::volume::tracking::ControlExtinction)'s variants;
/// values of [`GpuTrackingParams::control_mode`], the payload in `control_value`.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GpuControlMode {
    None = 0,
    Constant = 1,
    FractionOfBound = 2,
    SegmentMinorant = 3,
    FractionOfBoundCapped = 4,
}

impl GpuControlMode {
    /// The mode and its payload for a CPU control policy.
    pub fn from_control(c: crate::volume::tracking::ControlExtinction) -> (GpuControlMode, f32) {
        use crate::volume::tracking::ControlExtinction as C;
        match c {
            C::None => (GpuControlMode::None, 0.0),
            C::Constant(v) => (GpuControlMode::Constant, v),
            C::FractionOfBound(m) => (GpuControlMode::FractionOfBound, m),
            C::SegmentMinorant => (GpuControlMode::SegmentMinorant, 0.0),
            C::FractionOfBoundCapped(m) => (GpuControlMode::FractionOfBoundCapped, m),
        }
    }
}

/// Parameters of one tracking dispatch: the estimator, its knobs and the medium's optics.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTrackingParams {
    /// A [`GpuEstimator`] value.
    pub estimator: u32,
    /// A [`GpuMajorantMode`] value.
    pub majorant_mode: u32,
    /// A [`GpuControlMode`] value (decomposition and residual ratio tracking).
    pub control_mode: u32,
    /// Spectral probabilities: 0 = history-aware max, 1 = history-aware average.
    pub spectral_mode: u32,
    /// Majorant scale `b` (weighted delta, weighted decomposition, ratio, residual ratio,
    /// spectral); dimensionless.
    pub b: f32,
    /// Payload of `control_mode`: the constant `sigma_c` (per unit `t`) or the fraction `m`.
    pub control_value: f32,
    /// Single-scattering albedo of the medium, `sigma_s / sigma_t`.
    pub albedo: f32,
    /// Albedo used to split the control extinction into absorption and scattering.
    pub control_albedo: f32,
    /// Per-channel extinction multipliers of the spectral (RGB) medium:
    /// `sigma_t,c = channel_scale[c] * density_scale * value`; the majorant is scaled by the
    /// largest channel (given in `majorant_channel_scale`).
    pub channel_scale: [f32; 3],
    /// Seed of the RNG streams (`Rng::new(pixel, sample, seed)`).
    pub seed: u32,
    /// Factor applied to the DDA's density scale for the majorant (1 for grey media, the
    /// largest `channel_scale` for spectral tracking).
    pub majorant_channel_scale: f32,
    /// Samples per ray: invocation `i` estimates ray `i / samples_per_ray` with the stream
    /// `Rng::new(i, 0, seed)`.
    pub samples_per_ray: u32,
    /// Total number of invocations with work (`rays * samples_per_ray`).
    pub invocation_count: u32,
    /// Padding to a 16-byte row.
    pub _pad0: u32,
}
const _: () = assert!(size_of::<GpuTrackingParams>() == 64);

/// Counters a tracking kernel accumulates with atomics (the WGSL mirror declares each member
/// `atomic<u32>`); the meaning of each is that of
/// [`TrackingStats`](crate::volume::tracking::TrackingStats).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTrackingStats {
    /// Density lookups.
    pub lookups: u32,
    /// Null (fictitious) tentative collisions.
    pub null_collisions: u32,
    /// Real collisions decided from a lookup.
    pub real_collisions: u32,
    /// Collisions with the lookup-free control component.
    pub control_collisions: u32,
    /// Lookups where an analog tracker found the majorant did not bound.
    pub majorant_violations: u32,
    /// Segments skipped for a negative, NaN or infinite majorant.
    pub invalid_majorants: u32,
    /// Free flights stopped by `MAX_TENTATIVE_COLLISIONS`.
    pub collision_cap_hits: u32,
    /// Paths ended by Russian roulette.
    pub roulette_kills: u32,
    /// Bits of the largest `|weight|` seen (an `f32`; non-negative floats order like their
    /// bits, so `atomicMax` on the bits is a float max).
    pub max_abs_weight_bits: u32,
    /// Majorant segments walked.
    pub segments: u32,
    /// Padding to a 16-byte row.
    pub _pad1: u32,
    /// Padding to a 16-byte row.
    pub _pad2: u32,
}
const _: () = assert!(size_of::<GpuTrackingStats>() == 48);

impl GpuTrackingStats {
    /// The counters as the CPU's [`TrackingStats`](crate::volume::tracking::TrackingStats).
    pub fn to_cpu(&self) -> crate::volume::tracking::TrackingStats {
        crate::volume::tracking::TrackingStats {
            lookups: self.lookups as u64,
            null_collisions: self.null_collisions as u64,
            real_collisions: self.real_collisions as u64,
            control_collisions: self.control_collisions as u64,
            majorant_violations: self.majorant_violations as u64,
            invalid_majorants: self.invalid_majorants as u64,
            collision_cap_hits: self.collision_cap_hits as u64,
            roulette_kills: self.roulette_kills as u64,
            max_abs_weight: f32::from_bits(self.max_abs_weight_bits),
            segments: self.segments as u64,
        }
    }
}

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
    /// Padding to a 16-byte row.
    pub _pad0: u32,
    /// Padding to a 16-byte row.
    pub _pad1: u32,
}
const _: () = assert!(size_of::<GpuPathState>() == 112);

/// [`GpuPathState::flags`] bit: the last direction was chosen by a delta distribution (the
/// camera, a smooth dielectric), so no MIS applies when it meets an emitter.
pub const PATH_FLAG_SPECULAR: u32 = 1;
/// [`GpuPathState::flags`] bit: the path stopped at an opaque surface (its hit fields
/// describe it) and the next direction is to be sampled from the BSDF, not the phase function.
pub const PATH_FLAG_SURFACE: u32 = 2;
/// [`GpuPathState::flags`] bit: the free flight of the current bounce has drawn its sampler
/// point (`radiance`'s `flight_started`); cleared at every scattering event.
pub const PATH_FLAG_FLIGHT_STARTED: u32 = 4;

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
    /// Padding to a 16-byte row.
    pub _pad1: f32,
}
const _: () = assert!(size_of::<GpuShadowRay>() == 48);

/// One triangle as the GPU's ray queries and shading read it, in the BVH's primitive order
/// (`CwBvh::primitive_indices`): entry `k` is scene triangle `triangle`. Positions and normals
/// are the scene's world-space vertices; the material's surface kind and interior medium are
/// copied in so that shadow rays need no material lookup.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTriangle {
    /// First corner, world space, metres.
    pub p0: [f32; 3],
    /// Index into `Scene::triangles`.
    pub triangle: u32,
    /// Second corner.
    pub p1: [f32; 3],
    /// Index into `Scene::materials`.
    pub material: u32,
    /// Third corner.
    pub p2: [f32; 3],
    /// `AreaLights` selection density of this triangle, `area * luminance / total` divided by
    /// its area, i.e. `luminance / total` (0 when it is not an area light).
    pub light_pdf: f32,
    /// Shading normal at the first corner (all zero when the file gives none).
    pub n0: [f32; 3],
    /// `SURFACE_*` kind of the material (`prepare::SurfaceKind`).
    pub kind: u32,
    /// Shading normal at the second corner.
    pub n1: [f32; 3],
    /// `Material::interior_medium` (`NO_INDEX`: none).
    pub interior: u32,
    /// Shading normal at the third corner.
    pub n2: [f32; 3],
    /// Padding to a 16-byte row.
    pub _pad0: u32,
}
const _: () = assert!(size_of::<GpuTriangle>() == 96);

/// One entry of the area lights' selection CDF (`AreaLights::cdf`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuAreaLight {
    /// Cumulative `area * luminance / total` up to and including this light.
    pub cdf: f32,
    /// Its slot in the [`GpuTriangle`] buffer.
    pub prim: u32,
}
const _: () = assert!(size_of::<GpuAreaLight>() == 8);

/// A homogeneous medium (`integrator::media::HomogeneousMedium`), coefficients in m^-1.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuHomogeneousMedium {
    /// Absorption coefficient per RGB channel, m^-1.
    pub sigma_a: [f32; 3],
    /// Henyey-Greenstein `g`.
    pub g: f32,
    /// Scattering coefficient per RGB channel, m^-1.
    pub sigma_s: [f32; 3],
    /// Padding to a 16-byte row.
    pub _pad0: f32,
}
const _: () = assert!(size_of::<GpuHomogeneousMedium>() == 32);

/// `SurfaceKind` values of [`GpuTriangle::kind`].
pub const SURFACE_OPAQUE: u32 = 0;
pub const SURFACE_DIELECTRIC: u32 = 1;
pub const SURFACE_NULL: u32 = 2;

/// obvhs' `CwBvhNode` (80 bytes, uploaded as is) as the WGSL struct `CwBvhNode` sees it:
/// the three exponent bytes and `imask` read as one `e_imask` word, each 8-byte array as a
/// `vec2<u32>`.
pub const CWBVH_NODE_LAYOUT: StructLayout = {
    use obvhs::cwbvh::node::CwBvhNode as N;
    StructLayout {
        name: "CwBvhNode",
        size: size_of::<N>(),
        members: &[
            ("p", offset_of!(N, p)),
            ("e_imask", offset_of!(N, e)),
            ("child_base_idx", offset_of!(N, child_base_idx)),
            ("primitive_base_idx", offset_of!(N, primitive_base_idx)),
            ("child_meta", offset_of!(N, child_meta)),
            ("child_min_x", offset_of!(N, child_min_x)),
            ("child_max_x", offset_of!(N, child_max_x)),
            ("child_min_y", offset_of!(N, child_min_y)),
            ("child_max_y", offset_of!(N, child_max_y)),
            ("child_min_z", offset_of!(N, child_min_z)),
            ("child_max_z", offset_of!(N, child_max_z)),
        ],
    }
};
const _: () = assert!(offset_of!(obvhs::cwbvh::node::CwBvhNode, imask) == 15);

/// The work queues of the wavefront integrator; `GpuWavefrontCounters::queue_count` index.
/// Each queue holds path slot indices. The medium and done queues are double-buffered by
/// iteration parity (`GpuWavefrontParams::parity`): a stage reads `X0 + parity` and appends
/// to `X0 + 1 - parity` what the next iteration consumes.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GpuQueue {
    /// Paths whose current ray must be tracked through the media (parity 0).
    Medium0 = 0,
    /// The same, parity 1.
    Medium1 = 1,
    /// Finished paths (accumulated, then regenerated next iteration), parity 0.
    Done0 = 2,
    /// The same, parity 1.
    Done1 = 3,
    /// Paths that scattered in a medium (next-event estimation pending).
    Scatter = 4,
    /// Paths with a shadow ray to trace.
    Shadow = 5,
    /// Paths whose next direction is to be sampled from the phase function.
    Phase = 6,
    /// Paths whose ray left the scene.
    Escape = 7,
    /// Paths whose ray reached the surface it hits (no medium event before it).
    Surface = 8,
}

impl GpuQueue {
    pub const COUNT: usize = 9;
    pub const ALL: [GpuQueue; 9] = [
        GpuQueue::Medium0,
        GpuQueue::Medium1,
        GpuQueue::Done0,
        GpuQueue::Done1,
        GpuQueue::Scatter,
        GpuQueue::Shadow,
        GpuQueue::Phase,
        GpuQueue::Escape,
        GpuQueue::Surface,
    ];

    /// The WGSL constant name (`QUEUE_MEDIUM0`, ...).
    pub fn wgsl_name(self) -> &'static str {
        match self {
            GpuQueue::Medium0 => "QUEUE_MEDIUM0",
            GpuQueue::Medium1 => "QUEUE_MEDIUM1",
            GpuQueue::Done0 => "QUEUE_DONE0",
            GpuQueue::Done1 => "QUEUE_DONE1",
            GpuQueue::Scatter => "QUEUE_SCATTER",
            GpuQueue::Shadow => "QUEUE_SHADOW",
            GpuQueue::Phase => "QUEUE_PHASE",
            GpuQueue::Escape => "QUEUE_ESCAPE",
            GpuQueue::Surface => "QUEUE_SURFACE",
        }
    }
}

/// 64-bit counters of [`GpuWavefrontCounters::wide`]: pair `2k` (low word), `2k + 1` (high).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GpuWideCounter {
    Lookups = 0,
    NullCollisions = 1,
    RealCollisions = 2,
    ControlCollisions = 3,
    ShadowLookups = 4,
    DepthSum = 5,
    /// Emission and temperature grid reads (`MediaStats::emission_lookups`).
    EmissionLookups = 6,
    /// Majorant segments walked (`TrackingStats::segments`).
    Segments = 7,
    /// Majorant segments walked by shadow rays (`MediaStats::shadow_segments`).
    ShadowSegments = 8,
}

impl GpuWideCounter {
    pub const ALL: [GpuWideCounter; 9] = [
        GpuWideCounter::Lookups,
        GpuWideCounter::NullCollisions,
        GpuWideCounter::RealCollisions,
        GpuWideCounter::ControlCollisions,
        GpuWideCounter::ShadowLookups,
        GpuWideCounter::DepthSum,
        GpuWideCounter::EmissionLookups,
        GpuWideCounter::Segments,
        GpuWideCounter::ShadowSegments,
    ];

    pub fn wgsl_name(self) -> &'static str {
        match self {
            GpuWideCounter::Lookups => "WIDE_LOOKUPS",
            GpuWideCounter::NullCollisions => "WIDE_NULL_COLLISIONS",
            GpuWideCounter::RealCollisions => "WIDE_REAL_COLLISIONS",
            GpuWideCounter::ControlCollisions => "WIDE_CONTROL_COLLISIONS",
            GpuWideCounter::ShadowLookups => "WIDE_SHADOW_LOOKUPS",
            GpuWideCounter::DepthSum => "WIDE_DEPTH_SUM",
            GpuWideCounter::EmissionLookups => "WIDE_EMISSION_LOOKUPS",
            GpuWideCounter::Segments => "WIDE_SEGMENTS",
            GpuWideCounter::ShadowSegments => "WIDE_SHADOW_SEGMENTS",
        }
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
    /// Padding to a 16-byte row.
    pub _pad0: u32,
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
}
const _: () = assert!(size_of::<GpuWavefrontParams>() == 288);

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
    /// Padding to a 16-byte row.
    pub _pad0: u32,
}
const _: () = assert!(size_of::<GpuEmissionParams>() == 240);

/// The Rust layout of one shared struct: its WGSL name, size and `(member, offset)` list.
pub struct StructLayout {
    pub name: &'static str,
    pub size: usize,
    pub members: &'static [(&'static str, usize)],
}

macro_rules! layout {
    ($t:ty, $wgsl:literal, [$($f:ident),* $(,)?]) => {
        StructLayout {
            name: $wgsl,
            size: size_of::<$t>(),
            members: &[$((stringify!($f), offset_of!($t, $f))),*],
        }
    };
}

/// Every host/WGSL shared struct, as Rust lays it out. The WGSL structs carry the same names
/// and member names; `tests/gpu_wgsl.rs` checks them with naga's layouter.
pub const SHARED_STRUCTS: &[StructLayout] = &[
    layout!(
        GpuGridInfo,
        "GpuGridInfo",
        [
            dims,
            brick_count,
            cell_origin,
            constant_count,
            index_from_world,
            background,
            density_scale,
            global_bounds_index,
            cell_offset
        ]
    ),
    layout!(GpuRay, "GpuRay", [o, t_min, d, t_max]),
    layout!(
        GpuMajorantSegment,
        "GpuMajorantSegment",
        [t_min, t_max, sigma_maj, sigma_min]
    ),
    layout!(CellBounds, "CellBounds", [min, max]),
    layout!(
        GpuTrackingParams,
        "GpuTrackingParams",
        [
            estimator,
            majorant_mode,
            control_mode,
            spectral_mode,
            b,
            control_value,
            albedo,
            control_albedo,
            channel_scale,
            seed,
            majorant_channel_scale,
            samples_per_ray,
            invocation_count,
            _pad0
        ]
    ),
    layout!(
        GpuTrackingStats,
        "GpuTrackingStats",
        [
            lookups,
            null_collisions,
            real_collisions,
            control_collisions,
            majorant_violations,
            invalid_majorants,
            collision_cap_hits,
            roulette_kills,
            max_abs_weight_bits,
            segments,
            _pad1,
            _pad2
        ]
    ),
    layout!(
        GpuPathState,
        "GpuPathState",
        [
            o, t0, d, prev_pdf, beta, sample_id, l, depth, rng_state, rng_inc, flags, collisions,
            lookups, medium, hit_prim, hit_t, hit_b1, hit_b2, _pad0, _pad1
        ]
    ),
    layout!(
        GpuShadowRay,
        "GpuShadowRay",
        [o, dist, wi, medium, contribution, _pad1]
    ),
    layout!(
        GpuTriangle,
        "GpuTriangle",
        [p0, triangle, p1, material, p2, light_pdf, n0, kind, n1, interior, n2, _pad0]
    ),
    layout!(GpuAreaLight, "GpuAreaLight", [cdf, prim]),
    layout!(
        GpuHomogeneousMedium,
        "GpuHomogeneousMedium",
        [sigma_a, g, sigma_s, _pad0]
    ),
    CWBVH_NODE_LAYOUT,
    layout!(
        crate::scene::Material,
        "Material",
        [
            base_color,
            emission,
            metallic,
            roughness,
            transmission,
            ior,
            base_color_texture,
            interior_medium,
            emissive_texture,
            flags,
            _pad
        ]
    ),
    layout!(
        GpuWavefrontCounters,
        "GpuWavefrontCounters",
        [
            queue_count,
            next_sample,
            live,
            guard_fired,
            majorant_violations,
            invalid_majorants,
            collision_cap_hits,
            _pad0,
            wide,
            _pad1,
            _pad2
        ]
    ),
    layout!(
        GpuWavefrontParams,
        "GpuWavefrontParams",
        [
            camera,
            tan_half,
            aspect,
            znear,
            seed,
            forward,
            width,
            height,
            pixel0,
            s0,
            spp_batch,
            total_samples,
            path_count,
            light_count,
            parity,
            env,
            env_pdf,
            max_depth,
            rr_depth,
            max_collisions,
            has_env,
            medium_lo,
            phase_g,
            medium_hi,
            has_medium,
            scatter_albedo,
            spectral,
            albedo_rgb,
            shadow_estimator,
            tracking,
            camera_medium,
            area_count,
            rr_throughput,
            absorption_weight
        ]
    ),
    layout!(
        GpuEmissionParams,
        "GpuEmissionParams",
        [
            grid,
            temperature,
            strength_color,
            has_grid,
            tint,
            has_blackbody,
            temperature_scale,
            temperature_offset,
            intensity,
            _pad0
        ]
    ),
    layout!(
        crate::scene::PunctualLight,
        "PunctualLight",
        [position, kind, direction, range, intensity, cos_inner, cos_outer, _pad]
    ),
];

impl GpuGridInfo {
    /// The header of `grid` with `sigma_t = density_scale * value`.
    pub fn new(grid: &crate::volume::SparseGrid, density_scale: f32) -> GpuGridInfo {
        let m = grid.index_from_world;
        let (a, t) = (m.matrix3, m.translation);
        let row = |r: usize| {
            [
                a.col(0)[r] as f32,
                a.col(1)[r] as f32,
                a.col(2)[r] as f32,
                t[r] as f32,
            ]
        };
        GpuGridInfo {
            dims: grid.dims,
            brick_count: grid.brick_count() as u32,
            cell_origin: grid.cell_origin,
            constant_count: grid.constants.len() as u32,
            index_from_world: [row(0), row(1), row(2)],
            background: grid.background,
            density_scale,
            global_bounds_index: grid.cells.len() as u32,
            cell_offset: 0,
        }
    }
}
