//! OpenEXR output and input for films, reference images and cost maps.
//!
//! A Brume render is one single-part scan-line EXR (ZIP, lossless, f32) with these channels:
//!
//! | channel                          | meaning                                          |
//! |----------------------------------|--------------------------------------------------|
//! | `R`, `G`, `B`                    | pixel mean: the radiance estimate                |
//! | `A`                              | 1 (the film has no coverage notion)              |
//! | `variance.R`, `.G`, `.B`         | variance of the pixel mean (sample var / n)      |
//! | `samples.Y`                      | number of samples in the pixel                   |
//!
//! plus the [`Metadata`] as custom header attributes. The dotted names follow the OpenEXR
//! layer convention, so `oiiotool`, Nuke and Blender show `variance` and `samples` as layers.
//! The variance layer is what a per-pixel z-test against a reference needs.
//!
//! Files are written through [`write_atomically`], so a crash never leaves a truncated image.
//! Header attributes come back from [`read_exr`] sorted by name: the `exr` crate keeps them in a
//! hash map, so their order in the file is not fixed (the pixel data is).
use super::accum::{rgb, Film};
use super::atomic::write_atomically;
use super::checksum::{checksum, to_text, CHECKSUM_ATTRIBUTE};
use super::error::FilmError;
use super::metadata::{AttrValue, Metadata};
use exr::prelude::{
    AnyChannel, AnyChannels, AttributeValue, Encoding, FlatSamples, Image as ExrImage, Layer,
    LayerAttributes, SmallVec, Text, WritableImage,
};
use std::collections::BTreeMap;
use std::path::Path;

/// An image read from (or about to be written to) an EXR file. Pixel arrays are row-major
/// from the top-left, `width * height` long.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Colour per pixel. A grey (`Y`-only) file reads as `[Y, Y, Y]`.
    pub rgb: Vec<[f32; 3]>,
    /// Alpha, if the file has an `A` channel.
    pub alpha: Option<Vec<f32>>,
    /// Variance of the pixel mean, if the file has `variance.R/G/B`.
    pub variance: Option<Vec<[f32; 3]>>,
    /// Sample count per pixel, if the file has `samples.Y` (or `samples`).
    pub samples: Option<Vec<f32>>,
    /// Custom header attributes of types string, float, double and int (others are skipped),
    /// sorted by name.
    pub attributes: Metadata,
}

/// Header attribute saying whether the film is transparent: [`FILM_TRANSPARENT`] or
/// `"opaque"`.
pub const FILM_ATTRIBUTE: &str = "brume:film";
/// [`FILM_ATTRIBUTE`]'s value for a transparent film.
pub const FILM_TRANSPARENT: &str = "transparent";

impl Image {
    /// The film's beauty, variance and sample count as an image with `metadata`; this is
    /// exactly what [`write_exr`] writes. Its alpha is the pixels' coverage where `metadata`
    /// says the film is transparent ([`FILM_ATTRIBUTE`]), so the RGBA is premultiplied; an
    /// opaque film's image is opaque (alpha 1), as its colour includes the background.
    pub fn from_film(film: &Film, metadata: &Metadata) -> Self {
        let pixels = film.pixels();
        let transparent = metadata.text(FILM_ATTRIBUTE) == Some(FILM_TRANSPARENT);
        Image {
            width: film.width() as usize,
            height: film.height() as usize,
            rgb: pixels
                .iter()
                .map(|p| rgb(p.mean).map(|m| m as f32))
                .collect(),
            alpha: Some(
                pixels
                    .iter()
                    .map(|p| if transparent { p.mean[3] as f32 } else { 1.0 })
                    .collect(),
            ),
            variance: Some(
                pixels
                    .iter()
                    .map(|p| rgb(p.variance_of_mean()).map(|v| v as f32))
                    .collect(),
            ),
            samples: Some(pixels.iter().map(|p| p.count as f32).collect()),
            attributes: metadata.clone(),
        }
    }

    /// Colour of pixel `(x, y)`.
    pub fn rgb_at(&self, x: usize, y: usize) -> [f32; 3] {
        self.rgb[y * self.width + x]
    }
}

/// Writes `film` (mean, variance of the mean, sample count) and `metadata` to `path` as one
/// EXR, atomically.
pub fn write_exr(
    path: impl AsRef<Path>,
    film: &Film,
    metadata: &Metadata,
) -> Result<(), FilmError> {
    write_film(path.as_ref(), film, metadata, false)
}

/// Header attribute listing the light passes an image holds, space-separated in layer order.
pub const PASSES_ATTRIBUTE: &str = "brume:passes";

/// The film's beauty, variance, sample count and light passes (`<pass>.R/G/B`, the means),
/// with its exact accumulator state where `state`, and `metadata` (plus [`PASSES_ATTRIBUTE`]
/// where it has passes).
fn write_film(path: &Path, film: &Film, metadata: &Metadata, state: bool) -> Result<(), FilmError> {
    let mut metadata = metadata.clone();
    if let Some(p) = film.passes() {
        metadata.set(PASSES_ATTRIBUTE, AttrValue::Text(p.names().join(" ")));
    }
    let image = Image::from_film(film, &metadata);
    let mut list: Vec<(String, FlatSamples)> = image_channels(path, &image)?
        .into_iter()
        .map(|(n, v)| (n.to_string(), FlatSamples::F32(v)))
        .collect();
    if let Some(p) = film.passes() {
        let pixels = film.pixels().len();
        for (k, name) in p.names().iter().enumerate() {
            for (channel, c) in super::passes::exr_channels(name) {
                let values = (0..pixels).map(|i| p.mean(i, k)[c] as f32).collect();
                list.push((channel, FlatSamples::F32(values)));
            }
        }
    }
    if state {
        list.extend(
            super::state::state_channels(film)
                .into_iter()
                .map(|(n, v)| (n, FlatSamples::U32(v))),
        );
    }
    encode_any(path, image.width, image.height, list, &metadata)
}

/// Writes an [`Image`] as an EXR, atomically: channels `R G B`, and `A`, `variance.*`,
/// `samples.Y` where present.
pub fn write_image(path: impl AsRef<Path>, image: &Image) -> Result<(), FilmError> {
    write_image_with(path, image, Vec::new())
}

/// [`write_image`] with `extra` float channels after the image's own (named layers such as a
/// reference render's light passes, `volume.direct.R`).
pub fn write_image_with(
    path: impl AsRef<Path>,
    image: &Image,
    extra: Vec<(String, Vec<f32>)>,
) -> Result<(), FilmError> {
    let path = path.as_ref();
    let n = image.width * image.height;
    let mut channels: Vec<(String, FlatSamples)> = image_channels(path, image)?
        .into_iter()
        .map(|(name, v)| (name.to_string(), FlatSamples::F32(v)))
        .collect();
    for (name, v) in extra {
        check_len(path, &name, v.len(), n)?;
        channels.push((name, FlatSamples::F32(v)));
    }
    encode_any(path, image.width, image.height, channels, &image.attributes)
}

/// The f32 channels [`write_image`] writes for `image`, checked against its size.
fn image_channels<'a>(
    path: &Path,
    image: &'a Image,
) -> Result<Vec<(&'a str, Vec<f32>)>, FilmError> {
    let n = image.width * image.height;
    let mut channels: Vec<(&str, Vec<f32>)> = Vec::with_capacity(8);
    check_len(path, "rgb", image.rgb.len(), n)?;
    for (c, name) in ["R", "G", "B"].into_iter().enumerate() {
        channels.push((name, image.rgb.iter().map(|p| p[c]).collect()));
    }
    if let Some(alpha) = &image.alpha {
        check_len(path, "alpha", alpha.len(), n)?;
        channels.push(("A", alpha.clone()));
    }
    if let Some(variance) = &image.variance {
        check_len(path, "variance", variance.len(), n)?;
        for (c, name) in ["variance.R", "variance.G", "variance.B"]
            .into_iter()
            .enumerate()
        {
            channels.push((name, variance.iter().map(|p| p[c]).collect()));
        }
    }
    if let Some(samples) = &image.samples {
        check_len(path, "samples", samples.len(), n)?;
        channels.push(("samples.Y", samples.clone()));
    }
    Ok(channels)
}

/// [`write_exr`] plus the film's exact accumulator state as `u32` channels
/// ([`super::state::STATE_CHANNELS`]), so that a merge or a resume continues from the very
/// same f64 values instead of their f32 roundings.
pub fn write_exr_with_state(
    path: impl AsRef<Path>,
    film: &Film,
    metadata: &Metadata,
) -> Result<(), FilmError> {
    write_film(path.as_ref(), film, metadata, true)
}

/// Writes one map as an EXR, atomically: `values` of length `width * height` become channel
/// `Y`; of length `3 * width * height` (interleaved RGB) channels `R G B`. For cost maps and
/// other diagnostics; `metadata` should say what the values measure and in which units.
pub fn write_exr_single(
    path: impl AsRef<Path>,
    width: usize,
    height: usize,
    values: &[f32],
    metadata: &Metadata,
) -> Result<(), FilmError> {
    let path = path.as_ref();
    let n = width * height;
    let channels = if values.len() == n {
        vec![("Y", values.to_vec())]
    } else if values.len() == 3 * n {
        (0..3)
            .map(|c| {
                (
                    ["R", "G", "B"][c],
                    values.iter().skip(c).step_by(3).copied().collect(),
                )
            })
            .collect()
    } else {
        return Err(FilmError::InvalidInput {
            path: path.to_path_buf(),
            reason: format!(
                "{} values fit neither {width}x{height} grey ({n}) nor RGB ({})",
                values.len(),
                3 * n
            ),
        });
    };
    encode(path, width, height, channels, metadata)
}

fn check_len(path: &Path, what: &str, len: usize, expected: usize) -> Result<(), FilmError> {
    if len == expected {
        return Ok(());
    }
    Err(FilmError::InvalidInput {
        path: path.to_path_buf(),
        reason: format!("{what} has {len} pixels, the image has {expected}"),
    })
}

/// Builds the EXR in memory and writes it through a temporary file.
fn encode(
    path: &Path,
    width: usize,
    height: usize,
    channels: Vec<(&str, Vec<f32>)>,
    metadata: &Metadata,
) -> Result<(), FilmError> {
    let list = channels
        .into_iter()
        .map(|(n, v)| (n.to_string(), FlatSamples::F32(v)))
        .collect();
    encode_any(path, width, height, list, metadata)
}

/// [`encode`] for channels of any sample type.
fn encode_any(
    path: &Path,
    width: usize,
    height: usize,
    channels: Vec<(String, FlatSamples)>,
    metadata: &Metadata,
) -> Result<(), FilmError> {
    let invalid = |reason: String| FilmError::InvalidInput {
        path: path.to_path_buf(),
        reason,
    };
    if width == 0 || height == 0 {
        return Err(invalid(format!(
            "an EXR needs pixels, the image is {width}x{height}"
        )));
    }
    let mut attributes = LayerAttributes::default();
    let sum = checksum(channels.iter().map(|(n, v)| (n.as_str(), v)), metadata);
    let metadata = metadata
        .clone()
        .with(CHECKSUM_ATTRIBUTE, AttrValue::Text(to_text(sum)));
    for (name, value) in metadata.iter() {
        // OpenEXR names are NUL-terminated and at most 255 bytes with long names enabled.
        if name.is_empty() || name.len() > 255 || name.contains('\0') {
            return Err(invalid(format!(
                "attribute name {name:?} is not a valid EXR name"
            )));
        }
        let value = match value {
            // EXR strings are bytes; UTF-8 is what OpenImageIO and Blender expect in them.
            AttrValue::Text(s) => AttributeValue::Text(Text::from_slice_unchecked(s.as_bytes())),
            AttrValue::Float(v) => AttributeValue::F32(*v),
            AttrValue::Double(v) => AttributeValue::F64(*v),
            AttrValue::Int(v) => AttributeValue::I32(*v),
        };
        attributes
            .other
            .insert(Text::from_slice_unchecked(name.as_bytes()), value);
    }
    let list: SmallVec<[AnyChannel<FlatSamples>; 4]> = channels
        .into_iter()
        .map(|(name, values)| AnyChannel::new(name.as_str(), values))
        .collect();
    // ZIP over 16 scan lines, increasing line order: lossless, and the pixel blocks land in
    // the file in the same order every time.
    let layer = Layer::new(
        (width, height),
        attributes,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(list),
    );
    let image = ExrImage::from_layer(layer);
    write_atomically(path, |file| {
        image
            .write()
            .to_unbuffered(file)
            .map_err(|source| match source {
                // A full disk or a file-size limit: say so, not "cannot encode".
                exr::error::Error::Io(e) => FilmError::io("write", path, e),
                source => FilmError::ExrEncode {
                    path: path.to_path_buf(),
                    source,
                },
            })
    })
}

/// Reads an RGB(A) or grey float EXR with the optional `variance.*` and `samples` layers and
/// custom attributes. Errors name the file: missing, a directory, not an EXR, missing channels,
/// parts of different sizes.
pub fn read_exr(path: impl AsRef<Path>) -> Result<Image, FilmError> {
    read_exr_with_state(path).map(|(image, _)| image)
}

/// [`read_exr`], also returning the `u32` channels by name (the accumulator state written by
/// [`write_exr_with_state`], read back bit for bit).
pub fn read_exr_with_state(
    path: impl AsRef<Path>,
) -> Result<(Image, BTreeMap<String, Vec<u32>>), FilmError> {
    read_exr_checked(path.as_ref(), false).map(|(image, raw, _)| (image, raw))
}

/// [`read_exr_with_state`] for files Brume continues from (checkpoints, parts): the file must
/// carry a `brume:checksum` and its content must match it, so a damaged file is refused
/// instead of resumed or merged.
pub fn read_exr_verified(
    path: impl AsRef<Path>,
) -> Result<(Image, BTreeMap<String, Vec<u32>>), FilmError> {
    let path = path.as_ref();
    let (image, raw, computed) = read_exr_checked(path, true)?;
    let corrupt = |reason: String| FilmError::Corrupt {
        path: path.to_path_buf(),
        reason,
    };
    match image.attributes.text(CHECKSUM_ATTRIBUTE) {
        None => Err(corrupt(format!(
            "it has no {CHECKSUM_ATTRIBUTE} attribute, so its content cannot be trusted"
        ))),
        Some(stored) if stored != to_text(computed) => Err(corrupt(format!(
            "its content does not match its {CHECKSUM_ATTRIBUTE} ({stored} written, {} read)",
            to_text(computed)
        ))),
        Some(_) => Ok((image, raw)),
    }
}

/// Reads the file and, when `verify` asks for it, the checksum of what was read (see
/// [`checksum`]; only files Brume continues from pay for it).
#[allow(clippy::type_complexity)]
fn read_exr_checked(
    path: &Path,
    verify: bool,
) -> Result<(Image, BTreeMap<String, Vec<u32>>, u64), FilmError> {
    let decoded = decode(path)?;
    let channels = Channels::of(path, &decoded)?;
    let by_name = &channels.by_name;
    let (width, height) = channels.size.unwrap_or((0, 0));
    let computed = if verify {
        checksum(
            channels.read.iter().map(|(n, v)| (n.as_str(), *v)),
            &channels.attributes,
        )
    } else {
        0
    };
    let beauty = beauty_prefix(by_name);
    let get = |c: &str| by_name.get(&format!("{beauty}{c}"));
    let rgb = match (get("R"), get("G"), get("B"), get("Y")) {
        (Some(r), Some(g), Some(b), _) => zip3(r, g, b),
        (None, None, None, Some(y)) => y.iter().map(|&v| [v; 3]).collect(),
        (r, g, b, _) => {
            let absent: Vec<&str> = [("R", r), ("G", g), ("B", b)]
                .into_iter()
                .filter(|(_, c)| c.is_none())
                .map(|(n, _)| n)
                .collect();
            return Err(channels.missing(path, &absent));
        }
    };
    let variance_channels = ["variance.R", "variance.G", "variance.B"].map(|n| by_name.get(n));
    let variance = match variance_channels {
        [Some(r), Some(g), Some(b)] => Some(zip3(r, g, b)),
        [None, None, None] => None,
        partial => {
            let absent: Vec<&str> = ["variance.R", "variance.G", "variance.B"]
                .into_iter()
                .zip(partial)
                .filter(|(_, c)| c.is_none())
                .map(|(n, _)| n)
                .collect();
            return Err(channels.missing(path, &absent));
        }
    };
    let samples = by_name
        .get("samples.Y")
        .or_else(|| by_name.get("samples"))
        .cloned();
    Ok((
        Image {
            width,
            height,
            rgb,
            alpha: get("A").cloned(),
            variance,
            samples,
            attributes: channels.attributes.sorted(),
        },
        channels.raw_u32,
        computed,
    ))
}

/// Where the beauty's channels are: unprefixed, or in a Blender multilayer file's one
/// `<view layer>.Combined` layer (its passes are other layers beside it).
fn beauty_prefix(by_name: &BTreeMap<String, Vec<f32>>) -> String {
    if by_name.contains_key("R") || by_name.contains_key("Y") {
        return String::new();
    }
    let mut combined = by_name
        .keys()
        .filter_map(|k| k.strip_suffix("Combined.R"))
        .filter(|p| p.is_empty() || p.ends_with('.'));
    match (combined.next(), combined.next()) {
        (Some(p), None) => format!("{p}Combined."),
        _ => String::new(),
    }
}

/// Every float channel of an EXR by name (a part's layer name prefixed), with the size.
#[derive(Debug, Clone)]
pub struct ExrChannels {
    pub width: usize,
    pub height: usize,
    pub by_name: BTreeMap<String, Vec<f32>>,
}

/// Reads every channel of every part of the EXR at `path` as floats: for layers [`read_exr`]
/// does not interpret, such as a reference renderer's passes.
pub fn read_exr_channels(path: impl AsRef<Path>) -> Result<ExrChannels, FilmError> {
    let path = path.as_ref();
    let decoded = decode(path)?;
    let channels = Channels::of(path, &decoded)?;
    let (width, height) = channels.size.unwrap_or((0, 0));
    Ok(ExrChannels {
        width,
        height,
        by_name: channels.by_name,
    })
}

/// Decodes every part of the file at `path`; a directory, an unreadable file or bytes the
/// decoder rejects (or panics on) come back as errors naming the file.
fn decode(path: &Path) -> Result<exr::image::FlatImage, FilmError> {
    let meta = std::fs::metadata(path).map_err(|e| FilmError::io("read", path, e))?;
    if meta.is_dir() {
        let e = std::io::Error::other("it is a directory, not a file");
        return Err(FilmError::io("read", path, e));
    }
    let exr_error = |source| FilmError::Exr {
        path: path.to_path_buf(),
        source,
    };
    // The exr crate validates headers, but a decoder bug on hostile bytes should still come
    // back as an error naming the file rather than take the process down.
    std::panic::catch_unwind(|| exr::prelude::read_all_flat_layers_from_file(path))
        .map_err(|_| {
            exr_error(exr::error::Error::Invalid(
                "the decoder panicked on this file".into(),
            ))
        })?
        .map_err(exr_error)
}

/// The channels and attributes of every part of a decoded file, which must all have one size.
struct Channels<'a> {
    /// Channel name (with its part's layer name prefixed, as OpenEXR multi-part files name
    /// them) -> values.
    by_name: BTreeMap<String, Vec<f32>>,
    /// The `u32` channels by name, bit for bit.
    raw_u32: BTreeMap<String, Vec<u32>>,
    /// The file's and every part's custom attributes.
    attributes: Metadata,
    /// The parts' size; `None` for a file without parts.
    size: Option<(usize, usize)>,
    /// Every channel as stored, in file order, for the checksum.
    read: Vec<(String, &'a FlatSamples)>,
}

impl<'a> Channels<'a> {
    /// Collects the channels of `decoded` (read from `path`), refusing parts of different
    /// sizes.
    fn of(path: &Path, decoded: &'a exr::image::FlatImage) -> Result<Self, FilmError> {
        let mut c = Channels {
            by_name: BTreeMap::new(),
            raw_u32: BTreeMap::new(),
            attributes: Metadata::new(),
            size: None,
            read: Vec::new(),
        };
        collect_attributes(&decoded.attributes.other, &mut c.attributes);
        for layer in &decoded.layer_data {
            let layer_size = (layer.size.0, layer.size.1);
            match c.size {
                None => c.size = Some(layer_size),
                Some(expected) if expected != layer_size => {
                    return Err(FilmError::SizeMismatch {
                        path: path.to_path_buf(),
                        what: match &layer.attributes.layer_name {
                            Some(name) => {
                                format!("part {:?}", String::from_utf8_lossy(name.bytes()))
                            }
                            None => "an unnamed part".into(),
                        },
                        expected,
                        found: layer_size,
                    })
                }
                Some(_) => {}
            }
            collect_attributes(&layer.attributes.other, &mut c.attributes);
            let prefix = layer
                .attributes
                .layer_name
                .as_ref()
                // Blender writes single-layer files with an empty layer name: no prefix then.
                .filter(|t| !t.bytes().is_empty())
                .map(|t| format!("{}.", String::from_utf8_lossy(t.bytes())))
                .unwrap_or_default();
            for channel in &layer.channel_data.list {
                let own = String::from_utf8_lossy(channel.name.bytes());
                // Blender's multi-part files name each channel in full already.
                let name = if own.starts_with(&prefix) {
                    own.into_owned()
                } else {
                    format!("{prefix}{own}")
                };
                c.read.push((name.clone(), &channel.sample_data));
                if let FlatSamples::U32(v) = &channel.sample_data {
                    c.raw_u32.insert(name.clone(), v.clone());
                }
                c.by_name
                    .insert(name, channel.sample_data.values_as_f32().collect());
            }
        }
        Ok(c)
    }

    /// The error for the `absent` channels of the file at `path`, listing those it has.
    fn missing(&self, path: &Path, absent: &[&str]) -> FilmError {
        FilmError::MissingChannels {
            path: path.to_path_buf(),
            missing: absent.iter().map(|s| s.to_string()).collect(),
            found: self.by_name.keys().cloned().collect(),
        }
    }
}

fn zip3(r: &[f32], g: &[f32], b: &[f32]) -> Vec<[f32; 3]> {
    r.iter()
        .zip(g)
        .zip(b)
        .map(|((&r, &g), &b)| [r, g, b])
        .collect()
}

/// Keeps the attribute types [`AttrValue`] can hold; the exr crate has already parsed the
/// standard ones (channels, compression, windows) into their own fields.
pub(crate) fn collect_attributes(
    other: &std::collections::HashMap<Text, AttributeValue>,
    into: &mut Metadata,
) {
    for (name, value) in other {
        let value = match value {
            AttributeValue::Text(t) => AttrValue::Text(String::from_utf8_lossy(t.bytes()).into()),
            AttributeValue::F32(v) => AttrValue::Float(*v),
            AttributeValue::F64(v) => AttrValue::Double(*v),
            AttributeValue::I32(v) => AttrValue::Int(*v),
            _ => continue,
        };
        into.set(String::from_utf8_lossy(name.bytes()), value);
    }
}
