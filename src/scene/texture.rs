//! Base-colour and emissive textures: glTF images decoded once at load (PNG and JPEG through
//! the `image` crate), sRGB-decoded to linear floats, and looked up with the sampler's wrap
//! and filter modes and `KHR_texture_transform`.
//!
//! The lookup is written once here; `shaders/common/textures.wgsl` mirrors it line by line
//! and the texels go to the GPU as they are, so both backends read the same linear values.
//!
//! Conventions (glTF 2.0): texture coordinate (0, 0) is the image's top-left corner, `u` grows
//! to the right and `v` downwards, and texel `(i, j)` has its centre at
//! `((i + 0.5) / width, (j + 0.5) / height)`. Bilinear filtering blends the four texels whose
//! centres surround the point (OpenGL's `LINEAR`, Cycles' "Linear"); `NEAREST` reads the texel
//! containing it. No mip-mapping: a path tracer integrates the pixel footprint with its samples,
//! so a minifying `*_MIPMAP_*` filter is read as its magnification counterpart.
use std::io::Cursor;
use std::path::Path;

use glam::{Vec2, Vec3, Vec4};

use super::error::{Ctx, SceneError};
use super::{Material, Scene, NO_INDEX};
use crate::math::luminance;

/// `REPEAT`: the image tiles the plane.
pub const WRAP_REPEAT: u32 = 0;
/// `CLAMP_TO_EDGE`: coordinates outside [0, 1] read the border texels.
pub const WRAP_CLAMP: u32 = 1;
/// `MIRRORED_REPEAT`: the image tiles the plane, every other copy mirrored.
pub const WRAP_MIRROR: u32 = 2;

/// Largest width or height accepted, so a corrupt header cannot ask for gigabytes.
pub const MAX_TEXTURE_SIZE: u32 = 16384;

/// A texture as the materials use it: an image, how it is sampled, and how the texture
/// coordinates are transformed first. Two uses of one glTF texture with different transforms
/// are two entries.
#[derive(Clone, Debug, PartialEq)]
pub struct TextureRef {
    /// glTF texture index.
    pub texture: usize,
    /// glTF image index.
    pub image: usize,
    /// Image URI as written in the file (`None` for images in buffer views).
    pub uri: Option<String>,
    /// Index into `Scene::images`.
    pub image_slot: u32,
    /// `WRAP_*` along u and v.
    pub wrap: [u32; 2],
    /// The sampler's magnification filter is `NEAREST` (otherwise bilinear).
    pub nearest: bool,
    /// `KHR_texture_transform` as an affine map, rows `(a, b, c)` and `(d, e, f)`:
    /// `u' = a u + b v + c`, `v' = d u + e v + f`. Identity without the extension.
    pub transform: [f32; 6],
}

/// The identity texture transform.
pub const IDENTITY_TRANSFORM: [f32; 6] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0];

/// A decoded image: linear RGBA, row-major from the top row.
#[derive(Clone, Debug, PartialEq)]
pub struct TextureImage {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<[f32; 4]>,
    /// Mean linear luminance of the texels (for choosing emissive triangles to sample).
    pub mean_luminance: f32,
}

/// The sRGB transfer function inverted (IEC 61966-2-1), for an encoded value in [0, 1].
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Decodes a PNG or JPEG image. Colour channels are sRGB-decoded (glTF stores base colour and
/// emission sRGB-encoded), alpha is kept linear. Errors describe what is wrong with the bytes.
pub fn decode_image(bytes: &[u8]) -> Result<TextureImage, String> {
    let mut reader = image::io::Reader::new(Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| format!("cannot read the image: {e}"))?;
    match reader.format() {
        Some(image::ImageFormat::Png | image::ImageFormat::Jpeg) => {}
        Some(f) => return Err(format!("{f:?} images are not supported (PNG or JPEG)")),
        None => return Err("not a PNG or JPEG image".into()),
    }
    let mut limits = image::io::Limits::default();
    limits.max_image_width = Some(MAX_TEXTURE_SIZE);
    limits.max_image_height = Some(MAX_TEXTURE_SIZE);
    limits.max_alloc = Some(2 << 30);
    reader.limits(limits);
    let img = reader
        .decode()
        .map_err(|e| format!("cannot decode the image: {e}"))?;
    let (width, height) = (img.width(), img.height());
    if width == 0 || height == 0 {
        return Err("the image is empty".into());
    }
    // 8-bit images through a table (the common case), deeper ones through the formula.
    let table: Vec<f32> = (0..256).map(|i| srgb_to_linear(i as f32 / 255.0)).collect();
    let texels: Vec<[f32; 4]> = match img {
        image::DynamicImage::ImageLuma8(_)
        | image::DynamicImage::ImageLumaA8(_)
        | image::DynamicImage::ImageRgb8(_)
        | image::DynamicImage::ImageRgba8(_) => img
            .to_rgba8()
            .pixels()
            .map(|p| {
                let [r, g, b, a] = p.0;
                [
                    table[r as usize],
                    table[g as usize],
                    table[b as usize],
                    a as f32 / 255.0,
                ]
            })
            .collect(),
        _ => img
            .to_rgba32f()
            .pixels()
            .map(|p| {
                let [r, g, b, a] = p.0;
                [srgb_to_linear(r), srgb_to_linear(g), srgb_to_linear(b), a]
            })
            .collect(),
    };
    let sum: f64 = texels
        .iter()
        .map(|t| luminance(Vec3::new(t[0], t[1], t[2])) as f64)
        .sum();
    Ok(TextureImage {
        width,
        height,
        mean_luminance: (sum / texels.len() as f64) as f32,
        texels,
    })
}

/// Texel index along one axis of `n` texels for integer coordinate `i`, by wrap mode.
#[inline]
pub fn wrap_index(i: i32, n: i32, wrap: u32) -> i32 {
    match wrap {
        WRAP_CLAMP => i.clamp(0, n - 1),
        WRAP_MIRROR => {
            let m = i.rem_euclid(2 * n);
            if m >= n {
                2 * n - 1 - m
            } else {
                m
            }
        }
        _ => i.rem_euclid(n),
    }
}

/// `floor(x)` as an integer, clamped so that huge or non-finite coordinates stay in range
/// (the WGSL mirror clamps the same way before converting).
#[inline]
fn floor_index(x: f32) -> i32 {
    x.floor().clamp(-1.0e9, 1.0e9) as i32
}

impl TextureRef {
    /// The texture coordinate after `KHR_texture_transform`.
    #[inline]
    pub fn transform_uv(&self, uv: Vec2) -> Vec2 {
        let m = &self.transform;
        Vec2::new(
            m[0] * uv.x + m[1] * uv.y + m[2],
            m[3] * uv.x + m[4] * uv.y + m[5],
        )
    }

    /// Linear RGBA at texture coordinate `uv` (before the transform).
    pub fn sample(&self, img: &TextureImage, uv: Vec2) -> Vec4 {
        let st = self.transform_uv(uv);
        let (w, h) = (img.width as i32, img.height as i32);
        let texel = |i: i32, j: i32| {
            let x = wrap_index(i, w, self.wrap[0]);
            let y = wrap_index(j, h, self.wrap[1]);
            Vec4::from(img.texels[(y * w + x) as usize])
        };
        if self.nearest {
            return texel(floor_index(st.x * w as f32), floor_index(st.y * h as f32));
        }
        let x = st.x * w as f32 - 0.5;
        let y = st.y * h as f32 - 0.5;
        let (fx, fy) = (x - x.floor(), y - y.floor());
        let (i, j) = (floor_index(x), floor_index(y));
        let top = texel(i, j) * (1.0 - fx) + texel(i + 1, j) * fx;
        let bottom = texel(i, j + 1) * (1.0 - fx) + texel(i + 1, j + 1) * fx;
        top * (1.0 - fy) + bottom * fy
    }
}

impl Material {
    /// Whether a base-colour or emissive texture modulates this material.
    #[inline]
    pub fn is_textured(&self) -> bool {
        self.base_color_texture != NO_INDEX || self.emissive_texture != NO_INDEX
    }
}

impl Scene {
    /// Whether a material some triangle uses is textured (the `textures` effect).
    pub fn uses_textures(&self) -> bool {
        self.instances
            .iter()
            .any(|i| self.materials[i.material as usize].is_textured())
    }

    /// The texture coordinate `mat` reads at barycentrics `(b1, b2)` of triangle `t`: zero
    /// for an untextured material, whose lookups never read it (no vertex loads per hit).
    #[inline]
    pub fn material_uv(&self, mat: &Material, t: usize, b1: f32, b2: f32) -> Vec2 {
        if mat.is_textured() {
            self.uv_at(t, b1, b2)
        } else {
            Vec2::ZERO
        }
    }

    /// Texture coordinate of triangle `t` at barycentrics `(b1, b2)` of its second and third
    /// vertices.
    #[inline]
    pub fn uv_at(&self, t: usize, b1: f32, b2: f32) -> Vec2 {
        let uv = self.triangle_vertices(t).map(|v| Vec2::new(v.u, v.v));
        uv[0] * (1.0 - b1 - b2) + uv[1] * b1 + uv[2] * b2
    }

    /// Linear RGB of texture `k` (`NO_INDEX`: white) at `uv`.
    #[inline]
    pub fn texture_rgb(&self, k: u32, uv: Vec2) -> Vec3 {
        if k == NO_INDEX {
            return Vec3::ONE;
        }
        let tex = &self.textures[k as usize];
        tex.sample(&self.images[tex.image_slot as usize], uv)
            .truncate()
    }

    /// Base colour (factor times texture) of `mat` at `uv`.
    #[inline]
    pub fn base_color_at(&self, mat: &Material, uv: Vec2) -> Vec3 {
        Vec3::from_slice(&mat.base_color[..3]) * self.texture_rgb(mat.base_color_texture, uv)
    }

    /// Emitted radiance (factor times texture) of `mat` at `uv`, before the side test.
    #[inline]
    pub fn emission_at(&self, mat: &Material, uv: Vec2) -> Vec3 {
        Vec3::from(mat.emission) * self.texture_rgb(mat.emissive_texture, uv)
    }

    /// Mean emitted luminance of `mat` over its texture (the factor alone without one): the
    /// weight of its triangles when a light is chosen.
    pub fn mean_emission_luminance(&self, mat: &Material) -> f32 {
        let factor = luminance(Vec3::from(mat.emission));
        if mat.emissive_texture == NO_INDEX {
            return factor;
        }
        let tex = &self.textures[mat.emissive_texture as usize];
        factor * self.images[tex.image_slot as usize].mean_luminance
    }
}

/// Reads the sampler and transform of one texture use (`info` at JSON pointer `pointer`).
pub fn texture_ref(
    ctx: &mut Ctx,
    textures: &mut Vec<TextureRef>,
    info: &gltf::texture::Info,
    pointer: &str,
) -> u32 {
    if info.tex_coord() != 0 {
        ctx.warn(
            format!("{pointer}/texCoord"),
            "only TEXCOORD_0 is supported; using it",
        );
    }
    let tex = info.texture();
    let image = tex.source();
    let uri = match image.source() {
        gltf::image::Source::Uri { uri, .. } => Some(uri.to_owned()),
        gltf::image::Source::View { .. } => None,
    };
    let sampler = tex.sampler();
    let wrap = |m: gltf::texture::WrappingMode| match m {
        gltf::texture::WrappingMode::ClampToEdge => WRAP_CLAMP,
        gltf::texture::WrappingMode::MirroredRepeat => WRAP_MIRROR,
        gltf::texture::WrappingMode::Repeat => WRAP_REPEAT,
    };
    let transform = match info.texture_transform() {
        None => IDENTITY_TRANSFORM,
        Some(t) => {
            if t.tex_coord().is_some_and(|c| c != 0) {
                ctx.warn(
                    format!("{pointer}/extensions/KHR_texture_transform/texCoord"),
                    "only TEXCOORD_0 is supported; using it",
                );
            }
            // KHR_texture_transform: T(offset) * R(rotation) * S(scale), with
            // R = [[cos, sin], [-sin, cos]] (the spec's matrix, rotating counter-clockwise
            // in UV space where v points down).
            let [ox, oy] = t.offset();
            let [sx, sy] = t.scale();
            let (s, c) = t.rotation().sin_cos();
            [c * sx, s * sy, ox, -s * sx, c * sy, oy]
        }
    };
    let r = TextureRef {
        texture: tex.index(),
        image: image.index(),
        uri,
        image_slot: NO_INDEX,
        wrap: [wrap(sampler.wrap_s()), wrap(sampler.wrap_t())],
        nearest: sampler.mag_filter() == Some(gltf::texture::MagFilter::Nearest),
        transform,
    };
    if let Some(k) = textures.iter().position(|t| *t == r) {
        return k as u32;
    }
    textures.push(r);
    (textures.len() - 1) as u32
}

/// Decodes every image the textures use (each glTF image once) and points the textures at
/// them. Errors name the file, the image's JSON pointer and what is wrong.
pub fn read_images(
    ctx: &Ctx,
    doc: &gltf::Document,
    buffers: &[Vec<u8>],
    base: &Path,
    textures: &mut [TextureRef],
) -> Result<Vec<TextureImage>, SceneError> {
    let mut images: Vec<TextureImage> = Vec::new();
    let mut slot_of: Vec<(usize, u32)> = Vec::new();
    for tex in textures.iter_mut() {
        if let Some(&(_, slot)) = slot_of.iter().find(|(i, _)| *i == tex.image) {
            tex.image_slot = slot;
            continue;
        }
        let image = doc
            .images()
            .nth(tex.image)
            .expect("texture sources are validated by gltf");
        let pointer = format!("/images/{}", tex.image);
        let (bytes, what) = match image.source() {
            gltf::image::Source::Uri { uri, .. } => {
                let at = format!("{pointer}/uri");
                let bytes = super::document::read_uri(ctx, uri, base, &at, "texture image")?;
                let what = if uri.starts_with("data:") {
                    "data URI".to_string()
                } else {
                    base.join(uri).display().to_string()
                };
                (bytes, (at, what))
            }
            gltf::image::Source::View { view, .. } => {
                let at = format!("{pointer}/bufferView");
                let buf = &buffers[view.buffer().index()];
                let range = view.offset()..view.offset() + view.length();
                let Some(bytes) = buf.get(range) else {
                    return Err(ctx.invalid(at, "buffer view runs past the end of its buffer"));
                };
                (
                    bytes.to_vec(),
                    (at, format!("buffer view {}", view.index())),
                )
            }
        };
        let decoded = decode_image(&bytes)
            .map_err(|e| ctx.invalid(what.0.clone(), format!("texture image {}: {e}", what.1)))?;
        let slot = images.len() as u32;
        images.push(decoded);
        slot_of.push((tex.image, slot));
        tex.image_slot = slot;
    }
    Ok(images)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checker() -> TextureImage {
        // 2x2: red, green / blue, white (linear values).
        TextureImage {
            width: 2,
            height: 2,
            texels: vec![
                [1.0, 0.0, 0.0, 1.0],
                [0.0, 1.0, 0.0, 1.0],
                [0.0, 0.0, 1.0, 1.0],
                [1.0, 1.0, 1.0, 1.0],
            ],
            mean_luminance: 0.0,
        }
    }

    fn tex(wrap: u32, nearest: bool) -> TextureRef {
        TextureRef {
            texture: 0,
            image: 0,
            uri: None,
            image_slot: 0,
            wrap: [wrap; 2],
            nearest,
            transform: IDENTITY_TRANSFORM,
        }
    }

    #[test]
    fn texel_centres_read_exactly() {
        let img = checker();
        let t = tex(WRAP_REPEAT, false);
        for (uv, want) in [
            ((0.25, 0.25), Vec4::new(1.0, 0.0, 0.0, 1.0)),
            ((0.75, 0.25), Vec4::new(0.0, 1.0, 0.0, 1.0)),
            ((0.25, 0.75), Vec4::new(0.0, 0.0, 1.0, 1.0)),
            // Halfway between the two top texels: their average.
            ((0.5, 0.25), Vec4::new(0.5, 0.5, 0.0, 1.0)),
        ] {
            assert_eq!(t.sample(&img, Vec2::new(uv.0, uv.1)), want, "at {uv:?}");
        }
    }

    #[test]
    fn wrap_modes() {
        assert_eq!(wrap_index(-1, 4, WRAP_REPEAT), 3);
        assert_eq!(wrap_index(5, 4, WRAP_REPEAT), 1);
        assert_eq!(wrap_index(-1, 4, WRAP_CLAMP), 0);
        assert_eq!(wrap_index(9, 4, WRAP_CLAMP), 3);
        assert_eq!(wrap_index(-1, 4, WRAP_MIRROR), 0);
        assert_eq!(wrap_index(4, 4, WRAP_MIRROR), 3);
        assert_eq!(wrap_index(8, 4, WRAP_MIRROR), 0);
        let img = checker();
        // At u = 0 (a texel edge), repeat blends the right column in, clamp does not.
        let r = tex(WRAP_REPEAT, false).sample(&img, Vec2::new(0.0, 0.25));
        let c = tex(WRAP_CLAMP, false).sample(&img, Vec2::new(0.0, 0.25));
        assert_eq!(r, Vec4::new(0.5, 0.5, 0.0, 1.0));
        assert_eq!(c, Vec4::new(1.0, 0.0, 0.0, 1.0));
    }

    #[test]
    fn nearest_reads_the_containing_texel() {
        let img = checker();
        let t = tex(WRAP_REPEAT, true);
        assert_eq!(
            t.sample(&img, Vec2::new(0.49, 0.51)).truncate(),
            Vec3::new(0.0, 0.0, 1.0)
        );
        assert_eq!(
            t.sample(&img, Vec2::new(1.49, -0.49)).truncate(),
            Vec3::new(0.0, 0.0, 1.0)
        );
    }

    #[test]
    fn transform_follows_khr_texture_transform() {
        // Rotation by 90 degrees maps u to -v' ... check the spec's matrix on (1, 0).
        let (s, c) = std::f32::consts::FRAC_PI_2.sin_cos();
        let mut t = tex(WRAP_REPEAT, false);
        t.transform = [c * 2.0, s * 3.0, 0.5, -s * 2.0, c * 3.0, 0.25];
        let st = t.transform_uv(Vec2::new(1.0, 0.0));
        assert!((st - Vec2::new(0.5, -1.75)).length() < 1e-6, "{st}");
    }

    #[test]
    fn srgb_decoding_matches_the_standard() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
        assert!((srgb_to_linear(0.5) - 0.214_041).abs() < 1e-5);
    }

    #[test]
    fn bad_bytes_are_errors_not_panics() {
        assert!(decode_image(b"").is_err());
        assert!(decode_image(b"\x89PNG\r\n\x1a\n").is_err());
        assert!(decode_image(b"GIF89a....").is_err());
    }
}
