//! Decoding the equirectangular image of `BRUME_environment.uri`.
//!
//! `.exr` goes through the `exr` crate (the same reader as reference images, so half and float,
//! RGB(A) or grey, scan-line or tiled); `.hdr` (Radiance RGBE) through the `image` crate. The
//! pixels come back row-major from the top-left, as both formats store them; the direction each
//! pixel stands for is defined in `render::envmap` (Blender's convention).
//!
//! Every failure is a message for the scene loader to prefix with the glTF file and the JSON
//! pointer: unreadable or truncated files, files that are not images, empty images, NaN or
//! infinite pixels. Negative pixels (from a resampling filter's overshoot) are clamped to zero:
//! radiance cannot be negative, and the importance sampler needs non-negative weights.
use std::path::Path;

/// An environment image, linear RGB radiance factors.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvironmentImage {
    /// Pixels across (the full 360 degrees of azimuth).
    pub width: u32,
    /// Pixels down (zenith at the top row, nadir at the bottom).
    pub height: u32,
    /// Row-major from the top-left, `width * height` entries.
    pub rgb: Vec<[f32; 3]>,
}

impl EnvironmentImage {
    /// The pixel at column `x`, row `y` (from the top).
    #[inline]
    pub fn at(&self, x: u32, y: u32) -> [f32; 3] {
        self.rgb[(y * self.width + x) as usize]
    }

    /// `Some(rgb)` when every pixel holds the same value: the map is then the constant
    /// environment `rgb`, and is rendered as one (see `Lights::new`).
    pub fn constant(&self) -> Option<[f32; 3]> {
        let first = *self.rgb.first()?;
        self.rgb.iter().all(|p| *p == first).then_some(first)
    }
}

/// What decoding found, besides the pixels: how many were negative (and clamped to zero).
pub struct Decoded {
    pub image: EnvironmentImage,
    pub negative_pixels: usize,
}

/// Largest side accepted: 32768 pixels (a 32k x 16k map is 2 GiB of f32 RGB already).
pub const MAX_SIDE: u32 = 1 << 15;

/// Reads `path` by its extension (`.exr` or `.hdr`, any case). The error text does not repeat
/// the path: the caller names it with the JSON pointer.
pub fn read_environment_image(path: &Path) -> Result<Decoded, String> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    let file_len = std::fs::metadata(path)
        .map_err(|e| format!("cannot read: {e}"))?
        .len();
    let (width, height, mut rgb) = match ext.as_deref() {
        Some("exr") => {
            check_exr_header(path, file_len)?;
            let img = crate::film::exr_io::read_exr(path).map_err(|e| e.to_string())?;
            (img.width, img.height, img.rgb)
        }
        Some("hdr") => read_hdr(path, file_len)?,
        _ => {
            return Err("unsupported image format: expected an equirectangular .exr or .hdr".into())
        }
    };
    if width == 0 || height == 0 {
        return Err(format!("the image is empty ({width}x{height} pixels)"));
    }
    if width > MAX_SIDE as usize || height > MAX_SIDE as usize {
        return Err(format!(
            "the image is {width}x{height} pixels, larger than {MAX_SIDE} on a side"
        ));
    }
    if rgb.len() != width * height {
        return Err(format!(
            "the image holds {} pixels, not {width}x{height}",
            rgb.len()
        ));
    }
    if let Some(i) = rgb.iter().position(|p| p.iter().any(|c| !c.is_finite())) {
        return Err(format!(
            "pixel ({}, {}) (column, row from the top) is {:?}: not finite",
            i % width,
            i / width,
            rgb[i]
        ));
    }
    let mut negative_pixels = 0;
    for p in &mut rgb {
        if p.iter().any(|&c| c < 0.0) {
            negative_pixels += 1;
            *p = p.map(|c| c.max(0.0));
        }
    }
    Ok(Decoded {
        image: EnvironmentImage {
            width: width as u32,
            height: height as u32,
            rgb,
        },
        negative_pixels,
    })
}

/// The most pixels per byte of file any real map reaches: deflate (EXR's ZIP) compresses at
/// most ~1032:1, i.e. 12-byte float RGB pixels need at least ~0.012 bytes each; Radiance's
/// run-length encoding at most 127 repeats per 2 bytes and component. A header claiming more
/// is corrupt, and is refused before the decoder allocates what it claims (a 1 KB file
/// claiming 2 GB of pixels would otherwise abort the process on the failed allocation).
const MAX_PIXELS_PER_BYTE: u64 = 256;

fn check_claimed_size(width: u64, height: u64, file_len: u64) -> Result<(), String> {
    if width > MAX_SIDE as u64 || height > MAX_SIDE as u64 {
        return Err(format!(
            "the image is {width}x{height} pixels, larger than {MAX_SIDE} on a side"
        ));
    }
    if width * height > MAX_PIXELS_PER_BYTE * file_len {
        return Err(format!(
            "the header claims {width}x{height} pixels, more than a file of {file_len} bytes can \
             hold: the file is corrupt or truncated"
        ));
    }
    Ok(())
}

/// Checks the sizes an EXR's headers claim before decoding it.
fn check_exr_header(path: &Path, file_len: u64) -> Result<(), String> {
    let meta = std::panic::catch_unwind(|| exr::meta::MetaData::read_from_file(path, false))
        .map_err(|_| "the EXR header reader panicked on this file".to_string())?
        .map_err(|e| format!("not a readable OpenEXR file: {e}"))?;
    let mut total = 0u64;
    for h in meta.headers.iter() {
        let (w, hgt) = (h.layer_size.0 as u64, h.layer_size.1 as u64);
        check_claimed_size(w, hgt, file_len)?;
        total += w * hgt * h.channels.list.len() as u64;
    }
    // All parts' channels are decoded at once.
    if total > 4 * MAX_PIXELS_PER_BYTE * file_len {
        return Err(format!(
            "the headers claim {total} samples, more than a file of {file_len} bytes can hold"
        ));
    }
    Ok(())
}

/// Radiance RGBE through the `image` crate's HDR decoder (linear f32 RGB).
fn read_hdr(path: &Path, file_len: u64) -> Result<(usize, usize, Vec<[f32; 3]>), String> {
    let file = std::fs::File::open(path).map_err(|e| format!("cannot open: {e}"))?;
    let decoder = image::codecs::hdr::HdrDecoder::new(std::io::BufReader::new(file))
        .map_err(|e| format!("not a Radiance HDR image: {e}"))?;
    let meta = decoder.metadata();
    let (w, h) = (meta.width as usize, meta.height as usize);
    check_claimed_size(w as u64, h as u64, file_len)?;
    let pixels = decoder
        .read_image_hdr()
        .map_err(|e| format!("cannot decode the Radiance HDR image: {e}"))?;
    Ok((w, h, pixels.into_iter().map(|p| p.0).collect()))
}

/// Writes `image` as an RGB float EXR, atomically (for generated maps and tests).
pub fn write_environment_exr(path: &Path, image: &EnvironmentImage) -> Result<(), String> {
    let img = crate::film::Image {
        width: image.width as usize,
        height: image.height as usize,
        rgb: image.rgb.clone(),
        alpha: None,
        variance: None,
        samples: None,
        attributes: crate::film::Metadata::new(),
    };
    crate::film::write_image(path, &img).map_err(|e| e.to_string())
}
