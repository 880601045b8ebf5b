/// One piece of a ray over which the extinction bounds are constant: the unit every tracking
/// estimator consumes, whether it comes from the global bound or from the per-leaf DDA.
/// Coefficients are per unit of the ray parameter `t` (per world unit for a unit-length world
/// direction).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MajorantSegment {
    pub t_min: f32,
    pub t_max: f32,
    /// Upper bound of `sigma_t` over the segment (before any majorant scale `b`).
    pub sigma_maj: f32,
    /// Lower bound of `sigma_t` over the segment (the control extinction of decomposition
    /// tracking is derived from it).
    pub sigma_min: f32,
}
