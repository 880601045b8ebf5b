//! From a loaded [`Scene`] to what the integrators need: media ready to track, lights ready to
//! sample, surface kinds, the medium the camera sits in, and the feature flags that select
//! the specialised code.
use glam::{Affine3A, Mat4, Vec3};

use super::light_groups::{LightGroups, NO_GROUP};
use super::lights::Lights;
use super::media::{
    Blackbody, CullingSound, Emission, EmissionRegion, GridField, HomogeneousMedium, VdbMedium,
    VelocityBlur, WalkPlan,
};
use super::media_lights::MediaLights;
use super::settings::{BlackbodyModel, RenderSettings, VolumeSampling};
use super::stack::{MediumStack, MAX_NESTED_MEDIA};
use crate::math::Aabb;
use crate::scene::motion::FrameMotion;
use crate::scene::nesting::Nesting;
use crate::scene::{Material, Pinhole, Scene, Shutter, VdbMediumDesc};
use crate::volume::phases::Phase;
use crate::volume::{AdaptiveMajorants, Advection, CostModel};
use std::sync::Arc;

/// How a surface interacts with light.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SurfaceKind {
    /// Diffuse + rough specular reflection.
    Opaque,
    /// Smooth dielectric (reflect or refract by Fresnel).
    Dielectric,
    /// Index-matched boundary (`transmission > 0` with `ior == 1`): only changes the medium.
    Null,
}

pub fn surface_kind(m: &Material) -> SurfaceKind {
    if m.transmission > 0.0 {
        if (m.ior - 1.0).abs() < 1e-6 {
            SurfaceKind::Null
        } else {
            SurfaceKind::Dielectric
        }
    } else {
        SurfaceKind::Opaque
    }
}

/// The effects the scene's data call for, as the integrators specialise on them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FeatureFlags {
    pub surfaces: bool,
    pub heterogeneous: bool,
    pub homogeneous: bool,
    pub emission: bool,
    pub absorption: bool,
    pub chromatic: bool,
    /// Some material used by a triangle has a base-colour or emissive texture. The GPU
    /// variants cut texture code and bindings without it; the CPU path tests the material's
    /// texture index per hit instead of doubling its variants (a predictable branch beside a
    /// BVH query), and has no texture code at all without `surfaces`.
    pub textures: bool,
    /// The environment is a map (not constant). The GPU variants cut the map's lookup,
    /// sampling and bindings without it; the CPU path matches on the light (one branch per
    /// escape and environment sample, no variant).
    pub env_map: bool,
    /// Media that add along some ray: overlapping VDB media, or a VDB medium inside a
    /// homogeneous one (`integrator::mixture`). Not part of [`FeatureFlags::as_array`]: the
    /// CPU compiles the mixture into the generic variant only (`tile::specialised`).
    pub overlapping: bool,
    /// Closed media meshes nested in one another or around a VDB medium (the medium stack
    /// holds more than one entry).
    pub nested: bool,
    /// Camera samples see different instants of a shutter ([`RenderScene::shutter`]): a
    /// blurred medium or a moving camera. Not part of [`FeatureFlags::as_array`]: the CPU
    /// tests the shutter once per sample; the GPU variants cut the time's code without it.
    pub motion: bool,
    /// Some medium's phase function is not Henyey-Greenstein. Not part of
    /// [`FeatureFlags::as_array`]: the CPU matches on the phase per event; the GPU variants
    /// keep only Henyey-Greenstein's code without it.
    pub phases: bool,
    /// Some point or spot light shines where a medium is: flights get the equiangular
    /// estimate (`RenderSettings::volume_sampling`). Not part of [`FeatureFlags::as_array`]:
    /// the CPU tests the sampling mode per flight; the GPU variants cut the estimate without it.
    pub equiangular: bool,
}

impl FeatureFlags {
    pub const ALL: FeatureFlags = FeatureFlags {
        surfaces: true,
        heterogeneous: true,
        homogeneous: true,
        emission: true,
        absorption: true,
        chromatic: true,
        textures: true,
        env_map: true,
        overlapping: true,
        nested: true,
        motion: true,
        phases: true,
        equiangular: true,
    };

    /// The flags the CPU's tile renderer is specialised on (`textures` is not one).
    pub fn as_array(&self) -> [bool; 6] {
        [
            self.surfaces,
            self.heterogeneous,
            self.homogeneous,
            self.emission,
            self.absorption,
            self.chromatic,
        ]
    }

    /// A short name for logs: the enabled features, e.g. `surfaces+vdb+absorption`.
    pub fn name(&self) -> String {
        let names = [
            "surfaces",
            "vdb",
            "homogeneous",
            "emission",
            "absorption",
            "chromatic",
            "overlapping",
            "nested",
        ];
        let mut on: Vec<_> = self
            .as_array()
            .iter()
            .chain(&[self.overlapping, self.nested])
            .zip(names)
            .filter(|(b, _)| **b)
            .map(|(_, n)| n)
            .collect();
        if self.textures {
            on.push("textures");
        }
        if self.env_map {
            on.push("envmap");
        }
        if on.is_empty() {
            "empty".into()
        } else {
            on.join("+")
        }
    }
}

pub struct RenderScene<'s> {
    pub scene: &'s Scene,
    pub vdb: Vec<VdbMedium>,
    /// Indexed like `Scene::homogeneous_media`.
    pub homogeneous: Vec<HomogeneousMedium>,
    pub lights: Lights,
    /// Per material.
    pub kinds: Vec<SurfaceKind>,
    /// The homogeneous medium around the camera, if any (the top of `camera_media`).
    pub camera_medium: Option<u32>,
    /// The media around the camera, outermost first: every camera path's medium stack.
    pub camera_media: MediumStack,
    /// The deepest nesting of media meshes (1: media meshes, none inside another; 0: none).
    pub nesting_depth: usize,
    pub features: FeatureFlags,
    /// The scene camera's primary-ray frame, derived once (`Camera::pinhole`).
    pub pinhole: Pinhole,
    /// The shutter camera samples draw their time over, where some medium is blurred
    /// ([`VdbMedium::blur`]), or a medium, the camera, a mesh or a light moves
    /// (`VdbMedium::motion`, `Scene::camera_motion`, `Scene::moving_meshes`,
    /// `Scene::light_motion`); `None`: every sample sees the frame's
    /// instant.
    pub shutter: Option<Shutter>,
    /// The light groups the render keeps (`RenderSettings::light_groups`), if any; each
    /// medium's group is also on it (`VdbMedium::light_group`).
    pub groups: Option<LightGroups>,
    /// The emitting media sampled as lights (`RenderSettings::media_lights`), where some
    /// medium emits.
    pub media_lights: Option<MediaLights>,
}

impl RenderScene<'_> {
    /// The light group a light `source` gathers into ([`NO_GROUP`] where none are kept).
    #[inline(always)]
    pub fn light_group(&self, source: super::lights::LightSource) -> u8 {
        self.groups
            .as_ref()
            .map_or(NO_GROUP, |g| g.of_source(source))
    }

    /// The camera's pinhole at time offset `time`: posed where the camera moves.
    #[inline(always)]
    pub fn pinhole_at(&self, time: f32) -> Pinhole {
        match &self.scene.camera_motion {
            None => self.pinhole,
            Some(motion) => self.pinhole.posed(motion.world_from_node(time)),
        }
    }

    /// How the render samples distances in media: `settings`' choice, distance-only where
    /// the scene has no point or spot light for the equiangular strategy.
    pub fn volume_sampling(&self, settings: &RenderSettings) -> VolumeSampling {
        if self.lights.positional.is_empty() {
            VolumeSampling::Distance
        } else {
            settings.volume_sampling
        }
    }
}

fn field(grid: &crate::scene::LoadedGrid, world_from_node: Mat4) -> GridField {
    let world_from_index = world_from_node * grid.vdb_world_from_index;
    GridField {
        grid: grid.volume.clone(),
        index_from_world: Affine3A::from_mat4(world_from_index.inverse()),
    }
}

/// Mean index-space distance per unit of the ray parameter (per metre along a unit world
/// direction): the mean column norm of `index_from_world` (1 / voxel size when uniform).
pub fn index_per_t(f: &GridField) -> f32 {
    let m = f.index_from_world.matrix3;
    (m.x_axis.length() + m.y_axis.length() + m.z_axis.length()) / 3.0
}

impl<'s> RenderScene<'s> {
    /// Prepares `scene` for a render with `settings`: [`RenderScene::new`] with the settings'
    /// spectral choice, and their environment-map sampling.
    pub fn prepare(scene: &'s Scene, settings: &RenderSettings) -> Result<Self, String> {
        let mut rs = RenderScene::new(scene, settings.force_spectral)?;
        rs.lights.set_env_sampling(settings.env_sampling);
        if !settings.light_groups.is_empty() {
            let groups = LightGroups::of(scene)?;
            if groups.names != settings.light_groups {
                return Err(format!(
                    "{}: the light groups asked for ({}) are not the scene's ({})",
                    scene.source.display(),
                    settings.light_groups.join(", "),
                    groups.names.join(", ")
                ));
            }
            for (m, &g) in rs.vdb.iter_mut().zip(&groups.media) {
                m.light_group = g;
            }
            rs.groups = Some(groups);
        }
        if settings.blackbody == BlackbodyModel::Voxels {
            let emissions = rs.vdb.iter_mut().filter_map(|m| m.emission.as_mut());
            for b in emissions.filter_map(|e| e.blackbody.as_mut()) {
                b.of_voxels = true;
            }
        }
        if settings.media_lights {
            rs.media_lights = MediaLights::build(&mut rs.vdb);
        }
        Ok(rs)
    }

    /// Prepares `scene`. Fails (with the file named) on configurations the integrators do not
    /// handle: closed media meshes nested deeper than [`MAX_NESTED_MEDIA`].
    pub fn new(scene: &'s Scene, force_spectral: bool) -> Result<Self, String> {
        let file = scene.source.display();
        let vdb: Vec<VdbMedium> = scene
            .vdb_media
            .iter()
            .filter(|desc| desc.rendered())
            .map(|desc| vdb_medium(desc, scene.shutter, scene.fps))
            .collect::<Result<_, _>>()
            .map_err(|why| format!("{file}: {why}"))?;
        let homogeneous: Vec<HomogeneousMedium> = scene
            .homogeneous_media
            .iter()
            .map(|h| HomogeneousMedium {
                sigma_a: Vec3::from(h.sigma_a),
                sigma_s: Vec3::from(h.sigma_s),
                phase: h.phase,
            })
            .collect();
        let kinds: Vec<SurfaceKind> = scene.materials.iter().map(surface_kind).collect();
        let nesting = Nesting::of(scene);
        if let Some(m) = nesting.deepest().filter(|m| m.depth > MAX_NESTED_MEDIA) {
            let inst = &scene.instances[m.instance];
            return Err(format!(
                "{file}: /nodes/{}: the KHR_materials_volume mesh {} (primitive {}) lies inside \
                 {} other media meshes, {} nested media in all; Brume's medium stack holds at \
                 most {MAX_NESTED_MEDIA}",
                inst.node,
                inst.mesh,
                inst.primitive,
                m.depth - 1,
                m.depth
            ));
        }
        let used_homogeneous = !nesting.meshes.is_empty();
        let camera_media = MediumStack::from_outermost(&nesting.camera);
        let camera_medium = camera_media.top();
        let absorption = vdb.iter().any(|v| v.sigma_a.max_element() > 0.0)
            || (used_homogeneous && homogeneous.iter().any(|h| h.sigma_a.max_element() > 0.0));
        let chromatic = force_spectral
            || vdb.iter().any(|v| !v.grey)
            || (used_homogeneous
                && homogeneous.iter().any(|h| {
                    let s = h.sigma_t();
                    s.x != s.y || s.y != s.z
                }));
        let features = FeatureFlags {
            surfaces: scene.triangle_count() > 0,
            heterogeneous: !vdb.is_empty(),
            homogeneous: used_homogeneous,
            emission: vdb.iter().any(|v| v.emission.is_some()),
            absorption,
            chromatic,
            overlapping: nesting.overlapping || (nesting.nested && !vdb.is_empty()),
            nested: nesting.nested,
            textures: scene.uses_textures(),
            env_map: false,
            motion: false,
            phases: vdb
                .iter()
                .map(|v| &v.phase)
                .chain(homogeneous.iter().map(|h| &h.phase))
                .any(|p| p.henyey_greenstein_g().is_none()),
            equiangular: false,
        };
        let mut lights = Lights::new(scene);
        // Only media that scatter have medium events (a purely absorbing one, such as
        // KHR_materials_volume's tinted glass, never asks for a light).
        let albedo = |sigma_a: Vec3, sigma_s: Vec3| {
            (sigma_s.max_element() > 0.0)
                .then(|| crate::math::per_channel_ratio(sigma_s, sigma_a + sigma_s))
        };
        lights.set_media_albedo(
            vdb.iter()
                .filter_map(|m| albedo(m.sigma_a, m.sigma_s))
                .chain(
                    homogeneous
                        .iter()
                        .filter_map(|h| albedo(h.sigma_a, h.sigma_s)),
                ),
        );
        let moves = vdb.iter().any(|m| m.blur.is_some() || m.motion.is_some())
            || scene.camera_motion.is_some()
            || scene.moving_meshes.is_some()
            || scene.light_motion.iter().any(Option::is_some);
        let shutter = moves.then_some(scene.shutter);
        let features = FeatureFlags {
            env_map: lights.environment.as_ref().is_some_and(|e| e.map.is_some()),
            motion: shutter.is_some(),
            // The media part is `graph.rs`'s to add (the CPU's test is on the lights alone).
            equiangular: !lights.positional.is_empty(),
            ..features
        };
        Ok(RenderScene {
            scene,
            vdb,
            homogeneous,
            lights,
            kinds,
            camera_medium,
            camera_media,
            nesting_depth: nesting.deepest().map_or(0, |m| m.depth),
            features,
            pinhole: scene.camera.pinhole(),
            shutter,
            groups: None,
            media_lights: None,
        })
    }
}

/// One `BRUME_medium_vdb` medium ready to track: its density field, coefficients, emission,
/// the bounds its walks take, its adaptive hierarchy, culling tables and walk plans, and its
/// velocity blur under `shutter` at `fps`.
fn vdb_medium(desc: &VdbMediumDesc, shutter: Shutter, fps: f32) -> Result<VdbMedium, String> {
    let density = &desc.grids[0];
    let world_from_node = desc.world_from_medium * density.vdb_world_from_index.inverse();
    let mut density = field(density, world_from_node);
    let by_name = |name: &Option<String>| {
        desc.grid_named(name.as_deref())
            .map(|g| field(g, world_from_node))
    };
    let emission = emission(desc, &density, &by_name);
    let sigma_a = Vec3::from(desc.sigma_a_per_density());
    let sigma_s = Vec3::from(desc.sigma_s_per_density());
    let sigma_t = sigma_a + sigma_s;
    let mut sigma_t_bound = sigma_t.max_element();
    if !(sigma_t_bound > 0.0) {
        // An emitting medium with no extinction: a density of zeros at extinction 1
        // per unit, walked only where it emits (`emission_bounds`).
        density = super::emission_bounds::without_density(&density);
        sigma_t_bound = 1.0;
    }
    // Every tentative collision in an emitting medium also reads its emission grids
    // (`Medium::on_collision`), so collisions cost that much more against steps.
    let emission_reads = emission.as_ref().map_or(0, |e| {
        e.grid.is_some() as u32 + e.blackbody.is_some() as u32
    });
    let cost = CostModel {
        collision: 1.0 + emission_reads as f32,
        ..CostModel::DEFAULT
    };
    let per_t = index_per_t(&density);
    // An emitting medium's walks sample wherever it may emit, density or not.
    let mut walk_bounds = emission.as_ref().and_then(|e| {
        super::emission_bounds::walk_bounds(&density, e, sigma_t_bound, per_t).map(Arc::new)
    });
    let mut world_bounds = desc.world_bounds;
    let blur = velocity_blur(desc, &density, shutter, fps);
    if let Some(blur) = &blur {
        let bounds = walk_bounds.as_deref().unwrap_or(&density.grid.bounds);
        let dilated = blurred_bounds(desc, &density, bounds, blur, shutter)?;
        world_bounds = world_bounds.union(&cell_box_in_world(&density, &dilated));
        walk_bounds = Some(Arc::new(dilated));
    }
    let bounds = walk_bounds.as_deref().unwrap_or(&density.grid.bounds);
    let adaptive = Arc::new(AdaptiveMajorants::build(bounds, sigma_t_bound, per_t, cost));
    // The per-voxel stage where the collisions it culls save more lookups than its
    // reads cost (`voxel_bounds::voxel_culling_pays`); the dilated bounds of a blurred medium
    // have no per-voxel table.
    let voxel_culling_pays = blur.is_none() && {
        let kept = crate::volume::voxel_bounds::kept_fraction(&density.grid.grid, bounds);
        crate::volume::voxel_bounds::voxel_culling_pays(kept, 1.0 + emission_reads as f64)
    };
    let culling_sound = CullingSound::of(bounds, &density.grid.grid.cells, sigma_t_bound);
    let mut medium = VdbMedium {
        culling_sound,
        voxel_culling_pays,
        density,
        world_bounds,
        sigma_a,
        sigma_s,
        sigma_t_bound,
        adaptive,
        grey: sigma_t.x == sigma_t.y && sigma_t.y == sigma_t.z,
        phase: desc.phase.unwrap_or(Phase::hg(desc.anisotropy)),
        emission,
        walk_bounds,
        walks: [WalkPlan::UNPLANNED; 4],
        blur: blur.map(Arc::new),
        motion: None,
        light_group: NO_GROUP,
        emitter: None,
    };
    if let Some(node) = &desc.motion {
        let motion = FrameMotion {
            node: node.clone(),
            frame_world_from_node: world_from_node,
        };
        medium.world_bounds = motion.swept_bounds(medium.world_bounds);
        medium.motion = Some(Arc::new(motion));
    }
    medium.plan_walks();
    Ok(medium)
}

/// The medium's velocity blur under `shutter` at `fps`: `None` without a velocity grid, with
/// the shutter closed or a zero velocity factor (the medium then renders as without blur).
fn velocity_blur(
    desc: &VdbMediumDesc,
    density: &GridField,
    shutter: Shutter,
    fps: f32,
) -> Option<VelocityBlur> {
    let velocity = desc.velocity.as_ref()?;
    let factor = velocity.factor(shutter, fps);
    (factor != 0.0).then(|| VelocityBlur {
        advection: Advection::new(
            velocity.grid.clone(),
            desc.grids[0].volume.grid.world_from_index,
        ),
        factor,
        world_from_index: density.index_from_world.inverse(),
    })
}

/// `bounds` dilated to bound every lookup `blur` makes over `shutter`
/// (`volume::motion::advected_bounds`), refused where the dilation is unbounded or too large.
fn blurred_bounds(
    desc: &VdbMediumDesc,
    density: &GridField,
    bounds: &crate::volume::LeafBounds,
    blur: &VelocityBlur,
    shutter: Shutter,
) -> Result<crate::volume::LeafBounds, String> {
    let k_max = shutter.max_offset() as f64 * blur.factor.abs() as f64;
    let outside = crate::volume::CellBounds::point(density.grid.grid.background.max(0.0));
    crate::volume::motion::advected_bounds(
        bounds,
        outside,
        &blur.advection,
        k_max,
        crate::volume::DEFAULT_MAX_CELLS,
    )
    .ok_or_else(|| {
        format!(
            "{}: the velocity grid {:?} moves the medium by up to {:.0} voxels over the \
             shutter, more than its bounds can be dilated by; lower velocityScale or the shutter",
            desc.pointer,
            desc.velocity.as_ref().map_or("", |v| v.grid_name.as_str()),
            k_max * blur.advection.max_speed()
        )
    })
}

/// The world box of `bounds`' cell box in `density`'s index space.
fn cell_box_in_world(density: &GridField, bounds: &crate::volume::LeafBounds) -> Aabb {
    let lo = Vec3::from_array(bounds.cell_origin.map(|c| c as f32 * 8.0));
    let hi = lo + Vec3::from_array(bounds.dims.map(|d| d as f32 * 8.0));
    let world_from_index = Mat4::from(density.index_from_world.inverse());
    crate::scene::media::transform_aabb(&world_from_index, &Aabb::new(lo, hi))
}

/// The medium's emission (a colour, an emission grid, a blackbody temperature), limited to
/// Cycles' volume box; `None` where it emits nothing. `by_name` finds a grid of the medium.
fn emission(
    desc: &VdbMediumDesc,
    density: &GridField,
    by_name: &dyn Fn(&Option<String>) -> Option<GridField>,
) -> Option<Emission> {
    let strength_color = Vec3::from(desc.emission_color) * desc.emission_strength;
    let blackbody = by_name(&desc.temperature_grid)
        .filter(|_| desc.blackbody_intensity > 0.0)
        .map(|temperature| Blackbody {
            temperature,
            scale: desc.temperature_scale,
            offset: desc.temperature_offset,
            intensity: desc.blackbody_intensity,
            tint: Vec3::from(desc.blackbody_tint),
            of_voxels: false,
        });
    (strength_color != Vec3::ZERO || blackbody.is_some()).then(|| Emission {
        strength_color,
        grid: by_name(&desc.emission_grid),
        blackbody,
        // Cycles' volume box, in the density's index space
        // (`VdbMediumDesc::emission_box`).
        region: Some(EmissionRegion {
            index_from_world: density.index_from_world,
            bounds: desc.emission_box(),
        }),
    })
}
