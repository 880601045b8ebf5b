//! The scene features a specialised CPU path is compiled for, as one type parameter: every
//! stage of the path tracer takes `F: Features` and reads the features as constants, so the
//! code for a feature the scene lacks is compiled out of its variant.

/// The scene features a specialised CPU path is compiled for (see
/// [`crate::render::prepare::FeatureFlags`]): each stage reads them as constants, so code a
/// scene does not call for is compiled out.
pub trait Features {
    /// Surfaces: rays are intersected with the scene's triangles.
    const SURF: bool;
    /// Heterogeneous (VDB) media.
    const HET: bool;
    /// Homogeneous media inside closed meshes.
    const HOM: bool;
    /// Emitting media.
    const EMIT: bool;
    /// Absorption events in media.
    const ABS: bool;
    /// Chromatic extinction (spectral tracking).
    const CHROM: bool;
    /// Overlapping or nested media, tracked as their mixture (`integrator::mixture`).
    const MIX: bool;
}

/// The bit of each feature in [`Variant`]'s `BITS`: the order of
/// [`FeatureFlags::as_array`](crate::render::prepare::FeatureFlags::as_array), the mixture
/// last, so the flags' bits index the table of variants (`tile::specialised`).
pub mod bit {
    pub const SURF: u8 = 1 << 0;
    pub const HET: u8 = 1 << 1;
    pub const HOM: u8 = 1 << 2;
    pub const EMIT: u8 = 1 << 3;
    pub const ABS: u8 = 1 << 4;
    pub const CHROM: u8 = 1 << 5;
    pub const MIX: u8 = 1 << 6;
}

/// The features whose [`bit`]s are set in `BITS`: one type per compiled variant.
pub struct Variant<const BITS: u8>;

impl<const BITS: u8> Features for Variant<BITS> {
    const SURF: bool = BITS & bit::SURF != 0;
    const HET: bool = BITS & bit::HET != 0;
    const HOM: bool = BITS & bit::HOM != 0;
    const EMIT: bool = BITS & bit::EMIT != 0;
    const ABS: bool = BITS & bit::ABS != 0;
    const CHROM: bool = BITS & bit::CHROM != 0;
    const MIX: bool = BITS & bit::MIX != 0;
}

/// Every feature, the mixture included: the generic variant, which renders any scene.
pub type AllFeatures = Variant<127>;

/// No feature: the views of shadow rays, which gather no emission.
pub type NoFeatures = Variant<0>;
