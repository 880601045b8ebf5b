//! The light-transport effects a scene calls for, computed from its data. Integrators use
//! this list to pick specialised code paths (e.g. skip the free-flight loop when there is no
//! medium), so each flag must be true whenever the effect can occur.
use glam::Vec3;

use super::lights::LIGHT_DIRECTIONAL;
use super::Scene;

/// Plain flags, one per effect; [`Effects::names`] lists the set ones.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Effects {
    /// Any triangle.
    pub surfaces: bool,
    /// Any medium with non-zero extinction (homogeneous or heterogeneous).
    pub media: bool,
    /// A `BRUME_medium_vdb` medium with `densityScale > 0`.
    pub heterogeneous_media: bool,
    /// A `KHR_materials_volume` medium with non-zero extinction bounded by some mesh.
    pub homogeneous_media: bool,
    /// Some medium has sigma_s > 0 in some channel.
    pub scattering: bool,
    /// Some medium has sigma_a > 0 in some channel (single-scattering albedo < 1).
    pub absorption: bool,
    /// An emissive surface placed in the scene.
    pub surface_emission: bool,
    /// An emitting medium (emission grid/strength or blackbody from a temperature grid).
    pub media_emission: bool,
    /// Some medium's sigma_t differs across RGB channels (needs spectral MIS / hero channel).
    pub chromatic_extinction: bool,
    /// Some scattering medium's phase function is not isotropic: Henyey-Greenstein with g != 0,
    /// or another phase function.
    pub anisotropic_phase: bool,
    /// Any point, spot or directional light.
    pub punctual_lights: bool,
    /// A point or spot light inside a medium's world bounds (VDB) or closed mesh (homogeneous).
    pub lights_inside_media: bool,
    /// The camera sits inside a medium (same test as for lights).
    pub camera_inside_medium: bool,
    /// Non-zero environment radiance.
    pub environment_light: bool,
    /// The environment's radiance varies with direction (an image that is not constant).
    pub environment_map: bool,
    /// A base-colour or emissive texture on a material some triangle uses.
    pub textures: bool,
    /// Two VDB media whose world bounds overlap (their coefficients add).
    pub overlapping_media: bool,
    /// A VDB medium inside (or across) a `KHR_materials_volume` mesh, or such meshes nested.
    pub nested_media: bool,
}

impl Effects {
    /// Computes the flags of `scene`. VDB media are judged from their parameters, since their
    /// grids may not be loaded: extinction from `densityScale` and the colours, emission from
    /// the presence of an emission or temperature grid with non-zero strength.
    pub fn of(scene: &Scene) -> Effects {
        let mut e = Effects {
            surfaces: scene.triangle_count() > 0,
            ..Effects::default()
        };
        // Records one medium; false when it has no extinction at all.
        fn note_medium(e: &mut Effects, sigma_s: [f32; 3], sigma_a: [f32; 3], g: f32) -> bool {
            let sigma_t = [0, 1, 2].map(|c| sigma_s[c] + sigma_a[c]);
            if sigma_t.iter().all(|&s| s <= 0.0) {
                return false;
            }
            e.media = true;
            let scatters = sigma_s.iter().any(|&s| s > 0.0);
            e.scattering |= scatters;
            e.absorption |= sigma_a.iter().any(|&a| a > 0.0);
            e.anisotropic_phase |= scatters && g != 0.0;
            let (lo, hi) = sigma_t
                .iter()
                .fold((f32::INFINITY, 0.0f32), |(lo, hi), &s| {
                    (lo.min(s), hi.max(s))
                });
            e.chromatic_extinction |= hi - lo > 1e-6 * hi;
            true
        }
        for (k, m) in scene.homogeneous_media.iter().enumerate() {
            let bounded = scene
                .instances
                .iter()
                .any(|i| scene.materials[i.material as usize].interior_medium == k as u32);
            let g = m.phase.henyey_greenstein_g().unwrap_or(1.0);
            if bounded && note_medium(&mut e, m.sigma_s, m.sigma_a, g) {
                e.homogeneous_media = true;
            }
        }
        for m in &scene.vdb_media {
            if note_medium(
                &mut e,
                m.sigma_s_per_density(),
                m.sigma_a_per_density(),
                m.phase
                    .map_or(Some(m.anisotropy), |p| p.henyey_greenstein_g())
                    .unwrap_or(1.0),
            ) {
                e.heterogeneous_media = true;
            }
            e.media_emission |= m.emits();
        }
        e.surface_emission = scene.instances.iter().any(|i| {
            let m = &scene.materials[i.material as usize];
            i.triangle_count > 0 && m.emission.iter().any(|&c| c > 0.0)
        });
        e.punctual_lights = !scene.lights.is_empty();
        e.environment_light = scene.environment.radiance.iter().any(|&c| c > 0.0);
        e.environment_map = e.environment_light
            && scene
                .environment
                .image
                .as_ref()
                .is_some_and(|m| m.constant().is_none());
        e.textures = scene.uses_textures();
        e.lights_inside_media = scene
            .lights
            .iter()
            .filter(|l| l.kind != LIGHT_DIRECTIONAL)
            .any(|l| scene.inside_medium(Vec3::from(l.position)));
        e.camera_inside_medium = scene.inside_medium(scene.camera.position());
        let nesting = super::nesting::Nesting::of(scene);
        e.overlapping_media = nesting.overlapping;
        e.nested_media = nesting.nested;
        e
    }

    /// Names of the set flags, in declaration order.
    pub fn names(&self) -> Vec<&'static str> {
        let all = [
            (self.surfaces, "surfaces"),
            (self.media, "media"),
            (self.heterogeneous_media, "heterogeneous media"),
            (self.homogeneous_media, "homogeneous media"),
            (self.scattering, "scattering"),
            (self.absorption, "absorption"),
            (self.surface_emission, "surface emission"),
            (self.media_emission, "media emission"),
            (self.chromatic_extinction, "chromatic extinction"),
            (self.anisotropic_phase, "anisotropic phase"),
            (self.punctual_lights, "punctual lights"),
            (self.lights_inside_media, "lights inside media"),
            (self.camera_inside_medium, "camera inside medium"),
            (self.environment_light, "environment light"),
            (self.environment_map, "environment map"),
            (self.textures, "textures"),
            (self.overlapping_media, "overlapping media"),
            (self.nested_media, "nested media"),
        ];
        all.iter().filter(|(on, _)| *on).map(|(_, n)| *n).collect()
    }
}
