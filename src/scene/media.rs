//! Heterogeneous media from OpenVDB files, attached to nodes by `BRUME_medium_vdb`
//! (specified in `docs/BRUME_medium_vdb.md`).
//!
//! Parameters follow Blender's Principled Volume so scenes can be checked against Cycles. Per
//! unit of the density grid's value `d` (Cycles `svm_node_principled_volume`,
//! intern/cycles/kernel/svm/closure.h, checked against its source):
//! - `sigma_s = color * densityScale * d`
//! - `sigma_a = max(1 - color, 0) * max(1 - sqrt(absorptionColor), 0) * densityScale * d`
//! - emission (radiance per metre) `= emissionStrength * emissionColor * e`, where `e` is the
//!   `emissionGrid` value (1 when no grid is named); NOT multiplied by density, as in Cycles;
//! - blackbody from `temperatureGrid`, `T = temperatureScale * t + temperatureOffset` kelvin,
//!   adds `(5.670373e-8 * 1e-6 / pi) * ((1 - I) + I * T^4) * C(T) * blackbodyTint` with
//!   `I = blackbodyIntensity` and `C` the blackbody colour normalised to unit luminance
//!   (radiometry to be implemented with the integrator; the parameters are kept here).
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::DMat4;

use glam::{Mat4, Vec3};

use super::error::{Ctx, SceneError};
use super::json::Obj;
use super::nodes::PlacedNode;
use super::sequence;
use super::BRUME_MEDIUM_VDB;
use crate::math::Aabb;
use crate::volume::{self, GridLoadError};

/// One grid of a medium, read and converted to Brume's layout (shared: several media may use
/// the same file).
#[derive(Clone)]
pub struct LoadedGrid {
    /// Absolute path of the .vdb file.
    pub path: PathBuf,
    /// Grid name inside the file.
    pub name: String,
    /// The VDB's own index-to-world transform.
    pub vdb_world_from_index: Mat4,
    /// Index-space support of the grid: the padded cell box outside which every lookup is the
    /// background. `None` for a grid with no cells.
    pub index_bounds: Option<Aabb>,
    /// The converted grid and its per-leaf bounds.
    pub volume: Arc<volume::LoadedGrid>,
}

impl std::fmt::Debug for LoadedGrid {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LoadedGrid")
            .field("path", &self.path)
            .field("name", &self.name)
            .field("dims", &self.volume.grid.dims)
            .field("index_bounds", &self.index_bounds)
            .finish()
    }
}

impl PartialEq for LoadedGrid {
    fn eq(&self, o: &Self) -> bool {
        self.path == o.path && self.name == o.name && Arc::ptr_eq(&self.volume, &o.volume)
    }
}

/// The one place a scene reads grids: through [`volume::load_scene_grid`], which owns
/// OpenVDB and applies Brume's load policy (float grids only, level sets converted to fog,
/// NaN/Inf refused, negatives clamped). Returns the grid and the policy's warnings.
pub fn load_grid(path: &Path, grid: &str) -> Result<(LoadedGrid, Vec<String>), GridLoadError> {
    let loaded = volume::load_scene_grid(path, grid)?;
    let m = loaded.grid.world_from_index;
    let vdb_world_from_index = DMat4::from(m).as_mat4();
    let b = loaded.grid.index_bounds();
    let warnings = loaded.warnings.clone();
    Ok((
        LoadedGrid {
            path: path.to_path_buf(),
            name: grid.to_string(),
            vdb_world_from_index,
            index_bounds: (!b.is_empty()).then_some(b),
            volume: Arc::new(loaded),
        },
        warnings,
    ))
}

/// How a medium's world bounds were obtained.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BoundsSource {
    /// From the grid's active voxels.
    Grid,
    /// From the optional bounding `mesh`.
    Mesh,
}

/// Everything needed to build one heterogeneous medium once its grids are read.
#[derive(Clone, Debug, PartialEq)]
pub struct VdbMediumDesc {
    /// The `uri` as written.
    pub uri: String,
    /// Resolved absolute path of the .vdb file.
    pub vdb_path: PathBuf,
    /// Name of the density grid (`densityGrid`, default "density").
    pub density_grid: String,
    /// Extinction per unit density per metre (`densityScale`, >= 0, default 1).
    pub density_scale: f32,
    /// Principled Volume scattering `color` in [0, 1] (default 0.5 grey, Blender's).
    pub color: [f32; 3],
    /// Principled Volume `absorptionColor` in [0, 1] (default black).
    pub absorption_color: [f32; 3],
    /// Henyey-Greenstein g in (-1, 1).
    pub anisotropy: f32,
    /// The `phase` object, where given (it replaces `anisotropy`).
    pub phase: Option<crate::volume::phases::Phase>,
    /// Emission grid name, if any.
    pub emission_grid: Option<String>,
    /// Emission strength, >= 0 (default 0).
    pub emission_strength: f32,
    /// Emission colour in [0, 1] (default white).
    pub emission_color: [f32; 3],
    /// Temperature grid name, if any.
    pub temperature_grid: Option<String>,
    /// Blackbody intensity I, >= 0 (default 0; 1 is physically based).
    pub blackbody_intensity: f32,
    /// Blackbody tint in [0, 1] (default white).
    pub blackbody_tint: [f32; 3],
    /// Kelvin per unit of the temperature grid (default 1).
    pub temperature_scale: f32,
    /// Kelvin added after scaling (default 0).
    pub temperature_offset: f32,
    /// glTF mesh bounding the medium in node space, if given.
    pub bounding_mesh: Option<usize>,
    /// world_from_medium = node world matrix * the VDB's index-to-world transform.
    pub world_from_medium: Mat4,
    /// World-space bounds of the medium (see `bounds_source`).
    pub world_bounds: Aabb,
    pub bounds_source: BoundsSource,
    /// The grids as loaded: density first, then emission and temperature if named.
    pub grids: Vec<LoadedGrid>,
    /// glTF node index carrying the extension.
    pub node: usize,
    /// That node's name, for the medium's light group.
    pub name: Option<String>,
    /// JSON pointer of the extension object, for later errors.
    pub pointer: String,
    /// The velocity grid and its scaling (`velocityGrid`), for velocity motion blur.
    pub velocity: Option<super::velocity::VelocityDesc>,
    /// Which placement of its node it is (`nodes::place_nodes`' order).
    pub placement: usize,
    /// Its node's motion across the shutter, where an animation moves it then.
    pub motion: Option<super::motion::NodeMotion>,
}

impl VdbMediumDesc {
    /// sigma_s per unit grid density, m^-1.
    pub fn sigma_s_per_density(&self) -> [f32; 3] {
        self.color.map(|c| c * self.density_scale)
    }

    /// sigma_a per unit grid density, m^-1 (Cycles' Principled Volume formula).
    pub fn sigma_a_per_density(&self) -> [f32; 3] {
        [0, 1, 2].map(|i| {
            (1.0 - self.color[i]).max(0.0)
                * (1.0 - self.absorption_color[i].sqrt()).max(0.0)
                * self.density_scale
        })
    }

    /// sigma_t per unit grid density, m^-1.
    pub fn sigma_t_per_density(&self) -> [f32; 3] {
        let (s, a) = (self.sigma_s_per_density(), self.sigma_a_per_density());
        [0, 1, 2].map(|i| s[i] + a[i])
    }

    /// The loaded grid named `name` (`None` for no name, or a grid not loaded).
    pub fn grid_named(&self, name: Option<&str>) -> Option<&LoadedGrid> {
        let name = name?;
        self.grids.iter().find(|g| g.name == name)
    }

    /// Whether the renderer tracks the medium: it has density, or it emits (Principled
    /// Volume's emission does not scale with density, so a medium with none still glows).
    pub fn rendered(&self) -> bool {
        self.density_scale > 0.0 || self.emits()
    }

    /// The box the medium emits in, in the density grid's index space (VDB index coordinates):
    /// Cycles 5's volume mesh under null scattering, the union of its grids' active voxels,
    /// each grid's `[min - 1, max + 2]` in its own index coordinates (one voxel of padding for
    /// linear interpolation, and the mesh runs to one past the highest voxel). Empty where no
    /// grid has an active voxel (Cycles then builds no mesh). See
    /// `integrator::media::EmissionRegion`.
    pub fn emission_box(&self) -> Aabb {
        let Some(density) = self.grids.first() else {
            return Aabb::EMPTY;
        };
        let density_from_vdb = density.vdb_world_from_index.inverse();
        self.grids
            .iter()
            .filter_map(|g| {
                let (lo, hi) = g.volume.info.active_bbox?;
                let own = Aabb::new(
                    Vec3::from_array(lo.map(|c| c as f32 - 1.0)),
                    Vec3::from_array(hi.map(|c| c as f32 + 2.0)),
                );
                Some(transform_aabb(
                    &(density_from_vdb * g.vdb_world_from_index),
                    &own,
                ))
            })
            .fold(Aabb::EMPTY, |u, b| u.union(&b))
    }

    /// Whether the medium emits: a non-zero emission or a temperature grid with blackbody on.
    pub fn emits(&self) -> bool {
        let emission = self.emission_strength > 0.0 && self.emission_color.iter().any(|&c| c > 0.0);
        let blackbody = self.temperature_grid.is_some()
            && self.blackbody_intensity > 0.0
            && self.blackbody_tint.iter().any(|&c| c > 0.0);
        emission || blackbody
    }
}

/// The members `BRUME_medium_vdb` defines (others are warned about as unknown).
pub const FIELDS: &[&str] = &[
    "uri",
    "densityGrid",
    "densityScale",
    "color",
    "absorptionColor",
    "anisotropy",
    "phase",
    "emissionGrid",
    "emissionStrength",
    "emissionColor",
    "temperatureGrid",
    "blackbodyIntensity",
    "blackbodyTint",
    "temperatureScale",
    "temperatureOffset",
    "mesh",
    "velocityGrid",
    "velocityScale",
    "velocityUnit",
    "frameOffset",
];

/// Reads `BRUME_medium_vdb` from every placed node and loads its grids through [`load_grid`],
/// a sequence's (a `uri` with a run of `#`) from its file for `frame`.
pub fn read_vdb_media(
    ctx: &mut Ctx,
    doc: &gltf::Document,
    buffers: &[Vec<u8>],
    nodes: &[PlacedNode],
    base: &Path,
    frame: i32,
) -> Result<Vec<VdbMediumDesc>, SceneError> {
    let mut out = Vec::new();
    for (placement, placed) in nodes.iter().enumerate() {
        let node = placed.in_doc(doc);
        let Some(value) = node.extension_value(BRUME_MEDIUM_VDB) else {
            continue;
        };
        let obj = Obj::new(
            ctx,
            value,
            format!("/nodes/{}/extensions/{BRUME_MEDIUM_VDB}", placed.node),
        )?;
        obj.warn_unknown(ctx, FIELDS);
        let uri = obj
            .string(ctx, "uri")?
            .ok_or_else(|| ctx.invalid(obj.at("uri"), "missing: the .vdb file to read"))?;
        let offset = obj.number(ctx, "frameOffset", 0.0, -1e6, 1e6, false)?;
        if offset.fract() != 0.0 {
            return Err(ctx.invalid(
                obj.at("frameOffset"),
                format!("expected a whole number of frames, got {offset}"),
            ));
        }
        if offset != 0.0 && !sequence::is_sequence(&uri) {
            ctx.warn(
                obj.at("frameOffset"),
                "the uri names one file (no run of #): no effect",
            );
        }
        // The file of a sequence is frame + frameOffset: Blender's sequence start and offset.
        let file = sequence::for_frame(&uri, frame + offset as i32);
        let path = super::document::resolve_uri(ctx, &file, base, &obj.at("uri"))?;
        let vdb_path = std::path::absolute(&path).unwrap_or(path);
        let max = f32::MAX;
        let mut desc = VdbMediumDesc {
            density_grid: obj
                .string(ctx, "densityGrid")?
                .unwrap_or_else(|| "density".into()),
            density_scale: obj.number(ctx, "densityScale", 1.0, 0.0, max, false)?,
            color: obj.rgb(ctx, "color", [0.5; 3], 0.0, 1.0)?,
            absorption_color: obj.rgb(ctx, "absorptionColor", [0.0; 3], 0.0, 1.0)?,
            anisotropy: obj.number(ctx, "anisotropy", 0.0, -1.0, 1.0, true)?,
            phase: super::phase::read_phase(ctx, &obj)?,
            emission_grid: obj.string(ctx, "emissionGrid")?,
            emission_strength: obj.number(ctx, "emissionStrength", 0.0, 0.0, max, false)?,
            emission_color: obj.rgb(ctx, "emissionColor", [1.0; 3], 0.0, 1.0)?,
            temperature_grid: obj.string(ctx, "temperatureGrid")?,
            blackbody_intensity: obj.number(ctx, "blackbodyIntensity", 0.0, 0.0, max, false)?,
            blackbody_tint: obj.rgb(ctx, "blackbodyTint", [1.0; 3], 0.0, 1.0)?,
            temperature_scale: obj.number(ctx, "temperatureScale", 1.0, 0.0, max, false)?,
            temperature_offset: obj.number(ctx, "temperatureOffset", 0.0, f32::MIN, max, false)?,
            bounding_mesh: obj.index(ctx, "mesh")?,
            uri,
            vdb_path,
            world_from_medium: Mat4::IDENTITY,
            world_bounds: Aabb::EMPTY,
            bounds_source: BoundsSource::Grid,
            grids: Vec::new(),
            node: placed.node,
            name: node.name().map(str::to_owned),
            pointer: obj.pointer.clone(),
            velocity: None,
            placement,
            motion: None,
        };
        if let Some(m) = desc.bounding_mesh {
            if m >= doc.meshes().len() {
                return Err(ctx.invalid(
                    obj.at("mesh"),
                    format!("mesh {m} does not exist ({} meshes)", doc.meshes().len()),
                ));
            }
        }
        if desc.temperature_grid.is_none() && desc.blackbody_intensity > 0.0 {
            ctx.warn(
                obj.at("blackbodyIntensity"),
                "no temperatureGrid: blackbody emission is off",
            );
        }

        load_grids(ctx, &obj, &mut desc, &file, frame)?;
        desc.velocity = super::velocity::read_velocity(ctx, &obj, &desc.vdb_path)?;
        check_temperature_range(ctx, &obj, &desc)?;
        check_emission_range(ctx, &obj, &desc)?;
        widen_density_to_emission(ctx, &obj, &mut desc);

        desc.world_from_medium = placed.world_from_node * desc.grids[0].vdb_world_from_index;
        (desc.world_bounds, desc.bounds_source) = if let Some(b) = desc.grids[0].index_bounds {
            (
                transform_aabb(&desc.world_from_medium, &b),
                BoundsSource::Grid,
            )
        } else if let Some(m) = desc.bounding_mesh {
            (
                mesh_bounds(ctx, doc, buffers, m, &placed.world_from_node)?,
                BoundsSource::Mesh,
            )
        } else {
            // A grid with no cells: nothing to render, nothing to bound.
            (Aabb::EMPTY, BoundsSource::Grid)
        };
        check_optical_depth(ctx, &obj, &desc)?;
        out.push(desc);
    }
    Ok(out)
}

/// Loads the medium's density grid and its emission and temperature grids when it names them
/// from `file` (the `uri`, or its file for `frame` when the `uri` is a sequence).
fn load_grids(
    ctx: &mut Ctx,
    obj: &Obj,
    desc: &mut VdbMediumDesc,
    file: &str,
    frame: i32,
) -> Result<(), SceneError> {
    let mut grid_fields = vec![("densityGrid", desc.density_grid.clone())];
    grid_fields.extend(desc.emission_grid.clone().map(|g| ("emissionGrid", g)));
    grid_fields.extend(
        desc.temperature_grid
            .clone()
            .map(|g| ("temperatureGrid", g)),
    );
    for (field, name) in grid_fields {
        let (grid, warnings) = load_grid(&desc.vdb_path, &name).map_err(|e| match e {
            GridLoadError::File(msg) if file != desc.uri => ctx.invalid(
                obj.at("uri"),
                format!(
                    "medium file {file:?} (frame {frame} of {:?}): {msg}",
                    desc.uri
                ),
            ),
            GridLoadError::File(msg) => {
                ctx.invalid(obj.at("uri"), format!("medium file {:?}: {msg}", desc.uri))
            }
            GridLoadError::Grid(msg) => ctx.invalid(
                obj.at(field),
                format!("grid {name:?} in {}: {msg}", desc.vdb_path.display()),
            ),
        })?;
        for w in warnings {
            ctx.warn(obj.at(field), w);
        }
        desc.grids.push(grid);
    }
    Ok(())
}

/// Largest optical depth a medium may have across its world bounds. Free-flight distances are
/// 32-bit ray parameters: at optical depth `tau` across a box of size `L` the mean step is
/// `L / tau`, while the spacing of floats near `L` is `L * 1.2e-7`. Beyond about 1e7 steps stop
/// advancing the ray (found by `tests/files/fuzz_inputs/`: `densityScale: 1.8e19` tracked 2^24
/// null collisions at one point); 1e6 keeps the mean step at eight float spacings. The stress
/// suite covers optical depths up to 1e5.
pub const MAX_OPTICAL_DEPTH: f64 = 1e6;

/// Largest emitted radiance per metre (`emissionStrength * emissionColor * emissionGrid`). The
/// estimators add `beta * Le * w / sigma_maj` at collisions, so radiance near `f32::MAX` turns
/// into infinities (found by `tests/files/fuzz_inputs/`: `emissionStrength: 3.4e38`); 1e20 is
/// eighteen orders above the example fire and leaves room for `1 / sigma_maj`.
pub const MAX_EMISSION: f64 = 1e20;

/// Refuses media whose extinction makes free flights unresolvable in 32-bit ray distances
/// (see [`MAX_OPTICAL_DEPTH`]).
fn check_optical_depth(ctx: &Ctx, obj: &Obj, desc: &VdbMediumDesc) -> Result<(), SceneError> {
    if desc.world_bounds.is_empty() {
        return Ok(());
    }
    let g = desc.grids[0].volume.bounds.global;
    let sigma_t = desc
        .sigma_t_per_density()
        .iter()
        .fold(0.0f64, |a, &c| a.max(c as f64));
    let size = desc.world_bounds.max - desc.world_bounds.min;
    let diagonal = size.as_dvec3().length();
    let tau = g.max.max(0.0) as f64 * sigma_t * diagonal;
    if !(tau <= MAX_OPTICAL_DEPTH) {
        return Err(ctx.invalid(
            obj.at("densityScale"),
            format!(
                "the medium is optically too thick: densityScale {} * density up to {} across \
                 {diagonal:.4} m gives an optical depth of {tau:.3e}; the limit is \
                 {MAX_OPTICAL_DEPTH:e}, beyond which 32-bit ray distances cannot resolve its \
                 mean free path (lower densityScale: at this depth the medium is opaque anyway)",
                desc.density_scale, g.max
            ),
        ));
    }
    Ok(())
}

/// Refuses emission that would overflow 32-bit radiance (see [`MAX_EMISSION`]).
fn check_emission_range(ctx: &Ctx, obj: &Obj, desc: &VdbMediumDesc) -> Result<(), SceneError> {
    let color = desc
        .emission_color
        .iter()
        .fold(0.0f64, |a, &c| a.max(c as f64));
    let grid_max = desc
        .grid_named(desc.emission_grid.as_deref())
        .map_or(1.0, |g| g.volume.bounds.global.max.max(0.0) as f64);
    let emission = desc.emission_strength as f64 * color * grid_max;
    if !(emission <= MAX_EMISSION) {
        return Err(ctx.invalid(
            obj.at("emissionStrength"),
            format!(
                "emitted radiance reaches {emission:e} per metre (emissionStrength {} * \
                 emissionColor up to {color} * emission grid values up to {grid_max}); the \
                 limit is {MAX_EMISSION:e}, beyond which 32-bit radiance overflows",
                desc.emission_strength
            ),
        ));
    }
    Ok(())
}

/// Largest dense cell index the density grid may be widened to (4 bytes a cell: 64 MiB, and
/// 8 more a cell for its bounds; a 2048^3-voxel box) so
/// that its walks reach an emission or temperature grid past its own box.
pub const MAX_WIDENED_CELLS: u64 = 1 << 24;

/// Widens the density grid's cell box over the medium's emission box
/// ([`VdbMediumDesc::emission_box`]) where that reaches past it. The walks, and so the
/// emission Brume gathers, end at the density grid's box; Cycles emits in the emission box,
/// so a flame (or the glow of a temperature grid) reaching past the smoke must be walked there
/// too. The new cells hold no density (the background). Beyond [`MAX_WIDENED_CELLS`] the grid
/// is left as it is and a warning names the grids whose emission is cut at the density's box.
fn widen_density_to_emission(ctx: &mut Ctx, obj: &Obj, desc: &mut VdbMediumDesc) {
    if !desc.emits() {
        return;
    }
    let density = &desc.grids[0];
    let emission = desc.emission_box();
    let inside = |d: Aabb| {
        (emission.min - d.min).min_element() >= -1e-3
            && (d.max - emission.max).min_element() >= -1e-3
    };
    if emission.is_empty() || density.index_bounds.is_some_and(inside) {
        return;
    }
    let want = density.index_bounds.unwrap_or(Aabb::EMPTY).union(&emission);
    let reaching: Vec<(&str, String)> = [
        ("emissionGrid", &desc.emission_grid),
        ("temperatureGrid", &desc.temperature_grid),
    ]
    .into_iter()
    .filter_map(|(field, name)| {
        let g = desc.grid_named(name.as_deref())?;
        (g.name != density.name).then(|| (field, g.name.clone()))
    })
    .collect();
    // Whole cells around the wanted box, forgiving a thousandth of a voxel of the mapping's
    // rounding (as the test above).
    let lo = want
        .min
        .to_array()
        .map(|x| ((x + 1e-3) / 8.0).floor() as i64);
    let hi = want
        .max
        .to_array()
        .map(|x| ((x - 1e-3) / 8.0).ceil() as i64);
    let dims: [i64; 3] = std::array::from_fn(|a| hi[a] - lo[a]);
    let cells = dims.iter().map(|&d| d.max(0) as u64).product::<u64>();
    let fits = lo.iter().chain(&hi).all(|&c| c.abs() < (1 << 27)) && cells <= MAX_WIDENED_CELLS;
    // The density grid was loaded for this medium alone (every `load_grid` makes its own),
    // so it is widened in place, without copying its bricks.
    let volume = fits
        .then(|| Arc::get_mut(&mut desc.grids[0].volume))
        .flatten();
    let Some(volume) = volume else {
        for (field, name) in reaching {
            ctx.warn(
                obj.at(field),
                format!(
                    "grid {name:?} reaches so far past the density grid's box that covering \
                     it would take {cells} leaf cells of 8^3 voxels (the limit is \
                     {MAX_WIDENED_CELLS}); Brume renders its emission inside that box only"
                ),
            );
        }
        return;
    };
    volume
        .grid
        .widen_to(lo.map(|c| c as i32), dims.map(|d| d as u32));
    volume.bounds = volume::LeafBounds::build(&volume.grid);
    desc.grids[0].index_bounds = Some(volume.grid.index_bounds());
}

/// Hottest temperature a scene may reach, kelvin. Beyond ~1e13 K the blackbody radiance
/// (`~1.8e-14 T^4`) no longer fits a 32-bit float, so the renderer would produce infinities;
/// 1e12 K leaves margin for the colour and for summing along a path. (Nothing physical burns
/// hotter than ~1e9 K.)
pub const MAX_TEMPERATURE_K: f32 = 1e12;

/// Refuses blackbody media whose temperature (`temperatureScale * t + temperatureOffset` over
/// the temperature grid's value range) can exceed [`MAX_TEMPERATURE_K`]. Found by
/// `tests/files/fuzz_inputs/` (`temperatureOffset: 3e32` rendered infinite radiance).
fn check_temperature_range(ctx: &Ctx, obj: &Obj, desc: &VdbMediumDesc) -> Result<(), SceneError> {
    let Some(name) = &desc.temperature_grid else {
        return Ok(());
    };
    if !(desc.blackbody_intensity > 0.0) {
        return Ok(());
    }
    let Some(grid) = desc.grid_named(Some(name)) else {
        return Ok(());
    };
    let g = grid.volume.bounds.global;
    let (s, o) = (
        desc.temperature_scale as f64,
        desc.temperature_offset as f64,
    );
    let hottest = (s * g.min as f64 + o).max(s * g.max as f64 + o);
    if !(hottest <= MAX_TEMPERATURE_K as f64) {
        return Err(ctx.invalid(
            obj.at("temperatureOffset"),
            format!(
                "temperatures reach {hottest:e} K (temperatureScale {s} * grid values up to {} \
                 + temperatureOffset {o}); the limit is {MAX_TEMPERATURE_K:e} K, beyond which \
                 blackbody emission overflows 32-bit floats",
                g.max
            ),
        ));
    }
    Ok(())
}

/// World bounds of glTF mesh `m` placed by `world`.
fn mesh_bounds(
    ctx: &mut Ctx,
    doc: &gltf::Document,
    buffers: &[Vec<u8>],
    m: usize,
    world: &Mat4,
) -> Result<Aabb, SceneError> {
    let mesh = doc
        .meshes()
        .nth(m)
        .expect("mesh index checked by the caller");
    let mut b = Aabb::EMPTY;
    for prim in mesh.primitives() {
        let pointer = format!("/meshes/{m}/primitives/{}", prim.index());
        if let Some(local) = super::mesh::read_primitive(ctx, buffers, &prim, &pointer)? {
            for p in local.positions {
                b = b.union_point(world.transform_point3(p));
            }
        }
    }
    Ok(b)
}

/// Bounds of the eight transformed corners of `b`.
pub fn transform_aabb(m: &Mat4, b: &Aabb) -> Aabb {
    let mut out = Aabb::EMPTY;
    for k in 0..8 {
        let corner = Vec3::new(
            if k & 1 == 0 { b.min.x } else { b.max.x },
            if k & 2 == 0 { b.min.y } else { b.max.y },
            if k & 4 == 0 { b.min.z } else { b.max.z },
        );
        out = out.union_point(m.transform_point3(corner));
    }
    out
}
