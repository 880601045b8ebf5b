//! glTF 2.0 scenes with participating media, loaded into one backend-neutral [`Scene`]: flat
//! arrays that both the CPU and the GPU integrators consume (`#[repr(C)]` + `Pod` where they go
//! to the GPU), the CPU's accelerators over the triangles (a two-level BVH where a primitive is
//! placed more than once, see `accelerators`), and descriptions of the media.
//!
//! Supported: `.gltf` (embedded base64 or external buffers) and `.glb`; node hierarchies with
//! TRS or matrices; perspective cameras; triangle meshes (lists, strips, fans); the
//! metallic-roughness material factors with base-colour and emissive textures (PNG, JPEG,
//! `KHR_texture_transform`); `KHR_lights_punctual`, `KHR_materials_emissive_strength`,
//! `KHR_materials_transmission`, `KHR_materials_ior`, `KHR_materials_volume`,
//! `EXT_mesh_gpu_instancing` (each row one more placement of the mesh); and Brume's own
//! `BRUME_environment` (scene), `BRUME_materials_volume_scattering` (material) and
//! `BRUME_medium_vdb` (node, see `docs/BRUME_medium_vdb.md`).
//!
//! Not supported (error): orthographic cameras when named, sparse accessors, unknown
//! extensions listed in `extensionsRequired`. Ignored with a warning: points and lines,
//! textures other than base colour and emissive, `TEXCOORD_n` for n > 0, morph-target
//! animation. Skins and morph targets are ignored silently. Node animations (translation,
//! rotation, scale) are evaluated at the frame's time (`animation`).
//!
//! ```no_run
//! let scene = brume::scene::load(std::path::Path::new("scenes/cloud.gltf")).unwrap();
//! println!("{}", scene.summary());
//! ```
mod accelerators;
mod accessor;
pub mod animation;
pub mod bare_vdb;
pub mod camera;
mod document;
pub mod effects;
pub mod envmap;
pub mod error;
pub mod geometry_stats;
pub mod gpu_instancing;
mod json;
pub mod lights;
pub mod material;
pub mod media;
pub mod mesh;
pub mod motion;
pub mod moving_meshes;
pub mod nesting;
mod nodes;
pub mod phase;
pub mod render_settings;
pub mod sequence;
mod summary;
pub mod texture;
pub mod velocity;
pub mod world_mesh;

use std::path::{Path, PathBuf};

use glam::{Vec3, Vec3A};

pub use camera::{Camera, CameraEntry, CameraSource, Pinhole};
pub use effects::Effects;
pub use error::SceneError;
pub use lights::{Environment, PunctualLight, RADIOMETRIC_PER_PHOTOMETRIC};
pub use material::{HomogeneousMedium, Material};
pub use media::{
    load_grid, transform_aabb, BoundsSource, LoadedGrid, VdbMediumDesc, MAX_TEMPERATURE_K,
};
pub use mesh::{Instance, Triangle, Vertex};
pub use render_settings::SceneRenderSettings;
pub use texture::{TextureImage, TextureRef};

use crate::accel::embree::EmbreeTriangles;
use crate::accel::instanced::InstancedBvh;
use crate::accel::{Accel, TriangleBvh};
use crate::math::{Aabb, Ray};
pub use velocity::{Shutter, VelocityDesc, VelocityUnit};

/// "No such element" in the `u32` index fields of GPU structs.
pub const NO_INDEX: u32 = u32::MAX;

/// Scene-level extension: constant (and optionally mapped) environment light.
pub const BRUME_ENVIRONMENT: &str = "BRUME_environment";
/// Node extension: a heterogeneous medium from an OpenVDB file.
pub const BRUME_MEDIUM_VDB: &str = "BRUME_medium_vdb";
/// Material extension: scattering albedo and phase of a `KHR_materials_volume` medium.
pub const BRUME_MATERIALS_VOLUME_SCATTERING: &str = "BRUME_materials_volume_scattering";

/// Frames per second of a scene without `BRUME_render.fps`.
pub const DEFAULT_FPS: f32 = 24.0;

/// Caller's choices for [`load_with`].
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// Render through the camera (or camera node) with this name instead of the first one.
    pub camera: Option<String>,
    /// The frame whose files a sequence (a `uri` with a run of `#`) reads; default: the
    /// scene's `BRUME_render.frame`, else 1.
    pub frame: Option<i32>,
    /// The shutter, overriding the scene's `BRUME_render.shutter` (closed by default).
    pub shutter: Option<Shutter>,
}

/// A loaded scene. Everything is in world space, metres, linear RGB.
#[derive(Debug)]
pub struct Scene {
    /// The glTF file it came from.
    pub source: PathBuf,
    /// The camera to render through.
    pub camera: Camera,
    /// Every camera the file places, including ones not chosen.
    pub cameras: Vec<CameraEntry>,
    /// The meshes in world space: the vertex and triangle arrays ([`Scene::vertices`],
    /// [`Scene::triangles`]), built on first use where the two-level BVH answers the ray
    /// queries, and single triangles placed on demand ([`Scene::triangle_vertices`]).
    world: world_mesh::WorldMesh,
    pub instances: Vec<Instance>,
    /// glTF materials in file order, then the glTF default material.
    pub materials: Vec<Material>,
    /// Names of `materials`, same order.
    pub material_names: Vec<Option<String>>,
    /// Texture uses of the materials (`Material::base_color_texture`, `emissive_texture`).
    pub textures: Vec<TextureRef>,
    /// Decoded images of `textures` (`TextureRef::image_slot`).
    pub images: Vec<TextureImage>,
    /// `KHR_materials_volume` media, each bounded by the closed meshes of its material.
    pub homogeneous_media: Vec<HomogeneousMedium>,
    /// `BRUME_medium_vdb` media.
    pub vdb_media: Vec<VdbMediumDesc>,
    pub lights: Vec<PunctualLight>,
    /// Each punctual light's name (the glTF light's, else its node's), for its light group.
    pub light_names: Vec<Option<String>>,
    pub environment: Environment,
    /// BVH over `triangles` (same triangle order), as the frame places them: built with the
    /// scene where no two-level BVH answers, else on first use ([`Scene::bvh`]).
    flat_bvh: std::sync::OnceLock<TriangleBvh>,
    /// The two-level BVH (each primitive once, in local space, under its placements) where
    /// some primitive is placed more than once and no mesh moves; it then answers the CPU's
    /// closest hits where Embree is not used, and restates Embree's hits where it is.
    pub instanced: Option<InstancedBvh>,
    /// Embree over the same triangles (over each primitive once under the two-level BVH's
    /// placements, where there is one) where [`Scene::use_accel`] chose it; `None`: the BVH
    /// answers the CPU's closest hits.
    pub embree: Option<EmbreeTriangles>,
    /// The mesh instances an animation moves during the shutter, `None` where none does; ray
    /// queries then go through [`Scene::closest_hit`] at the sample's time.
    pub moving_meshes: Option<moving_meshes::MovingMeshes>,
    /// World bounds of the triangles and the media.
    pub bounds: Aabb,
    /// Render defaults from `BRUME_render` (the command line overrides them).
    pub render: SceneRenderSettings,
    /// The frame the scene was loaded for ([`LoadOptions::frame`]).
    pub frame: i32,
    /// Frames per second: the frame is time `frame / fps` of the file's animations.
    pub fps: f32,
    /// The shutter each camera sample's time is drawn over ([`LoadOptions::shutter`]).
    pub shutter: Shutter,
    /// The camera's poses across the shutter where an animation moves it during the shutter
    /// (transformation motion blur); `None`: the camera stands still.
    pub camera_motion: Option<motion::NodeMotion>,
    /// Each punctual light's motion across the shutter (`lights` order), where an animation
    /// moves it then.
    pub light_motion: Vec<Option<motion::NodeMotion>>,
    /// Nodes the file's animations move.
    pub animated_nodes: usize,
    /// Non-fatal problems met while loading, each with its JSON pointer.
    pub warnings: Vec<String>,
    /// How long the load and the BVH's build took.
    pub timings: geometry_stats::LoadTimings,
}

/// The accelerator [`Scene::use_accel`] chose.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AccelUsed {
    /// What was asked for.
    pub asked: Accel,
    /// [`Accel::Bvh`] or [`Accel::Embree`].
    pub accel: Accel,
    /// Why Embree could not be built where [`Accel::Auto`] picked it (the BVH answers).
    pub fallback: Option<String>,
}

/// Loads `path` (`.gltf` or `.glb`) with default options.
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    load_with(path, &LoadOptions::default())
}

/// Loads `path` (`.gltf` or `.glb`).
pub fn load_with(path: &Path, options: &LoadOptions) -> Result<Scene, SceneError> {
    let start = std::time::Instant::now();
    let mut ctx = error::Ctx::new(path);
    let loaded = document::read(&mut ctx, path)?;
    let doc = &loaded.doc;
    let render = render_settings::read_render_settings(&mut ctx, doc)?;
    let frame = options.frame.or(render.frame).unwrap_or(1);
    let fps = render.fps.unwrap_or(DEFAULT_FPS);
    let shutter = options
        .shutter
        .or(render.shutter)
        .unwrap_or(Shutter::CLOSED);
    let animations = animation::read_animations(&mut ctx, doc, &loaded.buffers)?;
    let pose = animations.pose(frame as f32 / fps);
    let nodes = nodes::place_nodes(&mut ctx, doc, &pose)?;
    let material::MaterialTables {
        materials,
        names: material_names,
        media: homogeneous_media,
        mut textures,
    } = material::read_materials(&mut ctx, doc)?;
    let images = texture::read_images(&ctx, doc, &loaded.buffers, &loaded.base_dir, &mut textures)?;
    let default_material = (materials.len() - 1) as u32;
    let mut geo = mesh::flatten(&mut ctx, doc, &loaded.buffers, &nodes, default_material)?;
    let read_lights = lights::read_lights(&mut ctx, doc, &nodes)?;
    let environment = lights::read_environment(&mut ctx, doc, &loaded.base_dir)?;
    let mut vdb_media = media::read_vdb_media(
        &mut ctx,
        doc,
        &loaded.buffers,
        &nodes,
        &loaded.base_dir,
        frame,
    )?;

    let mut world = world_mesh::WorldMesh::new(std::mem::take(&mut geo.locals), &geo.placements);
    let mut bounds = content_bounds(&world, &vdb_media);
    let camera = camera::choose_camera(&mut ctx, doc, &nodes, options.camera.as_deref(), &bounds)?;
    let steps = motion::placements(path, doc, &animations, frame, fps, shutter)?;
    let camera_motion = match &steps {
        Some(steps) => motion::camera_motion(
            path,
            doc,
            steps,
            options.camera.as_deref(),
            &bounds,
            shutter,
        )?,
        None => None,
    };
    for m in &mut vdb_media {
        m.motion = steps
            .as_ref()
            .and_then(|s| motion::placement_motion(s, m.placement, shutter));
    }
    let light_motion: Vec<_> = read_lights
        .light_placements
        .iter()
        .map(|&p| {
            steps
                .as_ref()
                .and_then(|s| motion::placement_motion(s, p, shutter))
        })
        .collect();

    let moving_meshes = steps.as_ref().and_then(|s| {
        moving_meshes::MovingMeshes::of_steps(s, &nodes, &world, &geo.instances, shutter)
    });
    let read_seconds = start.elapsed().as_secs_f64();
    let (flat_bvh, instanced) =
        accelerators::build(&geo.placements, &mut world, moving_meshes.is_some())
            .map_err(|e| ctx_invalid(path, e))?;
    let timings = geometry_stats::LoadTimings {
        read_seconds,
        bvh_seconds: start.elapsed().as_secs_f64() - read_seconds,
    };
    if let Some(m) = &moving_meshes {
        bounds = bounds.union(&m.swept_bounds());
    }
    warn_open_medium_boundaries(&mut ctx, &world, &geo.instances, &materials);
    let scene = Scene {
        source: path.to_path_buf(),
        camera,
        cameras: camera::list_cameras(doc, &nodes),
        world,
        instances: geo.instances,
        materials,
        material_names,
        textures,
        images,
        homogeneous_media,
        vdb_media,
        lights: read_lights.lights,
        light_names: read_lights.light_names,
        environment,
        flat_bvh,
        instanced,
        embree: None,
        moving_meshes,
        bounds,
        render,
        frame,
        fps,
        shutter,
        camera_motion,
        light_motion,
        animated_nodes: pose.len(),
        warnings: ctx.warnings,
        timings,
    };
    // A loader bug, not a user error, if this fails; still reported, never a panic.
    scene
        .validate()
        .map_err(|e| ctx_invalid(path, format!("internal consistency check failed: {e}")))?;
    Ok(scene)
}

/// The box around the meshes' world-space vertices and the VDB media: what a default camera
/// frames.
fn content_bounds(world: &world_mesh::WorldMesh, vdb_media: &[VdbMediumDesc]) -> Aabb {
    let mut bounds = Aabb::EMPTY;
    world.for_each_position(|p| bounds = bounds.union_point(p));
    for m in vdb_media {
        bounds = bounds.union(&m.world_bounds);
    }
    bounds
}

/// Warns about instances that bound a homogeneous medium but are not closed (some edge not
/// shared by exactly two triangles, after welding equal positions): paths could then enter the
/// medium without leaving it.
fn warn_open_medium_boundaries(
    ctx: &mut error::Ctx,
    world: &world_mesh::WorldMesh,
    instances: &[Instance],
    materials: &[Material],
) {
    use std::collections::HashMap;
    for inst in instances {
        if materials[inst.material as usize].interior_medium == NO_INDEX {
            continue;
        }
        let mut edges: HashMap<([u32; 3], [u32; 3]), u32> = HashMap::new();
        let first = inst.first_triangle as usize;
        for t in first..first + inst.triangle_count as usize {
            let key = world
                .corner_positions(t)
                .map(|p| p.to_array().map(f32::to_bits));
            for e in 0..3 {
                let (a, b) = (key[e], key[(e + 1) % 3]);
                *edges
                    .entry(if a < b { (a, b) } else { (b, a) })
                    .or_default() += 1;
            }
        }
        let open = edges.values().filter(|&&n| n != 2).count();
        if open > 0 {
            ctx.warn(
                format!("/meshes/{}/primitives/{}", inst.mesh, inst.primitive),
                format!("bounds a KHR_materials_volume medium but is not closed ({open} edges not shared by exactly two triangles)"),
            );
        }
    }
}

impl std::fmt::Display for Scene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.summary())
    }
}

fn ctx_invalid(path: &Path, message: String) -> SceneError {
    SceneError::Invalid {
        file: path.to_path_buf(),
        pointer: String::new(),
        message,
    }
}

impl Scene {
    /// The effects this scene calls for.
    pub fn effects(&self) -> Effects {
        Effects::of(self)
    }

    /// Triangles stored and instanced, and the bytes of the geometry and its accelerators.
    pub fn geometry_stats(&self) -> geometry_stats::GeometryStats {
        geometry_stats::GeometryStats::of(self)
    }

    /// Human-readable description: camera, meshes, materials, lights, media and effects.
    pub fn summary(&self) -> String {
        summary::summary(self)
    }

    /// Where triangle `t`'s instance is at time offset `dt` relative to the frame, `None` where
    /// it stands still: positions and (by its inverse transpose) normals map through it.
    #[inline]
    pub fn triangle_motion(&self, t: usize, dt: f32) -> Option<glam::Affine3A> {
        let m = self.moving_meshes.as_ref()?;
        m.of_instance(self.triangle_instance(t))
            .map(|f| f.world_from_rest(dt))
    }

    /// The world-space vertex array, every placement's vertices in instance order; built here
    /// on first use where the scene kept only its stored primitives.
    pub fn vertices(&self) -> &[Vertex] {
        &self.world.arrays().vertices
    }

    /// The world-space triangle array, indexing [`Scene::vertices`], in instance order; built
    /// here on first use where the scene kept only its stored primitives.
    pub fn triangles(&self) -> &[Triangle] {
        &self.world.arrays().triangles
    }

    /// Whether the world arrays are held (the flat BVH's scenes, or something asked for
    /// them), rather than only the stored primitives they are built from.
    pub fn world_arrays_built(&self) -> bool {
        self.world.built().is_some()
    }

    /// Bytes of the stored primitives the scene keeps to place triangles from (none where it
    /// keeps the world arrays alone).
    pub fn stored_primitive_bytes(&self) -> usize {
        self.world.stored_bytes()
    }

    /// The stored primitives in local space, indexed by the two-level BVH's shapes (empty
    /// where the scene keeps the world arrays alone).
    pub fn stored_primitives(&self) -> &[mesh::LocalPrimitive] {
        self.world.locals()
    }

    /// Triangles placed in the world, every placement counted.
    #[inline]
    pub fn triangle_count(&self) -> usize {
        self.world.triangle_count()
    }

    /// Vertices placed in the world, every placement counted.
    pub fn vertex_count(&self) -> usize {
        self.world.vertex_count()
    }

    /// The instance triangle `t` belongs to.
    #[inline]
    pub fn triangle_instance(&self, t: usize) -> u32 {
        self.world.instance_of(t)
    }

    /// The three world-space vertices of triangle `t`, in its corner order.
    #[inline]
    pub fn triangle_vertices(&self, t: usize) -> [Vertex; 3] {
        self.world.corners(t)
    }

    /// Corner positions of triangle `t`.
    #[inline]
    pub fn triangle_corners(&self, t: usize) -> [Vec3; 3] {
        self.world.corner_positions(t)
    }

    /// Whether an animation moves instance `k` during the shutter.
    #[inline]
    pub fn instance_moves(&self, k: u32) -> bool {
        self.moving_meshes
            .as_ref()
            .is_some_and(|m| m.of_instance(k).is_some())
    }

    /// Corner positions of triangle `t` at time offset `dt`: where a moving mesh is then.
    #[inline]
    pub fn triangle_corners_at(&self, t: usize, dt: f32) -> [Vec3; 3] {
        let c = self.triangle_corners(t);
        match self.triangle_motion(t, dt) {
            None => c,
            Some(f) => c.map(|p| f.transform_point3(p)),
        }
    }

    /// Whether `p` lies inside the closed surface of instance `k`, by the parity of crossings
    /// along three fixed, irrational-ish directions (majority vote guards against rays grazing
    /// an edge). Meshes that are not closed give arbitrary answers.
    pub fn inside_instance(&self, p: Vec3, k: usize) -> bool {
        const DIRS: [[f32; 3]; 3] = [
            [0.5773, 0.5774, 0.5775],
            [-0.3141, 0.8660, -0.3892],
            [0.2718, -0.4142, 0.8685],
        ];
        let inst = &self.instances[k];
        let range =
            inst.first_triangle as usize..(inst.first_triangle + inst.triangle_count) as usize;
        let votes = DIRS
            .iter()
            .filter(|d| {
                let ray = Ray::new(p, Vec3::from(**d));
                let crossings = range
                    .clone()
                    .filter(|&t| {
                        let c = self.triangle_corners(t).map(Vec3A::from);
                        crate::accel::intersect_triangle(&ray, &c, 0.0, f32::INFINITY).is_some()
                    })
                    .count();
                crossings % 2 == 1
            })
            .count();
        votes >= 2
    }

    /// Whether `p` lies inside some medium: a VDB medium's world bounds, or the closed mesh
    /// of a material with an interior medium that has non-zero extinction.
    pub fn inside_medium(&self, p: Vec3) -> bool {
        let in_box = |b: &Aabb| !b.is_empty() && p.cmpge(b.min).all() && p.cmple(b.max).all();
        if self
            .vdb_media
            .iter()
            .any(|m| m.rendered() && in_box(&m.world_bounds))
        {
            return true;
        }
        self.instances.iter().enumerate().any(|(k, inst)| {
            let medium = self.materials[inst.material as usize].interior_medium;
            medium != NO_INDEX
                && self.homogeneous_media[medium as usize]
                    .sigma_t()
                    .iter()
                    .any(|&s| s > 0.0)
                && self.inside_instance(p, k)
        })
    }

    /// Checks the invariants every consumer relies on: indices in range, instance ranges
    /// tiling the triangle array, finite data, physical coefficients, a sound BVH.
    pub fn validate(&self) -> Result<(), String> {
        let finite = |xs: &[f32]| xs.iter().all(|x| x.is_finite());
        self.world.validate()?;
        let mut next = 0u32;
        for (k, inst) in self.instances.iter().enumerate() {
            if inst.first_triangle != next || inst.material as usize >= self.materials.len() {
                return Err(format!("instance {k} has a bad triangle range or material"));
            }
            let end = inst.first_triangle + inst.triangle_count;
            // Without the arrays a triangle's instance is derived from these very ranges.
            let wrong = self.world_arrays_built()
                && (inst.first_triangle..end)
                    .any(|t| self.triangle_instance(t as usize) != k as u32);
            if wrong {
                return Err(format!("instance {k}'s triangles point elsewhere"));
            }
            next = end;
        }
        if next as usize != self.triangle_count() {
            return Err("instances do not cover every triangle".into());
        }
        for (k, m) in self.materials.iter().enumerate() {
            let tex_ok = |i: u32| i == NO_INDEX || (i as usize) < self.textures.len();
            let medium_ok = m.interior_medium == NO_INDEX
                || (m.interior_medium as usize) < self.homogeneous_media.len();
            if !finite(&m.base_color)
                || !finite(&m.emission)
                || !tex_ok(m.base_color_texture)
                || !tex_ok(m.emissive_texture)
                || !medium_ok
            {
                return Err(format!("material {k} is inconsistent"));
            }
        }
        for (k, m) in self.homogeneous_media.iter().enumerate() {
            let ok = m
                .sigma_a
                .iter()
                .chain(&m.sigma_s)
                .all(|s| s.is_finite() && *s >= 0.0)
                && m.phase
                    .henyey_greenstein_g()
                    .map_or(true, |g| g.abs() < 1.0)
                && (m.material as usize) < self.materials.len()
                && self.materials[m.material as usize].interior_medium == k as u32;
            if !ok {
                return Err(format!("homogeneous medium {k} is inconsistent"));
            }
        }
        for (k, m) in self.vdb_media.iter().enumerate() {
            let ok = m.density_scale >= 0.0
                && m.anisotropy.abs() < 1.0
                && m.world_from_medium.is_finite()
                && m.world_from_medium.determinant() != 0.0
                && !m.grids.is_empty()
                && finite(&m.sigma_t_per_density());
            if !ok {
                return Err(format!("VDB medium {k} is inconsistent"));
            }
        }
        for (k, l) in self.lights.iter().enumerate() {
            let d = Vec3::from(l.direction);
            if !finite(&l.position)
                || !finite(&l.intensity)
                || (d.length() - 1.0).abs() > 1e-4
                || l.kind > lights::LIGHT_DIRECTIONAL
            {
                return Err(format!("light {k} is inconsistent"));
            }
        }
        if !finite(&self.environment.radiance) {
            return Err("environment radiance is not finite".into());
        }
        let c = &self.camera;
        if !(c.world_from_camera.is_finite() && c.yfov > 0.0 && c.yfov < std::f32::consts::PI) {
            return Err("camera is inconsistent".into());
        }
        self.validate_accelerators()
    }
}
