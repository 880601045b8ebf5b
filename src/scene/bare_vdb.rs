//! A scene for a bare `.vdb` file, so `brume render smoke.vdb -o smoke.exr` needs no glTF.
//!
//! The grids are chosen by their usual names: the density is the float grid named `density`,
//! else the file's only float grid; emission comes from a float grid named `flame`, and from
//! `temperature` or `heat`, when the file has them. The scene around the medium:
//! - a camera that frames the density grid's active box (the framing of
//!   [`camera::default_camera`]: the bounding sphere in the vertical field of view with a 10 %
//!   margin, seen from the front and a little above);
//! - a sun (directional light, 3 W/m^2, from above and to the left) and a light blue sky
//!   (`BRUME_environment`), so thin and dense media both read;
//! - `densityScale` such that the densest voxel, spread over the box's mean edge length,
//!   gives an optical depth of [`TARGET_OPTICAL_DEPTH`]: whatever the grid's units and size,
//!   the medium is neither invisible nor a black blot; albedo 0.9 (Principled Volume colour
//!   0.9, no absorption colour), isotropic;
//! - emission scaled the same way: the hottest voxel over the mean edge gives radiance
//!   [`TARGET_EMISSION`] (an orange `emissionGrid`, not a blackbody, since the grid's units
//!   are unknown).
//!
//! [`BareVdbScene::describe`] says all of this in one line, and the glTF it writes is an
//! ordinary Brume scene (`--save-scene`) to edit and render again.
use std::path::{Component, Path, PathBuf};

use glam::Vec3;
use serde_json::{json, Value};

use super::camera::{self, DEFAULT_YFOV};
use super::transform_aabb;
use crate::math::Aabb;
use crate::volume;

/// Optical depth of the densest voxel's value over the active box's mean edge length.
pub const TARGET_OPTICAL_DEPTH: f32 = 10.0;
/// Emitted radiance of the hottest voxel's value over the active box's mean edge length.
pub const TARGET_EMISSION: f32 = 2.0;
/// Principled Volume colour of the medium (its single-scattering albedo with no absorption
/// colour).
pub const ALBEDO: f32 = 0.9;
/// Sun irradiance, W/m^2 (glTF lux read as W/m^2, as everywhere in Brume).
pub const SUN_IRRADIANCE: f32 = 3.0;
/// Sky radiance scale (its colour is a light blue).
pub const SKY_STRENGTH: f32 = 0.35;

/// Grid names that hold emission, in the order they are taken.
const FLAME_NAMES: [&str; 1] = ["flame"];
const TEMPERATURE_NAMES: [&str; 2] = ["temperature", "heat"];

/// The scene made for one `.vdb` file.
#[derive(Clone, Debug)]
pub struct BareVdbScene {
    /// The `.vdb` file.
    pub vdb: PathBuf,
    /// Name of the density grid.
    pub density_grid: String,
    /// Largest density value.
    pub density_max: f32,
    /// Emission grid and its largest value, if any.
    pub emission: Option<(String, f32)>,
    /// World-space box of the density grid's active voxels.
    pub active_box: Aabb,
    /// Extinction per unit density per metre.
    pub density_scale: f32,
    /// Emission strength per unit of the emission grid.
    pub emission_strength: f32,
    /// Camera node translation and rotation (quaternion x, y, z, w).
    pub camera_translation: Vec3,
    pub camera_rotation: [f32; 4],
}

/// True for a path that names a `.vdb` file (case-insensitive extension).
pub fn is_vdb(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("vdb"))
}

/// Reads `vdb`'s grids and makes its scene. Errors name the file: no float grid, several
/// float grids and none named `density`, a grid the load policy refuses, an empty grid.
pub fn synthesize(vdb: &Path) -> Result<BareVdbScene, String> {
    let file = brume_ffi::VdbFile::open(vdb).map_err(|e| e.message)?;
    let floats: Vec<&str> = file
        .grids()
        .iter()
        .filter(|g| g.value_type == "float")
        .map(|g| g.name.as_str())
        .collect();
    let density_grid = match floats.iter().find(|n| **n == "density") {
        Some(n) => n.to_string(),
        None if floats.len() == 1 => floats[0].to_string(),
        None if floats.is_empty() => {
            return Err(format!(
                "{}: no float grid to render (grids: {})",
                vdb.display(),
                grid_list(&file)
            ))
        }
        None => {
            return Err(format!(
                "{}: no grid named 'density' and several float grids ({}); write a glTF scene \
                 naming one in BRUME_medium_vdb.densityGrid",
                vdb.display(),
                floats.join(", ")
            ))
        }
    };
    let load = |name: &str| {
        volume::load_grid_from(&file, name, volume::ConversionPolicy::default())
            .map_err(|e| e.to_string())
    };
    let density = load(&density_grid)?;
    let info = &density.info;
    let Some((lo, hi)) = info.active_bbox else {
        return Err(format!(
            "{}: grid '{density_grid}' has no active voxels",
            vdb.display()
        ));
    };
    let index_box = Aabb::new(
        Vec3::new(lo[0] as f32, lo[1] as f32, lo[2] as f32) - Vec3::splat(0.5),
        Vec3::new(hi[0] as f32, hi[1] as f32, hi[2] as f32) + Vec3::splat(0.5),
    );
    let world_from_index = glam::DMat4::from(density.grid.world_from_index).as_mat4();
    let active_box = transform_aabb(&world_from_index, &index_box);
    let extent = active_box.max - active_box.min;
    let mean_edge = ((extent.x + extent.y + extent.z) / 3.0).max(1e-6);
    let density_max = density.bounds.stats().global_max;
    if !(density_max > 0.0) {
        return Err(format!(
            "{}: grid '{density_grid}' holds no positive density",
            vdb.display()
        ));
    }
    let density_scale = TARGET_OPTICAL_DEPTH / (density_max * mean_edge);

    let pick = |names: &[&str]| {
        names
            .iter()
            .find(|n| floats.contains(n) && **n != density_grid)
            .map(|n| n.to_string())
    };
    let emission_grid = pick(&FLAME_NAMES).or_else(|| pick(&TEMPERATURE_NAMES));
    let emission = match emission_grid {
        Some(name) => {
            let g = load(&name)?;
            let max = g.bounds.stats().global_max;
            (max > 0.0).then_some((name, max))
        }
        None => None,
    };
    let emission_strength = emission
        .as_ref()
        .map_or(0.0, |(_, max)| TARGET_EMISSION / (max * mean_edge));

    let cam = camera::default_camera(&active_box);
    let (_, rotation, translation) = cam.world_from_camera.to_scale_rotation_translation();
    Ok(BareVdbScene {
        vdb: vdb.to_path_buf(),
        density_grid,
        density_max,
        emission,
        active_box,
        density_scale,
        emission_strength,
        camera_translation: translation,
        camera_rotation: rotation.to_array(),
    })
}

fn grid_list(file: &brume_ffi::VdbFile) -> String {
    let names: Vec<String> = file
        .grids()
        .iter()
        .map(|g| format!("'{}' ({})", g.name, g.value_type))
        .collect();
    if names.is_empty() {
        "none".to_string()
    } else {
        names.join(", ")
    }
}

impl BareVdbScene {
    /// One line: what was chosen, for the render log.
    pub fn describe(&self) -> String {
        let e = &self.active_box;
        let emission = match &self.emission {
            Some((name, max)) => format!(
                ", emission grid '{name}' (max {max:.3}) x {:.4}",
                self.emission_strength
            ),
            None => String::new(),
        };
        format!(
            "{}: density grid '{}' (max {:.3}), densityScale {:.4}, albedo {ALBEDO}{emission}; \
             camera framing the active box [{:.3}, {:.3}, {:.3}]..[{:.3}, {:.3}, {:.3}], \
             sun {SUN_IRRADIANCE} W/m^2 and sky",
            self.vdb.display(),
            self.density_grid,
            self.density_max,
            self.density_scale,
            e.min.x,
            e.min.y,
            e.min.z,
            e.max.x,
            e.max.y,
            e.max.z,
        )
    }

    /// The scene as glTF JSON, for a `.gltf` file written in `scene_dir` (the `.vdb` is named
    /// by a path relative to it).
    pub fn gltf(&self, scene_dir: &Path) -> Value {
        let uri = vdb_uri(&self.vdb, scene_dir);
        let mut medium = json!({
            "uri": uri,
            "densityGrid": self.density_grid,
            "densityScale": self.density_scale,
            "color": [ALBEDO, ALBEDO, ALBEDO],
            "absorptionColor": [0.0, 0.0, 0.0],
            "anisotropy": 0.0,
        });
        if let Some((name, _)) = &self.emission {
            medium["emissionGrid"] = json!(name);
            medium["emissionStrength"] = json!(self.emission_strength);
            medium["emissionColor"] = json!([1.0, 0.45, 0.1]);
        }
        // The sun: glTF directional lights shine along the node's -Z; turned to come from
        // above, the left and the front of the camera.
        let sun_dir = Vec3::new(0.7, -0.7, -0.25).normalize();
        let sun_rot = glam::Quat::from_rotation_arc(Vec3::NEG_Z, sun_dir);
        let t = self.camera_translation;
        json!({
            "asset": {"version": "2.0", "generator": "brume render (a scene for a bare .vdb)"},
            "scene": 0,
            "scenes": [{"nodes": [0, 1, 2]}],
            "nodes": [
                {
                    "name": "camera",
                    "camera": 0,
                    "translation": [t.x, t.y, t.z],
                    "rotation": self.camera_rotation,
                },
                {
                    "name": "sun",
                    "rotation": sun_rot.to_array(),
                    "extensions": {"KHR_lights_punctual": {"light": 0}},
                },
                {
                    "name": "medium",
                    "extensions": {"BRUME_medium_vdb": medium},
                },
            ],
            "cameras": [{
                "name": "camera",
                "type": "perspective",
                "perspective": {"yfov": DEFAULT_YFOV, "znear": 0.01 * self.radius()},
            }],
            "extensions": {
                "KHR_lights_punctual": {"lights": [{
                    "name": "sun",
                    "type": "directional",
                    "color": [1.0, 0.96, 0.9],
                    "intensity": SUN_IRRADIANCE,
                }]},
                "BRUME_environment": {"color": [0.45, 0.62, 1.0], "strength": SKY_STRENGTH},
            },
            "extensionsUsed": ["KHR_lights_punctual", "BRUME_medium_vdb", "BRUME_environment"],
        })
    }

    fn radius(&self) -> f32 {
        (0.5 * (self.active_box.max - self.active_box.min).length()).max(1e-3)
    }

    /// Writes the scene to `path` (a `.gltf`).
    pub fn write(&self, path: &Path) -> Result<(), String> {
        let dir = path.parent().filter(|d| !d.as_os_str().is_empty());
        let dir = dir.unwrap_or(Path::new("."));
        let text = serde_json::to_string_pretty(&self.gltf(dir)).map_err(|e| e.to_string())?;
        std::fs::write(path, text + "\n").map_err(|e| format!("{}: {e}", path.display()))
    }
}

/// The `.vdb`'s URI seen from `scene_dir`: a relative path (with `..` where needed) when both
/// are absolute paths on the same root, else the absolute path; percent-encoded where glTF
/// URIs need it.
fn vdb_uri(vdb: &Path, scene_dir: &Path) -> String {
    let abs = |p: &Path| {
        std::fs::canonicalize(p).unwrap_or_else(|_| {
            std::env::current_dir()
                .map(|d| d.join(p))
                .unwrap_or_else(|_| p.to_path_buf())
        })
    };
    let (vdb_abs, dir_abs) = (abs(vdb), abs(scene_dir));
    let (a, d): (Vec<Component>, Vec<Component>) = (
        vdb_abs.components().collect(),
        dir_abs.components().collect(),
    );
    let common = a.iter().zip(&d).take_while(|(x, y)| x == y).count();
    let names = |cs: &[Component]| cs.iter().all(|c| matches!(c, Component::Normal(_)));
    let parts: Vec<String> = if common > 0 && names(&a[common..]) && names(&d[common..]) {
        let up = std::iter::repeat("..".to_string()).take(d.len() - common);
        up.chain(
            a[common..]
                .iter()
                .map(|c| encode(&c.as_os_str().to_string_lossy())),
        )
        .collect()
    } else {
        let mut out = vec![String::new()];
        out.extend(a.iter().filter_map(|c| match c {
            Component::Normal(s) => Some(encode(&s.to_string_lossy())),
            _ => None,
        }));
        out
    };
    parts.join("/")
}

/// Percent-encodes what a glTF URI cannot hold as is.
fn encode(name: &str) -> String {
    let mut out = String::new();
    for b in name.bytes() {
        match b {
            b'%' | b' ' | b'#' | b'?' => out.push_str(&format!("%{b:02X}")),
            _ => out.push(b as char),
        }
    }
    out
}

/// A scene file made for a bare `.vdb`: at the path asked for, or a temporary file removed
/// when this is dropped.
pub struct PreparedScene {
    path: PathBuf,
    temporary: bool,
}

impl PreparedScene {
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for PreparedScene {
    fn drop(&mut self) {
        if self.temporary {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

/// For `brume render`: when `scene` is a `.vdb`, makes its scene, prints [`BareVdbScene::describe`]
/// on stderr and writes the glTF to `save` (or to a temporary file); `None` for any other
/// scene. `save` with a scene that is not a `.vdb` is an error.
pub fn prepare(scene: &Path, save: Option<&Path>) -> Result<Option<PreparedScene>, String> {
    if !is_vdb(scene) {
        return match save {
            Some(_) => Err(format!(
                "--save-scene writes the scene made for a bare .vdb; {} is already a scene",
                scene.display()
            )),
            None => Ok(None),
        };
    }
    let bare = synthesize(scene)?;
    eprintln!("scene for {}", bare.describe());
    let (path, temporary) = match save {
        Some(p) => (p.to_path_buf(), false),
        None => (
            std::env::temp_dir().join(format!("brume-bare-vdb-{}.gltf", std::process::id())),
            true,
        ),
    };
    let prepared = PreparedScene { path, temporary };
    bare.write(&prepared.path)?;
    if !temporary {
        eprintln!("scene written to {}", prepared.path.display());
    }
    Ok(Some(prepared))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uris_are_relative_to_the_scene_and_encoded() {
        let d = Path::new("/nowhere/scenes");
        assert_eq!(vdb_uri(&d.join("a b/x%.vdb"), d), "a%20b/x%25.vdb");
        assert_eq!(
            vdb_uri(Path::new("/nowhere/vdb/s.vdb"), &d.join("q")),
            "../../vdb/s.vdb"
        );
    }

    #[test]
    fn the_extension_decides() {
        assert!(is_vdb(Path::new("a/smoke.VDB")));
        assert!(!is_vdb(Path::new("a/smoke.gltf")));
    }
}
