//! Tracking dispatch parameters and counters, and the enumerations they carry.
use bytemuck::{Pod, Zeroable};
use std::mem::size_of;

wgsl_enum! {
    /// Which tracking estimator a kernel runs; values of [`GpuTrackingParams::estimator`].
    pub enum GpuEstimator {
        /// `tracking::delta`.
        Delta = 0 => "ESTIMATOR_DELTA",
        /// `tracking::weighted_delta` with majorant scale `b`.
        WeightedDelta = 1 => "ESTIMATOR_WEIGHTED_DELTA",
        /// `tracking::decomposition`.
        Decomposition = 2 => "ESTIMATOR_DECOMPOSITION",
        /// `tracking::weighted_decomposition` with residual majorant scale `b`.
        WeightedDecomposition = 3 => "ESTIMATOR_WEIGHTED_DECOMPOSITION",
        /// `tracking::ratio` with majorant scale `b`.
        Ratio = 4 => "ESTIMATOR_RATIO",
        /// `tracking::residual_ratio` with residual majorant scale `b`.
        ResidualRatio = 5 => "ESTIMATOR_RESIDUAL_RATIO",
        /// `tracking::spectral` (RGB) with majorant scale `b`.
        Spectral = 6 => "ESTIMATOR_SPECTRAL",
    }
}

wgsl_enum! {
    /// Where the majorant segments come from; values of [`GpuTrackingParams::majorant_mode`].
    pub enum GpuMajorantMode {
        /// `DdaMajorantIterator::new`: one segment per cell of the leaf bounds.
        PerCell = 0 => "MAJORANT_PER_CELL",
        /// `DdaMajorantIterator::global`: one segment with the global bounds.
        Global = 1 => "MAJORANT_GLOBAL",
        /// `AdaptiveMajorantIterator`: one segment per merged node of the adaptive hierarchy.
        Adaptive = 2 => "MAJORANT_ADAPTIVE",
        /// `DdaMajorantIterator::global` with its tentative collisions culled by the leaf cells
        /// (`volume::cull::LeafCulling`, `tracking::sample_free_flight`).
        Culled = 3 => "MAJORANT_CULLED",
    }
}

wgsl_enum! {
    /// Mirror of [`ControlExtinction`](crate::volume::tracking::ControlExtinction)'s variants;
    /// values of [`GpuTrackingParams::control_mode`], the payload in `control_value`.
    pub enum GpuControlMode {
        None = 0 => "CONTROL_NONE",
        Constant = 1 => "CONTROL_CONSTANT",
        FractionOfBound = 2 => "CONTROL_FRACTION_OF_BOUND",
        SegmentMinorant = 3 => "CONTROL_SEGMENT_MINORANT",
        FractionOfBoundCapped = 4 => "CONTROL_FRACTION_OF_BOUND_CAPPED",
    }
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
