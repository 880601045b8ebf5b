//! The only home of the structs shared by the host and the WGSL shaders.
//!
//! Rust is the source of truth: every struct here is `#[repr(C)]` + `bytemuck::Pod`, built from
//! 16-byte rows (a `vec3` plus one scalar, a `vec4`, or four scalars) so that the WGSL layout
//! rules (`vec3` aligned to 16) add no hidden padding, with any padding named. The WGSL mirrors
//! live in `shaders/common/types.wgsl`; `tests/gpu_layout.rs` parses that file with naga and
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
    /// Padding to a 16-byte row.
    pub _pad0: u32,
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
    /// Padding to a 16-byte row.
    pub _pad0: u32,
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
        }
    }
}

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
/// and member names; `tests/gpu_layout.rs` checks them with naga's layouter.
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
            _pad0
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
            _pad0,
            _pad1,
            _pad2
        ]
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
            _pad0: 0,
        }
    }
}
