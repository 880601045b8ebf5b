//! A VDB medium as the trackers see it along one ray: the grey view (`sigma_t` equal in
//! every channel) and the RGB view (spectral tracking), each in the medium's index space with
//! its coefficients, its emission accumulator and its culling ([`crate::volume::tracking::Medium`],
//! [`MediumRgb`]). Every VDB flight of `integrator::media`, `mixture` and `nested` builds one
//! per medium and ray; the WGSL mirror is the tracker state of `shaders/common/tracking.wgsl`
//! and the emission of `shaders/common/emission.wgsl`.
use std::cell::Cell;
use std::marker::PhantomData;

use glam::Vec3;

use super::features::Features;
use crate::math::{per_channel_ratio, Ray};
use crate::render::media::{TrackingConfig, VdbMedium, VelocityBlur};
use crate::render::media_lights::MediaLights;
use crate::render::settings::{Absorption, MajorantMode};
use crate::volume::tracking::{Coeffs, CoeffsRgb, ControlExtinction, Medium, MediumRgb};
use crate::volume::{LeafCulling, VoxelCulling};

/// What the MIS weight of a flight's emission against the media lights needs
/// (`render::media_lights`): the lights, and the pdf of the direction the ray left its last
/// scattering event by (the ray's origin).
#[derive(Clone, Copy)]
pub struct EmissionMis<'f> {
    pub lights: &'f MediaLights,
    pub pdf_dir: f32,
}

/// The grey view of a VDB medium along one ray (`sigma_t` equal in all channels; the RGB
/// albedo is applied as a weight at scattering events). It gathers emission if `F::EMIT`;
/// `ABS` is whether it has an absorption coefficient, chosen per flight by the settings.
pub(super) struct GreyView<'a, F: Features, const ABS: bool> {
    pub(super) m: &'a VdbMedium,
    pub(super) ray_i: Ray,
    pub(super) ray_w: Ray,
    /// Grey coefficients per unit density: `sigma_s` is the channel mean (absorption as an
    /// event) or `sigma_t` (absorption as a weight: no absorption events).
    pub(super) sigma_a: f32,
    pub(super) sigma_s: f32,
    pub(super) control: ControlExtinction,
    pub(super) control_albedo: f32,
    /// Path throughput when the flight started (emission is weighted by it).
    pub(super) beta: Vec3,
    pub(super) emitted: Cell<Vec3>,
    pub(super) emission_lookups: Cell<u64>,
    /// The per-leaf culling of the culled global walk ([`VdbMedium::culling`]).
    pub(super) culling: Option<LeafCulling<'a>>,
    /// The per-voxel culling of the walk's kept collisions ([`VdbMedium::voxel_culling`]).
    pub(super) voxel: Option<VoxelCulling<'a>>,
    pub(super) blur: Blur<'a>,
    /// The MIS weight of its emission against the media lights, after a scattering event.
    pub(super) mis: Option<EmissionMis<'a>>,
    features: PhantomData<F>,
}

/// A view's velocity blur: the medium's and the sample's time offset, where the medium is
/// blurred and the time is not the frame's.
#[derive(Clone, Copy)]
pub(super) struct Blur<'a>(Option<(&'a VelocityBlur, f32)>);

impl<'a> Blur<'a> {
    fn of(m: &'a VdbMedium, time: f32) -> Self {
        Blur(m.blur.as_deref().filter(|_| time != 0.0).map(|b| (b, time)))
    }

    /// The index point a lookup at `ray_i(t)` reads.
    #[inline(always)]
    fn index_point(&self, ray_i: &Ray, t: f32) -> Vec3 {
        match self.0 {
            None => ray_i.at(t),
            Some((b, dt)) => b.source(ray_i.at(t), dt),
        }
    }

    /// The world point an emission lookup at `ray_w(t)` (`ray_i(t)` in index space) reads.
    #[inline(always)]
    fn world_point(&self, ray_w: &Ray, ray_i: &Ray, t: f32) -> Vec3 {
        match self.0 {
            None => ray_w.at(t),
            Some((b, dt)) => b.source_world(ray_i.at(t), dt),
        }
    }
}

impl<'a, F: Features, const ABS: bool> GreyView<'a, F, ABS> {
    pub(super) fn new(m: &'a VdbMedium, ray_w: &Ray, cfg: &TrackingConfig, beta: Vec3) -> Self {
        let ray_w = &m.rest_ray(ray_w, cfg.time);
        let ray_i = Ray::new(
            m.density.index_from_world.transform_point3(ray_w.o),
            m.density.index_from_world.transform_vector3(ray_w.d),
        );
        let sigma_t = m.sigma_t_bound;
        // Absorption as a weight: the trackers see a purely scattering medium with the same
        // sigma_t (every real collision scatters); `scatter_albedo` then applies the RGB
        // albedo sigma_s / sigma_t. As an event: the grey sigma_s is the channel mean.
        let sigma_s = match cfg.absorption {
            Absorption::Weight => sigma_t,
            Absorption::Event => (m.sigma_s.x + m.sigma_s.y + m.sigma_s.z) / 3.0,
        };
        GreyView {
            m,
            ray_i,
            ray_w: *ray_w,
            sigma_a: if ABS {
                (sigma_t - sigma_s).max(0.0)
            } else {
                0.0
            },
            sigma_s,
            control: cfg.control(),
            control_albedo: if sigma_t > 0.0 {
                sigma_s / sigma_t
            } else {
                0.0
            },
            beta,
            emitted: Cell::new(Vec3::ZERO),
            emission_lookups: Cell::new(0),
            culling: m.culling(cfg.majorant),
            voxel: m.voxel_culling(cfg.majorant),
            blur: Blur::of(m, cfg.time),
            mis: None,
            features: PhantomData,
        }
    }

    /// The view with its emission weighed by `mis` (`render::media_lights`).
    pub(super) fn with_mis(mut self, mis: Option<EmissionMis<'a>>) -> Self {
        self.mis = mis;
        self
    }

    /// The density the trackers read at `ray(t)` (the medium's motion and blur included).
    pub(super) fn density_at(&self, t: f32) -> f32 {
        self.m
            .density
            .at_index(self.blur.index_point(&self.ray_i, t))
    }

    /// RGB factor of a scattering event chosen with the grey `sigma_s`.
    pub(super) fn scatter_albedo(&self) -> Vec3 {
        if self.sigma_s > 0.0 {
            self.m.sigma_s / self.sigma_s
        } else {
            Vec3::ZERO
        }
    }
}

impl<F: Features, const ABS: bool> Medium for GreyView<'_, F, ABS> {
    #[inline]
    fn coeffs(&self, t: f32) -> Coeffs {
        let d = self
            .m
            .density
            .at_index(self.blur.index_point(&self.ray_i, t));
        Coeffs {
            sigma_a: if ABS { self.sigma_a * d } else { 0.0 },
            sigma_s: self.sigma_s * d,
        }
    }

    #[inline]
    fn control(&self, seg: &crate::volume::MajorantSegment) -> Coeffs {
        Coeffs::from_sigma_t(self.control.sigma_c(seg), self.control_albedo)
    }

    #[inline]
    fn cull_ratio(&self, t: f32) -> f32 {
        cull_ratio(self.culling.as_ref(), &self.ray_i, t)
    }

    #[inline]
    fn voxel_ratio(&self, t: f32, _seg: &crate::volume::MajorantSegment, bound: f32) -> f32 {
        voxel_ratio(self.voxel.as_ref(), &self.ray_i, t, bound)
    }

    #[inline]
    fn on_collision(&self, t: f32, sigma_maj: f32, w: f32) {
        if F::EMIT {
            if let Some(e) = &self.m.emission {
                let p = self.blur.world_point(&self.ray_w, &self.ray_i, t);
                let le = e.radiance(p, &self.emission_lookups);
                let w = w * emission_weight(self.m, self.mis, &self.ray_i, self.ray_w.o, t, le);
                self.emitted
                    .set(self.emitted.get() + self.beta * (w / sigma_maj) * le);
            }
        }
    }
}

/// The MIS weight of emission `le` met at `ray_i(t)` in medium `m` against the media lights
/// (`MediaLights::collision_weight`; the ray leaves its last event at `t = 0`, and `m` is
/// sampled as a light only where it stands still, so `t` is the distance from it, the world
/// point `x`): 1 without MIS or where `m` is not sampled.
#[inline(always)]
fn emission_weight(
    m: &VdbMedium,
    mis: Option<EmissionMis>,
    ray_i: &Ray,
    x: Vec3,
    t: f32,
    le: Vec3,
) -> f32 {
    match (mis, m.emitter) {
        (Some(mis), Some(slot)) if le != Vec3::ZERO => {
            mis.lights
                .collision_weight(slot, ray_i.at(t), x, t, mis.pdf_dir)
        }
        _ => 1.0,
    }
}

/// `Medium::cull_ratio` of a view: the culling's ratio at the index-space point `ray_i(t)` (the
/// point its lookup reads), 1 without culling.
///
/// Only the test for no culling is inlined. As `Option::map_or` the whole of it was a call at
/// every tentative collision, also of the walks without culling (the per-leaf walk's), with
/// the loop's registers saved around it; inlining the ratio as well saved instructions but
/// grew every free-flight variant enough to raise instruction-cache misses by half
/// (callgrind, the fire).
#[inline(always)]
fn cull_ratio(culling: Option<&LeafCulling>, ray_i: &Ray, t: f32) -> f32 {
    match culling {
        Some(c) => leaf_ratio(c, ray_i, t),
        None => 1.0,
    }
}

#[inline(never)]
fn leaf_ratio(c: &LeafCulling, ray_i: &Ray, t: f32) -> f32 {
    c.ratio(ray_i.at(t))
}

/// `Medium::voxel_ratio` of a view: the voxel culling's ratio at `ray_i(t)` against `bound`,
/// 1 without it (the test inlined, the ratio not, as in [`cull_ratio`]).
#[inline(always)]
fn voxel_ratio(voxel: Option<&VoxelCulling>, ray_i: &Ray, t: f32, bound: f32) -> f32 {
    match voxel {
        Some(v) => voxel_ratio_at(v, ray_i, t, bound),
        None => 1.0,
    }
}

#[inline(never)]
fn voxel_ratio_at(v: &VoxelCulling, ray_i: &Ray, t: f32, bound: f32) -> f32 {
    v.ratio(ray_i.at(t), bound)
}

/// The RGB view of a VDB medium along one ray, for spectral tracking. It gathers emission if
/// `F::EMIT`.
pub(super) struct RgbView<'a, F: Features> {
    pub(super) m: &'a VdbMedium,
    pub(super) ray_i: Ray,
    pub(super) ray_w: Ray,
    /// Coefficients per unit density as the tracker sees them: the medium's own, or with
    /// absorption as a weight `(0, sigma_t)` (every real collision scatters; the RGB albedo is
    /// applied afterwards by [`RgbView::scatter_albedo`]).
    pub(super) sigma_a: Vec3,
    pub(super) sigma_s: Vec3,
    /// RGB factor of a scattering event: the albedo `sigma_s / sigma_t` per channel when
    /// absorption is a weight (a clear channel scatters nothing), 1 when it is an event.
    pub(super) scatter_albedo: Vec3,
    pub(super) beta: Vec3,
    pub(super) emitted: Cell<Vec3>,
    pub(super) emission_lookups: Cell<u64>,
    /// As [`GreyView::culling`].
    pub(super) culling: Option<LeafCulling<'a>>,
    pub(super) blur: Blur<'a>,
    /// The MIS weight of its emission against the media lights, after a scattering event.
    pub(super) mis: Option<EmissionMis<'a>>,
    features: PhantomData<F>,
}

impl<'a, F: Features> RgbView<'a, F> {
    pub(super) fn new(
        m: &'a VdbMedium,
        ray_w: &Ray,
        absorption: Absorption,
        majorant: MajorantMode,
        time: f32,
        beta: Vec3,
    ) -> Self {
        let (sigma_a, sigma_s, scatter_albedo) = match absorption {
            Absorption::Event => (m.sigma_a, m.sigma_s, Vec3::ONE),
            Absorption::Weight => {
                let sigma_t = m.sigma_a + m.sigma_s;
                (Vec3::ZERO, sigma_t, per_channel_ratio(m.sigma_s, sigma_t))
            }
        };
        let ray_w = &m.rest_ray(ray_w, time);
        RgbView {
            m,
            ray_i: Ray::new(
                m.density.index_from_world.transform_point3(ray_w.o),
                m.density.index_from_world.transform_vector3(ray_w.d),
            ),
            ray_w: *ray_w,
            sigma_a,
            sigma_s,
            scatter_albedo,
            beta,
            emitted: Cell::new(Vec3::ZERO),
            emission_lookups: Cell::new(0),
            culling: m.culling(majorant),
            blur: Blur::of(m, time),
            mis: None,
            features: PhantomData,
        }
    }
}

impl<F: Features> RgbView<'_, F> {
    /// The density a lookup at `ray_i(t)` reads (advected where the medium is blurred).
    #[inline]
    pub(super) fn density(&self, t: f32) -> f32 {
        self.m
            .density
            .at_index(self.blur.index_point(&self.ray_i, t))
    }
}

impl<F: Features> MediumRgb for RgbView<'_, F> {
    #[inline]
    fn coeffs(&self, t: f32) -> CoeffsRgb {
        let d = self.density(t);
        CoeffsRgb {
            sigma_a: self.sigma_a * d,
            sigma_s: self.sigma_s * d,
        }
    }

    #[inline]
    fn cull_ratio(&self, t: f32) -> f32 {
        cull_ratio(self.culling.as_ref(), &self.ray_i, t)
    }

    #[inline]
    fn on_collision(&self, t: f32, sigma_maj: f32, w: Vec3) {
        if F::EMIT {
            if let Some(e) = &self.m.emission {
                let p = self.blur.world_point(&self.ray_w, &self.ray_i, t);
                let le = e.radiance(p, &self.emission_lookups);
                let w = w * emission_weight(self.m, self.mis, &self.ray_i, self.ray_w.o, t, le);
                self.emitted
                    .set(self.emitted.get() + self.beta * w * le / sigma_maj);
            }
        }
    }
}
