//! A tracking medium whose tentative collisions are culled by a finer bound, as the renderer's
//! views cull under the culled global walk (`VdbMedium::culling`, `volume::cull`).
use brume::volume::tracking::{self as tr, Coeffs, CoeffsRgb};
use brume::volume::MajorantSegment;

/// `inner` with `cull_ratio(t) = ratio(t)` (in `[0, 1]`; 1 culls nothing).
pub struct CulledBy<M, F> {
    pub inner: M,
    pub ratio: F,
}

impl<M: tr::Medium, F: Fn(f32) -> f32> tr::Medium for CulledBy<M, F> {
    fn coeffs(&self, t: f32) -> Coeffs {
        self.inner.coeffs(t)
    }

    fn control(&self, seg: &MajorantSegment) -> Coeffs {
        self.inner.control(seg)
    }

    fn cull_ratio(&self, t: f32) -> f32 {
        (self.ratio)(t)
    }
}

impl<M: tr::MediumRgb, F: Fn(f32) -> f32> tr::MediumRgb for CulledBy<M, F> {
    fn coeffs(&self, t: f32) -> CoeffsRgb {
        self.inner.coeffs(t)
    }

    fn cull_ratio(&self, t: f32) -> f32 {
        (self.ratio)(t)
    }
}
