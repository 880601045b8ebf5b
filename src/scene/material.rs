//! Surface materials (glTF metallic-roughness, approximated) and the homogeneous media that
//! `KHR_materials_volume` puts inside closed meshes.
//!
//! What Brume keeps of a glTF material, and what it approximates:
//! - base colour factor and texture, metallic and roughness factors: enough for a diffuse lobe
//!   plus a rough GGX specular lobe. The metallic-roughness *texture*, normal and occlusion
//!   textures are ignored (a warning says so).
//! - emission = `emissiveFactor * emissiveStrength` (`KHR_materials_emissive_strength`), read as
//!   radiance in W m^-2 sr^-1 with the same factor 1 as the lights (see `lights.rs`).
//! - `KHR_materials_transmission` factor and `KHR_materials_ior` (default 1.5) for dielectrics.
//! - Base-colour and emissive textures (with `KHR_texture_transform`) are decoded and sampled
//!   by `texture.rs`.
use bytemuck::{Pod, Zeroable};

use super::error::{Ctx, SceneError};
use super::json::{check_all, check_f32, Obj};
use super::texture::{texture_ref, TextureRef};
use super::{BRUME_MATERIALS_VOLUME_SCATTERING, NO_INDEX};
use crate::volume::phases::Phase;

/// Surface description, 64 bytes, uploaded as is.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Material {
    /// Linear RGB base colour factor and alpha.
    pub base_color: [f32; 4],
    /// Emitted radiance, W m^-2 sr^-1 (`emissiveFactor * emissiveStrength`).
    pub emission: [f32; 3],
    /// Metalness in [0, 1].
    pub metallic: f32,
    /// Perceptual roughness in [0, 1] (GGX alpha = roughness^2).
    pub roughness: f32,
    /// Specular transmission weight in [0, 1] (`KHR_materials_transmission`).
    pub transmission: f32,
    /// Index of refraction of the interior (`KHR_materials_ior`, default 1.5).
    pub ior: f32,
    /// Index into `Scene::textures` of the base colour texture, `NO_INDEX` if none.
    pub base_color_texture: u32,
    /// Index into `Scene::homogeneous_media` of the medium this closed surface encloses,
    /// `NO_INDEX` if none.
    pub interior_medium: u32,
    /// Index into `Scene::textures` of the emissive texture, `NO_INDEX` if none.
    pub emissive_texture: u32,
    /// `MATERIAL_DOUBLE_SIDED` and friends.
    pub flags: u32,
    /// Explicit padding to 64 bytes.
    pub _pad: u32,
}
const _: () = assert!(std::mem::size_of::<Material>() == 64);

/// The glTF `doubleSided` flag.
pub const MATERIAL_DOUBLE_SIDED: u32 = 1;

impl Default for Material {
    /// The glTF default material: white, fully metallic, fully rough.
    fn default() -> Self {
        Self {
            base_color: [1.0; 4],
            emission: [0.0; 3],
            metallic: 1.0,
            roughness: 1.0,
            transmission: 0.0,
            ior: 1.5,
            base_color_texture: NO_INDEX,
            interior_medium: NO_INDEX,
            emissive_texture: NO_INDEX,
            flags: 0,
            _pad: 0,
        }
    }
}

/// A homogeneous medium: coefficients per metre, linear RGB, and its phase function.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HomogeneousMedium {
    /// Absorption coefficient sigma_a, m^-1.
    pub sigma_a: [f32; 3],
    /// Scattering coefficient sigma_s, m^-1.
    pub sigma_s: [f32; 3],
    /// The phase function (`BRUME_materials_volume_scattering`'s `phase`, else
    /// Henyey-Greenstein with its `anisotropy`).
    pub phase: Phase,
    /// Index into `Scene::materials` of the material whose closed surfaces bound it.
    pub material: u32,
}

impl HomogeneousMedium {
    /// Extinction sigma_t = sigma_a + sigma_s, m^-1.
    pub fn sigma_t(&self) -> [f32; 3] {
        [0, 1, 2].map(|c| self.sigma_a[c] + self.sigma_s[c])
    }

    /// The medium that `KHR_materials_volume` describes, with Brume's scattering albedo.
    ///
    /// The spec defines attenuation only: light travelling `attenuationDistance` metres keeps
    /// the fraction `attenuationColor`, so per channel
    /// `sigma_t = -ln(attenuationColor) / attenuationDistance`, and an infinite distance (the
    /// default) means no attenuation. `albedo` splits sigma_t into `sigma_s = albedo * sigma_t`
    /// and `sigma_a = (1 - albedo) * sigma_t`; albedo 0 keeps the spec's purely absorbing
    /// reading.
    pub fn from_attenuation(
        attenuation_color: [f32; 3],
        attenuation_distance: f32,
        albedo: [f32; 3],
        phase: Phase,
        material: u32,
    ) -> Self {
        let sigma_t = attenuation_color.map(|c| {
            if attenuation_distance.is_infinite() {
                0.0
            } else {
                // A channel with colour 0 would be opaque (sigma_t = inf); the loader clamps
                // the colour first, and max(0) turns the -0.0 of colour 1 into +0.0.
                (-c.ln() / attenuation_distance).max(0.0)
            }
        });
        Self {
            sigma_a: [0, 1, 2].map(|c| (1.0 - albedo[c]) * sigma_t[c]),
            sigma_s: [0, 1, 2].map(|c| albedo[c] * sigma_t[c]),
            phase,
            material,
        }
    }
}

/// Smallest attenuation colour component accepted; 0 would mean infinite extinction.
pub const MIN_ATTENUATION_COLOR: f32 = 1e-6;

/// What [`read_materials`] produces.
pub struct MaterialTables {
    /// glTF materials in file order, then the glTF default material.
    pub materials: Vec<Material>,
    /// Names of `materials`.
    pub names: Vec<Option<String>>,
    pub media: Vec<HomogeneousMedium>,
    pub textures: Vec<TextureRef>,
}

/// Reads all materials (plus the glTF default material, appended last) and the homogeneous
/// media of the volumetric ones.
pub fn read_materials(ctx: &mut Ctx, doc: &gltf::Document) -> Result<MaterialTables, SceneError> {
    let mut materials = Vec::new();
    let mut media = Vec::new();
    let mut textures: Vec<TextureRef> = Vec::new();
    let mut names = Vec::new();
    for mat in doc.materials() {
        let i = mat.index().expect("document materials have indices");
        let at = |p: &str| format!("/materials/{i}{p}");
        let mut m = read_factors(ctx, &mat, &at)?;
        read_textures(ctx, &mat, &mut textures, &mut m, &at);
        let has_transmission = read_dielectric(ctx, &mat, &mut m, &at)?;
        if let Some(medium) = read_interior_medium(ctx, &mat, i, has_transmission, &at)? {
            m.interior_medium = media.len() as u32;
            media.push(medium);
        }
        materials.push(m);
        names.push(mat.name().map(str::to_owned));
    }
    materials.push(Material::default());
    names.push(Some("glTF default material".into()));
    Ok(MaterialTables {
        materials,
        names,
        media,
        textures,
    })
}

/// The material's factors: base colour, metallic, roughness, the double-sided flag and the
/// emission (`emissiveFactor * emissiveStrength`, which must stay finite).
fn read_factors(
    ctx: &mut Ctx,
    mat: &gltf::Material,
    at: &impl Fn(&str) -> String,
) -> Result<Material, SceneError> {
    let pbr = mat.pbr_metallic_roughness();
    let mut m = Material {
        base_color: check_all(
            ctx,
            pbr.base_color_factor(),
            &at("/pbrMetallicRoughness/baseColorFactor"),
            0.0,
            1.0,
        )?,
        metallic: check_f32(
            ctx,
            pbr.metallic_factor(),
            at("/pbrMetallicRoughness/metallicFactor"),
            0.0,
            1.0,
        )?,
        roughness: check_f32(
            ctx,
            pbr.roughness_factor(),
            at("/pbrMetallicRoughness/roughnessFactor"),
            0.0,
            1.0,
        )?,
        flags: if mat.double_sided() {
            MATERIAL_DOUBLE_SIDED
        } else {
            0
        },
        ..Material::default()
    };
    let strength = check_f32(
        ctx,
        mat.emissive_strength().unwrap_or(1.0),
        at("/extensions/KHR_materials_emissive_strength/emissiveStrength"),
        0.0,
        f32::MAX,
    )?;
    let factor = check_all(ctx, mat.emissive_factor(), &at("/emissiveFactor"), 0.0, 1.0)?;
    m.emission = factor.map(|c| c * strength);
    if !m.emission.iter().all(|c| c.is_finite()) {
        return Err(ctx.invalid(
            at("/extensions/KHR_materials_emissive_strength/emissiveStrength"),
            "emission overflows to infinity",
        ));
    }
    Ok(m)
}

/// Registers the base-colour and emissive textures of `mat` in `textures` and points `m` at
/// them; warns about the texture kinds Brume ignores.
fn read_textures(
    ctx: &mut Ctx,
    mat: &gltf::Material,
    textures: &mut Vec<TextureRef>,
    m: &mut Material,
    at: &impl Fn(&str) -> String,
) {
    let pbr = mat.pbr_metallic_roughness();
    if let Some(info) = pbr.base_color_texture() {
        m.base_color_texture = texture_ref(
            ctx,
            textures,
            &info,
            &at("/pbrMetallicRoughness/baseColorTexture"),
        );
    }
    if let Some(info) = mat.emissive_texture() {
        m.emissive_texture = texture_ref(ctx, textures, &info, &at("/emissiveTexture"));
    }
    if pbr.metallic_roughness_texture().is_some()
        || mat.normal_texture().is_some()
        || mat.occlusion_texture().is_some()
    {
        ctx.warn(
            at(""),
            "metallic-roughness, normal and occlusion textures are ignored (factors only)",
        );
    }
}

/// Reads `KHR_materials_ior` and `KHR_materials_transmission` into `m`; returns whether the
/// transmission extension is present (the volume extension needs it).
fn read_dielectric(
    ctx: &mut Ctx,
    mat: &gltf::Material,
    m: &mut Material,
    at: &impl Fn(&str) -> String,
) -> Result<bool, SceneError> {
    if let Some(ior) = mat
        .extension_value("KHR_materials_ior")
        .and_then(|v| v.get("ior"))
    {
        let obj_ptr = at("/extensions/KHR_materials_ior/ior");
        m.ior = super::json::check_number(ctx, ior, obj_ptr, 1.0, 10.0, false)?;
    }
    let transmission = mat.transmission();
    if let Some(t) = &transmission {
        m.transmission = check_f32(
            ctx,
            t.transmission_factor(),
            at("/extensions/KHR_materials_transmission/transmissionFactor"),
            0.0,
            1.0,
        )?;
    }
    Ok(transmission.is_some())
}

/// The homogeneous medium that material `i`'s `KHR_materials_volume` (with
/// `BRUME_materials_volume_scattering`) puts inside its closed surfaces; `None`, with a
/// warning saying why, where the spec gives it no volume.
fn read_interior_medium(
    ctx: &mut Ctx,
    mat: &gltf::Material,
    i: usize,
    has_transmission: bool,
    at: &impl Fn(&str) -> String,
) -> Result<Option<HomogeneousMedium>, SceneError> {
    let Some(vol) = mat.volume() else {
        if mat
            .extension_value(BRUME_MATERIALS_VOLUME_SCATTERING)
            .is_some()
        {
            ctx.warn(
                at(&format!("/extensions/{BRUME_MATERIALS_VOLUME_SCATTERING}")),
                "ignored without KHR_materials_volume",
            );
        }
        return Ok(None);
    };
    let vp = at("/extensions/KHR_materials_volume");
    let thickness = check_f32(
        ctx,
        vol.thickness_factor(),
        format!("{vp}/thicknessFactor"),
        0.0,
        f32::MAX,
    )?;
    let distance = vol.attenuation_distance();
    if distance.is_nan() || distance <= 0.0 {
        return Err(ctx.invalid(
            format!("{vp}/attenuationDistance"),
            format!("{distance} must be > 0 (omit it for no attenuation)"),
        ));
    }
    let mut color = check_all(
        ctx,
        vol.attenuation_color(),
        &format!("{vp}/attenuationColor"),
        0.0,
        1.0,
    )?;
    let (albedo, phase) = read_volume_scattering(
        ctx,
        mat,
        &at(&format!("/extensions/{BRUME_MATERIALS_VOLUME_SCATTERING}")),
    )?;
    if !has_transmission {
        // The spec: the volume extension only has an effect together with transmission.
        ctx.warn(
            &vp,
            "KHR_materials_volume without KHR_materials_transmission has no effect; no medium",
        );
        return Ok(None);
    }
    if thickness == 0.0 {
        // The spec: thickness 0 (the default) means thin-walled, i.e. no volume.
        ctx.warn(
            format!("{vp}/thicknessFactor"),
            "thicknessFactor 0 makes the material thin-walled; no medium",
        );
        return Ok(None);
    }
    if color.iter().any(|&c| c < MIN_ATTENUATION_COLOR) {
        ctx.warn(
            format!("{vp}/attenuationColor"),
            format!("components below {MIN_ATTENUATION_COLOR} clamped (0 would be opaque)"),
        );
        color = color.map(|c| c.max(MIN_ATTENUATION_COLOR));
    }
    Ok(Some(HomogeneousMedium::from_attenuation(
        color, distance, albedo, phase, i as u32,
    )))
}

/// `BRUME_materials_volume_scattering`: `albedo` (RGB in [0, 1], default 0: purely absorbing,
/// as `KHR_materials_volume` alone implies) and the phase function: the `phase` object as
/// `BRUME_medium_vdb` reads it, else Henyey-Greenstein with `anisotropy` g in (-1, 1).
fn read_volume_scattering(
    ctx: &mut Ctx,
    mat: &gltf::Material,
    pointer: &str,
) -> Result<([f32; 3], Phase), SceneError> {
    let Some(value) = mat.extension_value(BRUME_MATERIALS_VOLUME_SCATTERING) else {
        return Ok(([0.0; 3], Phase::hg(0.0)));
    };
    let obj = Obj::new(ctx, value, pointer.to_string())?;
    obj.warn_unknown(ctx, &["albedo", "anisotropy", "phase"]);
    let albedo = obj.rgb(ctx, "albedo", [0.0; 3], 0.0, 1.0)?;
    let g = obj.number(ctx, "anisotropy", 0.0, -1.0, 1.0, true)?;
    let phase = super::phase::read_phase(ctx, &obj)?.unwrap_or(Phase::hg(g));
    Ok((albedo, phase))
}
