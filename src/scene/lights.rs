//! Punctual lights (`KHR_lights_punctual`) and the environment (`BRUME_environment`).
//!
//! # Units
//! glTF gives point and spot intensity in candela (lm/sr) and directional intensity in lux
//! (lm/m^2). Brume renders radiometric RGB: W/sr and W/m^2. Brume deliberately uses the factor
//! [`RADIOMETRIC_PER_PHOTOMETRIC`] = 1, i.e. the numbers are taken as W/sr and W/m^2 directly,
//! as Blender's glTF importer does in its raw ("Unitless"/compat) lighting mode, rather than
//! dividing by 683 lm/W (the luminous efficacy at 555 nm). Reasons: Cycles, our reference,
//! takes sun strength as irradiance in W/m^2, so a scene written with `intensity: 3` renders
//! the same in both; the emissive materials and `BRUME_environment` are unitless radiances with
//! the same factor 1, so lights and emitters stay in proportion; and a 1/683 factor would only
//! move the exposure. A file authored in physical photometric units (a 100 000 lux sun) renders
//! correspondingly bright: scale the exposure, or divide by 683 when authoring.
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use std::path::PathBuf;

use super::envmap::{read_environment_image, EnvironmentImage};
use super::error::{Ctx, SceneError};
use super::json::{check_all, check_f32, Obj};
use super::nodes::PlacedNode;
use super::BRUME_ENVIRONMENT;
use std::sync::Arc;

/// W/sr per cd and W/m^2 per lux: deliberately 1 (see the module documentation).
pub const RADIOMETRIC_PER_PHOTOMETRIC: f32 = 1.0;

/// `PunctualLight::kind` values.
pub const LIGHT_POINT: u32 = 0;
pub const LIGHT_SPOT: u32 = 1;
pub const LIGHT_DIRECTIONAL: u32 = 2;

/// A punctual light in world space, 64 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct PunctualLight {
    /// World-space position, metres (unused for directional lights).
    pub position: [f32; 3],
    /// `LIGHT_POINT`, `LIGHT_SPOT` or `LIGHT_DIRECTIONAL`.
    pub kind: u32,
    /// Unit world-space direction the light travels (the node's -Z), spot and directional.
    pub direction: [f32; 3],
    /// glTF `range` cut-off in metres; +inf when absent (Brume renders physically and ignores
    /// it; kept for completeness).
    pub range: f32,
    /// `color * intensity * RADIOMETRIC_PER_PHOTOMETRIC`: radiant intensity W/sr (point,
    /// spot) or irradiance W/m^2 on a surface facing the light (directional).
    pub intensity: [f32; 3],
    /// Cosine of the spot's inner cone angle (full intensity inside).
    pub cos_inner: f32,
    /// Cosine of the spot's outer cone angle (zero outside).
    pub cos_outer: f32,
    /// Explicit padding to 64 bytes.
    pub _pad: [f32; 3],
}
const _: () = assert!(std::mem::size_of::<PunctualLight>() == 64);

/// Lights placed by the scene's nodes, in node order, with the placement (in
/// `nodes::place_nodes`' order) of each.
pub fn read_lights(
    ctx: &mut Ctx,
    doc: &gltf::Document,
    nodes: &[PlacedNode],
) -> Result<ReadLights, SceneError> {
    let mut out = Vec::new();
    let mut placements = Vec::new();
    let mut names = Vec::new();
    for (placement, placed) in nodes.iter().enumerate() {
        let node = placed.in_doc(doc);
        let Some(light) = node.light() else { continue };
        let at = |p: &str| {
            format!(
                "/extensions/KHR_lights_punctual/lights/{}{p}",
                light.index()
            )
        };
        let color = check_all(ctx, light.color(), &at("/color"), 0.0, 1.0)?;
        let intensity = check_f32(ctx, light.intensity(), at("/intensity"), 0.0, f32::MAX)?;
        let range = match light.range() {
            Some(r) => check_f32(ctx, r, at("/range"), f32::MIN_POSITIVE, f32::MAX)?,
            None => f32::INFINITY,
        };
        let world = placed.world_from_node;
        let direction = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
        if direction == Vec3::ZERO {
            return Err(ctx.invalid(
                format!("/nodes/{}", placed.node),
                "light node's transform collapses its direction",
            ));
        }
        let (kind, cos_inner, cos_outer) = match light.kind() {
            gltf::khr_lights_punctual::Kind::Point => (LIGHT_POINT, -1.0, -1.0),
            gltf::khr_lights_punctual::Kind::Directional => (LIGHT_DIRECTIONAL, 1.0, 1.0),
            gltf::khr_lights_punctual::Kind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => {
                let half_pi = std::f32::consts::FRAC_PI_2;
                let outer = check_f32(
                    ctx,
                    outer_cone_angle,
                    at("/spot/outerConeAngle"),
                    f32::MIN_POSITIVE,
                    half_pi,
                )?;
                let inner = check_f32(
                    ctx,
                    inner_cone_angle,
                    at("/spot/innerConeAngle"),
                    0.0,
                    half_pi,
                )?;
                if inner >= outer {
                    return Err(ctx.invalid(
                        at("/spot/innerConeAngle"),
                        format!("{inner} must be less than outerConeAngle {outer}"),
                    ));
                }
                (LIGHT_SPOT, inner.cos(), outer.cos())
            }
        };
        out.push(PunctualLight {
            position: world.transform_point3(Vec3::ZERO).to_array(),
            kind,
            direction: direction.to_array(),
            range,
            intensity: color.map(|c| c * intensity * RADIOMETRIC_PER_PHOTOMETRIC),
            cos_inner,
            cos_outer,
            _pad: [0.0; 3],
        });
        placements.push(placement);
        names.push(light.name().or(node.name()).map(str::to_owned));
    }
    Ok(ReadLights {
        lights: out,
        light_placements: placements,
        light_names: names,
    })
}

/// The punctual lights of a document, with each one's placement (index into the placed
/// nodes) and name (the light's, else its node's).
pub struct ReadLights {
    pub lights: Vec<PunctualLight>,
    pub light_placements: Vec<usize>,
    pub light_names: Vec<Option<String>>,
}

/// Light arriving from infinitely far away in every direction not blocked by the scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Environment {
    /// Constant radiance, W m^-2 sr^-1: `color * strength`. Zero without `BRUME_environment`.
    /// With a map, the radiance from direction `w` is `map(w) * radiance`.
    pub radiance: [f32; 3],
    /// Absolute path of the equirectangular map (`uri`), when given.
    pub map: Option<PathBuf>,
    /// Its decoded pixels.
    pub image: Option<Arc<EnvironmentImage>>,
    /// Euler XYZ rotation in radians of Blender's Mapping node (type Point) applied to the
    /// lookup direction in Blender's Z-up axes; see `render::envmap` for the convention.
    pub rotation: [f32; 3],
}

/// Reads the scene-level `BRUME_environment` extension:
/// `{"color": [r, g, b], "strength": s, "uri": "optional.exr|.hdr", "rotation": [rx, ry, rz]}`.
pub fn read_environment(
    ctx: &mut Ctx,
    doc: &gltf::Document,
    base: &std::path::Path,
) -> Result<Environment, SceneError> {
    let Some(value) = doc.extension_value(BRUME_ENVIRONMENT) else {
        return Ok(Environment {
            radiance: [0.0; 3],
            map: None,
            image: None,
            rotation: [0.0; 3],
        });
    };
    let obj = Obj::new(ctx, value, format!("/extensions/{BRUME_ENVIRONMENT}"))?;
    obj.warn_unknown(ctx, &["color", "strength", "uri", "rotation"]);
    let color = obj.rgb(ctx, "color", [1.0; 3], 0.0, 1.0)?;
    let strength = obj.number(ctx, "strength", 1.0, 0.0, f32::MAX, false)?;
    // Any finite angle; Blender does not wrap them either.
    let rotation = obj.rgb(ctx, "rotation", [0.0; 3], -1e6, 1e6)?;
    let (map, image) = match obj.string(ctx, "uri")? {
        None => (None, None),
        Some(uri) => {
            let path = super::document::resolve_uri(ctx, &uri, base, &obj.at("uri"))?;
            if !path.is_file() {
                return Err(ctx.invalid(
                    obj.at("uri"),
                    format!(
                        "environment map {} does not exist or is not a file",
                        path.display()
                    ),
                ));
            }
            let decoded = read_environment_image(&path).map_err(|e| {
                ctx.invalid(
                    obj.at("uri"),
                    format!("environment map {}: {e}", path.display()),
                )
            })?;
            if decoded.negative_pixels > 0 {
                ctx.warn(
                    obj.at("uri"),
                    format!(
                        "environment map {}: {} pixels with negative components were clamped to 0",
                        path.display(),
                        decoded.negative_pixels
                    ),
                );
            }
            (Some(path), Some(Arc::new(decoded.image)))
        }
    };
    Ok(Environment {
        radiance: color.map(|c| c * strength),
        map,
        image,
        rotation,
    })
}
