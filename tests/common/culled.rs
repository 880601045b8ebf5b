//! A tracking medium whose tentative collisions are culled by a finer bound, as the renderer's
//! views cull under the culled global walk (`VdbMedium::culling`, `volume::cull`).
use brume::volume::tracking::{self as tr, Coeffs, CoeffsRgb};
use brume::volume::MajorantSegment;

/// `inner` with `cull_ratio(t) = ratio(t)` (in `[0, 1]`; 1 culls nothing) and
/// `voxel_ratio(t, _, bound) = voxel(t, bound)`, the second stage (`volume::cull::VoxelCulling`).
pub struct CulledBy<M, F, V = fn(f32, f32) -> f32> {
    pub inner: M,
    pub ratio: F,
    pub voxel: V,
}

/// No second stage.
pub fn no_voxel(_t: f32, _bound: f32) -> f32 {
    1.0
}

impl<M: tr::Medium, F: Fn(f32) -> f32, V: Fn(f32, f32) -> f32> tr::Medium for CulledBy<M, F, V> {
    fn coeffs(&self, t: f32) -> Coeffs {
        self.inner.coeffs(t)
    }

    fn control(&self, seg: &MajorantSegment) -> Coeffs {
        self.inner.control(seg)
    }

    fn cull_ratio(&self, t: f32) -> f32 {
        (self.ratio)(t)
    }

    fn voxel_ratio(&self, t: f32, _seg: &MajorantSegment, bound: f32) -> f32 {
        (self.voxel)(t, bound)
    }
}

impl<M: tr::MediumRgb, F: Fn(f32) -> f32, V> tr::MediumRgb for CulledBy<M, F, V> {
    fn coeffs(&self, t: f32) -> CoeffsRgb {
        self.inner.coeffs(t)
    }

    fn cull_ratio(&self, t: f32) -> f32 {
        (self.ratio)(t)
    }
}
