//! Parts of one image rendered apart (farm tasks, checkpoints): what each holds and how it is
//! read back whole.
//!
//! A part is an ordinary Brume EXR (beauty, `variance.*`, `samples.Y`) plus
//!
//! - the film's exact accumulator state as `u32` channels (`film::state::STATE_CHANNELS`): per pixel the
//!   sample count and the f64 bits of Welford's mean and `M2` per channel, so a merge or a
//!   resume starts from the very values the renderer held, not from their f32 roundings;
//! - header attributes saying what it is a part of ([`PartInfo`]): a content hash of the scene
//!   file and every file it references, the settings that shape the image, seed, size and
//!   Brume version (all must match to merge), and its coverage: the sample ranges and pixel
//!   regions it holds (`brume:coverage`, e.g. `0..64@0,0,320,240`), which must not overlap.
//!
//! Exactness. Resuming a checkpoint folds the remaining passes onto the saved state in the
//! order of the uninterrupted render: the result is the same **bit for bit**. A merge of parts
//! combines per-pixel (count, mean, M2) triples with Chan et al.'s formula, a different
//! grouping of the same sums than the single render's pass-by-pass fold: it equals the single
//! render **to the last rounding of the f64 summation order** (relative differences of order
//! 1e-16 in the state; the f32 channels written to the EXR are equal or one unit in the last
//! place apart). `tests/cli/farm_parts.rs` checks both.
use std::path::{Path, PathBuf};

use thiserror::Error;

use super::coverage::{coverage_text, parse_coverage, parse_range, Coverage};
use crate::film::accum::CHANNELS;
use crate::film::exr_io::{collect_attributes, read_exr_verified};
use crate::film::passes::PassLayers;
use crate::film::state::{m2_channel, mean_channel, STATE_CHANNELS};
use crate::film::{AttrValue, Film, FilmError, Metadata, PixelStats};

/// Why a part cannot be read, resumed or merged. Every message names the file.
#[derive(Debug, Error)]
pub enum PartError {
    #[error(transparent)]
    Film(#[from] FilmError),
    #[error("{path}: {reason}")]
    Refused { path: PathBuf, reason: String },
}

pub(super) fn refused(path: &Path, reason: impl Into<String>) -> PartError {
    PartError::Refused {
        path: path.to_path_buf(),
        reason: reason.into(),
    }
}

/// What a part is a part of, and what it holds; stored as `brume:*` header attributes.
#[derive(Clone, Debug, PartialEq)]
pub struct PartInfo {
    /// FNV-1a 64 of the scene file and every file it references ([`super::key::scene_hash`]).
    pub scene_hash: String,
    /// Every setting that shapes the image, as `key=value` words ([`super::key::settings_key`]).
    pub settings: String,
    pub seed: String,
    pub version: String,
    pub width: u32,
    pub height: u32,
    /// The (sample range, region) pairs this file holds.
    pub coverage: Vec<Coverage>,
    /// The range a render of this file was asked for (`--samples`, or `0..spp`), which a
    /// resume continues to; absent in merges.
    pub target: Option<(u32, u32)>,
    /// Render seconds, summed over every part merged in.
    pub seconds: f64,
    /// Number of renders this file combines.
    pub parts: u32,
}

impl PartInfo {
    /// Writes the attributes into `meta` (replacing `brume:seconds`).
    pub fn write_into(&self, meta: &mut Metadata) {
        let t = |s: &str| AttrValue::Text(s.to_string());
        meta.set("brume:scene_hash", t(&self.scene_hash));
        meta.set("brume:settings", t(&self.settings));
        meta.set("brume:seed", t(&self.seed));
        meta.set("brume:version", t(&self.version));
        meta.set("brume:width", AttrValue::Int(self.width as i32));
        meta.set("brume:height", AttrValue::Int(self.height as i32));
        meta.set("brume:coverage", t(&coverage_text(&self.coverage)));
        match self.target {
            Some((a, b)) => meta.set("brume:target", t(&format!("{a}..{b}"))),
            None => meta.set("brume:target", t("")),
        };
        meta.set("brume:seconds", AttrValue::Double(self.seconds));
        meta.set("brume:parts", AttrValue::Int(self.parts as i32));
    }

    /// Reads the attributes back; a file without them is not a part.
    pub fn from_metadata(path: &Path, meta: &Metadata) -> Result<Self, PartError> {
        let text = |k: &str| -> Result<String, PartError> {
            meta.text(k).map(str::to_string).ok_or_else(|| {
                refused(
                    path,
                    format!("not a Brume part: no {k} attribute (render it with this Brume)"),
                )
            })
        };
        let int = |k: &str| -> Result<u32, PartError> {
            match meta.get(k) {
                Some(AttrValue::Int(v)) if *v >= 0 => Ok(*v as u32),
                _ => Err(refused(path, format!("{k} is missing or not a count"))),
            }
        };
        let coverage = parse_coverage(&text("brume:coverage")?)
            .map_err(|e| refused(path, format!("brume:coverage: {e}")))?;
        let target = match text("brume:target")?.as_str() {
            "" => None,
            s => Some(parse_range(s).map_err(|e| refused(path, format!("brume:target: {e}")))?),
        };
        let seconds = match meta.get("brume:seconds") {
            Some(AttrValue::Double(v)) => *v,
            Some(AttrValue::Float(v)) => *v as f64,
            _ => return Err(refused(path, "brume:seconds is missing")),
        };
        Ok(PartInfo {
            scene_hash: text("brume:scene_hash")?,
            settings: text("brume:settings")?,
            seed: text("brume:seed")?,
            version: text("brume:version")?,
            width: int("brume:width")?,
            height: int("brume:height")?,
            coverage,
            target,
            seconds,
            parts: int("brume:parts")?,
        })
    }

    /// The first field in which `other` (from `other_path`) differs from `self`, as a refusal
    /// naming `other_path` and `self_path`.
    pub fn check_same_image(
        &self,
        self_path: &Path,
        other: &PartInfo,
        other_path: &Path,
    ) -> Result<(), PartError> {
        let fields = [
            ("scene (content hash)", &self.scene_hash, &other.scene_hash),
            ("settings", &self.settings, &other.settings),
            ("seed", &self.seed, &other.seed),
            ("Brume version", &self.version, &other.version),
        ];
        for (what, a, b) in fields {
            if a != b {
                return Err(refused(
                    other_path,
                    format!(
                        "not the same {what} as {}: {b:?} against {a:?}",
                        self_path.display()
                    ),
                ));
            }
        }
        if (self.width, self.height) != (other.width, other.height) {
            return Err(refused(
                other_path,
                format!(
                    "not the same size as {}: {}x{} against {}x{}",
                    self_path.display(),
                    other.width,
                    other.height,
                    self.width,
                    self.height
                ),
            ));
        }
        Ok(())
    }
}

/// A part read back: its identity and coverage, its film (exact state) and all its attributes.
#[derive(Debug, Clone)]
pub struct Part {
    pub path: PathBuf,
    pub info: PartInfo,
    pub film: Film,
    pub metadata: Metadata,
}

/// Reads only the header of a part (no pixels): for checking a set of parts before reading
/// gigabytes of them.
pub fn read_part_info(path: &Path) -> Result<(PartInfo, Metadata), PartError> {
    let meta = exr::meta::MetaData::read_from_file(path, false).map_err(|source| {
        PartError::Film(FilmError::Exr {
            path: path.to_path_buf(),
            source,
        })
    })?;
    let mut attributes = Metadata::new();
    for h in &meta.headers {
        collect_attributes(&h.shared_attributes.other, &mut attributes);
        collect_attributes(&h.own_attributes.other, &mut attributes);
    }
    let attributes = attributes.sorted();
    Ok((PartInfo::from_metadata(path, &attributes)?, attributes))
}

/// Reads a part with its exact state, checking that it is whole: its content matches its
/// checksum, the state channels are all there, every value is finite, and every pixel holds
/// exactly the samples its coverage says.
pub fn read_part(path: &Path) -> Result<Part, PartError> {
    let (image, raw) = read_exr_verified(path)?;
    let info = PartInfo::from_metadata(path, &image.attributes)?;
    if (image.width, image.height) != (info.width as usize, info.height as usize) {
        return Err(refused(
            path,
            format!(
                "the pixels are {}x{} but brume:width/height say {}x{}",
                image.width, image.height, info.width, info.height
            ),
        ));
    }
    let channels: Vec<&Vec<u32>> = STATE_CHANNELS
        .iter()
        .map(|n| {
            raw.get(*n).ok_or_else(|| {
                refused(
                    path,
                    format!("no {n} channel: not a Brume part with its accumulator state"),
                )
            })
        })
        .collect::<Result<_, _>>()?;
    let n = image.width * image.height;
    let bits = |hi: &Vec<u32>, lo: &Vec<u32>, i: usize| {
        f64::from_bits(((hi[i] as u64) << 32) | lo[i] as u64)
    };
    // Adaptive sampling stops converged pixels early: they hold at most their coverage.
    let adaptive = image
        .attributes
        .get(super::context::NOISE_THRESHOLD_ATTRIBUTE)
        .is_some();
    let mut pixels = Vec::with_capacity(n);
    for i in 0..n {
        let mut p = PixelStats {
            count: channels[0][i],
            ..Default::default()
        };
        for c in 0..CHANNELS {
            let (m, m2) = (mean_channel(c), m2_channel(c));
            p.mean[c] = bits(channels[m], channels[m + 1], i);
            p.m2[c] = bits(channels[m2], channels[m2 + 1], i);
        }
        let (x, y) = ((i % image.width) as u32, (i / image.width) as u32);
        if !(p.mean.iter().chain(&p.m2).all(|v| v.is_finite())
            && image.rgb[i].iter().all(|v| v.is_finite()))
        {
            return Err(refused(
                path,
                format!(
                    "pixel ({x}, {y}) is not finite (mean {:?}, M2 {:?}): a NaN or infinite \
                     sample would poison the merge",
                    p.mean, p.m2
                ),
            ));
        }
        let expected: u64 = info
            .coverage
            .iter()
            .filter(|c| c.contains_pixel(x, y))
            .map(|c| (c.end - c.start) as u64)
            .sum();
        if p.count as u64 != expected && !(adaptive && (p.count as u64) < expected) {
            return Err(refused(
                path,
                format!(
                    "pixel ({x}, {y}) holds {} samples but the coverage {} says {expected}",
                    p.count,
                    coverage_text(&info.coverage)
                ),
            ));
        }
        pixels.push(p);
    }
    let mut film = Film::from_pixels(info.width, info.height, pixels)
        .expect("the pixel count was checked against the size");
    let names = pass_names(&image.attributes);
    if !names.is_empty() {
        film.set_passes(read_pass_state(path, &raw, &names, n)?);
    }
    Ok(Part {
        path: path.to_path_buf(),
        info,
        film,
        metadata: image.attributes,
    })
}

/// The light passes a file's header lists ([`crate::film::exr_io::PASSES_ATTRIBUTE`]), in layer
/// order; none without the attribute.
pub fn pass_names(meta: &Metadata) -> Vec<String> {
    meta.text(crate::film::exr_io::PASSES_ATTRIBUTE)
        .map_or_else(Vec::new, |t| {
            t.split_whitespace().map(str::to_string).collect()
        })
}

/// The exact state of light passes `names` from a part's `u32` channels.
fn read_pass_state(
    path: &Path,
    raw: &std::collections::BTreeMap<String, Vec<u32>>,
    names: &[String],
    n: usize,
) -> Result<PassLayers, PartError> {
    let mut passes = PassLayers::new(names, n);
    for (k, name) in names.iter().enumerate() {
        let chans: Vec<&Vec<u32>> = crate::film::state::pass_state_channels(name)
            .iter()
            .map(|c| {
                raw.get(c).filter(|v| v.len() == n).ok_or_else(|| {
                    refused(
                        path,
                        format!("the header lists pass {name} but {c} is missing"),
                    )
                })
            })
            .collect::<Result<_, _>>()?;
        let bits = |hi: &Vec<u32>, lo: &Vec<u32>, i: usize| {
            f64::from_bits(((hi[i] as u64) << 32) | lo[i] as u64)
        };
        for i in 0..n {
            let mean = [0, 1, 2].map(|c| bits(chans[2 * c], chans[2 * c + 1], i));
            let m2 = [0, 1, 2].map(|c| bits(chans[6 + 2 * c], chans[7 + 2 * c], i));
            if !mean.iter().chain(&m2).all(|v| v.is_finite()) {
                return Err(refused(
                    path,
                    format!("pass {name} is not finite at pixel {i}: a NaN would poison the merge"),
                ));
            }
            passes.set(i, k, mean, m2);
        }
    }
    Ok(passes)
}
