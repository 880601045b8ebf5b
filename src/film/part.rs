//! Parts of one image rendered apart (farm tasks, checkpoints) and their merge.
//!
//! A part is an ordinary Brume EXR (beauty, `variance.*`, `samples.Y`) plus
//!
//! - the film's exact accumulator state as `u32` channels ([`STATE_CHANNELS`]): per pixel the
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
//! place apart). `tests/farm_parts.rs` checks both.
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use thiserror::Error;

use super::accum::{Film, PixelStats};
use super::error::FilmError;
use super::exr_io::{collect_attributes, read_exr_verified};
use super::metadata::{AttrValue, Metadata};

/// The `u32` channels holding the accumulator state: count, then per channel the high and low
/// 32 bits of the f64 mean and of the f64 `M2`.
pub const STATE_CHANNELS: [&str; 13] = [
    "accum.count",
    "accum.mean_hi.R",
    "accum.mean_lo.R",
    "accum.mean_hi.G",
    "accum.mean_lo.G",
    "accum.mean_hi.B",
    "accum.mean_lo.B",
    "accum.m2_hi.R",
    "accum.m2_lo.R",
    "accum.m2_hi.G",
    "accum.m2_lo.G",
    "accum.m2_hi.B",
    "accum.m2_lo.B",
];

/// The state channels of `film`, named as in [`STATE_CHANNELS`].
pub fn state_channels(film: &Film) -> Vec<(String, Vec<u32>)> {
    let px = film.pixels();
    let mut out: Vec<(String, Vec<u32>)> = STATE_CHANNELS
        .iter()
        .map(|n| (n.to_string(), Vec::with_capacity(px.len())))
        .collect();
    for p in px {
        out[0].1.push(p.count);
        for c in 0..3 {
            let (m, m2) = (p.mean[c].to_bits(), p.m2[c].to_bits());
            out[1 + 2 * c].1.push((m >> 32) as u32);
            out[2 + 2 * c].1.push(m as u32);
            out[7 + 2 * c].1.push((m2 >> 32) as u32);
            out[8 + 2 * c].1.push(m2 as u32);
        }
    }
    out
}

/// Why a part cannot be read, resumed or merged. Every message names the file.
#[derive(Debug, Error)]
pub enum PartError {
    #[error(transparent)]
    Film(#[from] FilmError),
    #[error("{path}: {reason}")]
    Refused { path: PathBuf, reason: String },
}

fn refused(path: &Path, reason: impl Into<String>) -> PartError {
    PartError::Refused {
        path: path.to_path_buf(),
        reason: reason.into(),
    }
}

/// Sample indices `[start, end)` of every pixel of `region` (`[x0, y0, x1, y1]`, half-open).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Coverage {
    pub start: u32,
    pub end: u32,
    pub region: [u32; 4],
}

impl Coverage {
    /// Whether the two hold a common (pixel, sample).
    pub fn overlaps(&self, o: &Coverage) -> bool {
        let [ax0, ay0, ax1, ay1] = self.region;
        let [bx0, by0, bx1, by1] = o.region;
        self.start.max(o.start) < self.end.min(o.end)
            && ax0.max(bx0) < ax1.min(bx1)
            && ay0.max(by0) < ay1.min(by1)
    }

    fn contains_pixel(&self, x: u32, y: u32) -> bool {
        let [x0, y0, x1, y1] = self.region;
        (x0..x1).contains(&x) && (y0..y1).contains(&y)
    }
}

impl std::fmt::Display for Coverage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let [x0, y0, x1, y1] = self.region;
        write!(f, "{}..{}@{x0},{y0},{x1},{y1}", self.start, self.end)
    }
}

/// Parses `START..END` (half-open sample indices).
pub fn parse_range(s: &str) -> Result<(u32, u32), String> {
    let (a, b) = s
        .split_once("..")
        .ok_or_else(|| format!("sample range {s:?} is not START..END"))?;
    let num = |t: &str| {
        t.trim()
            .parse::<u32>()
            .map_err(|e| format!("sample range {s:?}: {t:?}: {e}"))
    };
    let (a, b) = (num(a)?, num(b)?);
    if a > b {
        return Err(format!("sample range {s:?} ends before it starts"));
    }
    Ok((a, b))
}

/// Parses `x0,y0,x1,y1` (a half-open pixel rectangle).
pub fn parse_region(s: &str) -> Result<[u32; 4], String> {
    let v: Vec<u32> = s
        .split(',')
        .map(|t| t.trim().parse::<u32>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("region {s:?} is not x0,y0,x1,y1: {e}"))?;
    match v[..] {
        [x0, y0, x1, y1] if x0 < x1 && y0 < y1 => Ok([x0, y0, x1, y1]),
        [_, _, _, _] => Err(format!("region {s:?} is empty (need x0 < x1 and y0 < y1)")),
        _ => Err(format!("region {s:?} is not x0,y0,x1,y1")),
    }
}

fn parse_coverage(s: &str) -> Result<Vec<Coverage>, String> {
    if s.is_empty() {
        return Ok(Vec::new());
    }
    s.split(';')
        .map(|item| {
            let (range, region) = item
                .split_once('@')
                .ok_or_else(|| format!("coverage item {item:?} is not START..END@x0,y0,x1,y1"))?;
            let (start, end) = parse_range(range)?;
            // An empty range has an empty region on its side of no consequence.
            let region = parse_region(region)?;
            Ok(Coverage { start, end, region })
        })
        .collect()
}

/// Sorts coverage items and joins neighbours (same region, touching ranges), so that the
/// coverage of a merge of merges stays short.
pub fn coalesce(mut items: Vec<Coverage>) -> Vec<Coverage> {
    items.retain(|c| c.start < c.end);
    items.sort_by_key(|c| (c.region, c.start));
    let mut out: Vec<Coverage> = Vec::with_capacity(items.len());
    for c in items {
        match out.last_mut() {
            Some(l) if l.region == c.region && l.end == c.start => l.end = c.end,
            _ => out.push(c),
        }
    }
    out.sort_by_key(|c| (c.start, c.region));
    out
}

fn coverage_text(items: &[Coverage]) -> String {
    items
        .iter()
        .map(Coverage::to_string)
        .collect::<Vec<_>>()
        .join(";")
}

/// What a part is a part of, and what it holds; stored as `brume:*` header attributes.
#[derive(Clone, Debug, PartialEq)]
pub struct PartInfo {
    /// FNV-1a 64 of the scene file and every file it references ([`scene_hash`]).
    pub scene_hash: String,
    /// Every setting that shapes the image, as `key=value` words ([`settings_key`]).
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

/// The image-shaping settings as `key=value` words (everything but the sample range, region,
/// tile size, time limit and thread count, which do not change a pixel's samples).
pub fn settings_key(s: &crate::integrator::RenderSettings, camera: Option<&str>) -> String {
    format!(
        "estimator={} b={} m={} majorant={} shadow={:?} spectral={} absorption={} generic={} \
         sampler={} max_depth={} rr_depth={} rr_throughput={} max_pass_spp={} \
         max_collisions={} env_sampling={} light_selection={} camera={}",
        s.estimator,
        s.b,
        s.m_or_default()
            .map_or("minorant".into(), |m| m.to_string()),
        s.majorant.name(),
        s.shadow,
        s.force_spectral,
        s.absorption.name(),
        s.generic,
        s.sampler.name(),
        s.max_depth,
        s.rr_depth,
        s.rr_throughput,
        s.max_pass_spp,
        s.max_collisions_per_path,
        s.env_sampling,
        s.light_selection.name(),
        camera.unwrap_or("-"),
    )
}

/// FNV-1a 64 (stable across builds and machines, unlike `std`'s hasher).
struct Fnv(u64);

impl Fnv {
    fn new() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
    fn eat(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= b as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
}

/// A content hash of a scene: FNV-1a 64 over the scene file and every file its JSON refers to
/// by a relative `uri` (buffers, images, OpenVDB grids, environment maps), in sorted order,
/// each preceded by its URI. Files that cannot be read are hashed by name only (the scene
/// loader reports them).
pub fn scene_hash(scene: &Path) -> Result<String, PartError> {
    let bytes = std::fs::read(scene).map_err(|e| FilmError::io("read", scene, e))?;
    let mut h = Fnv::new();
    h.eat(&bytes);
    // A .glb holds its JSON in the first chunk, after a 12-byte header and an 8-byte chunk
    // header; a .gltf is JSON.
    let json_bytes = if bytes.starts_with(b"glTF") && bytes.len() >= 20 {
        let len = u32::from_le_bytes([bytes[12], bytes[13], bytes[14], bytes[15]]) as usize;
        &bytes[20..(20 + len).min(bytes.len())]
    } else {
        &bytes[..]
    };
    let mut uris = Vec::new();
    if let Ok(json) = serde_json::from_slice::<serde_json::Value>(json_bytes) {
        collect_uris(&json, &mut uris);
    }
    uris.sort();
    uris.dedup();
    let base = scene.parent().unwrap_or(Path::new("."));
    for uri in uris {
        h.eat(uri.as_bytes());
        h.eat(&[0]);
        // Streamed: a referenced VDB can be larger than memory allows to hold twice.
        if let Ok(mut f) = std::fs::File::open(base.join(&uri)) {
            use std::io::Read;
            let mut buf = vec![0u8; 1 << 20];
            loop {
                match f.read(&mut buf) {
                    Ok(0) | Err(_) => break,
                    Ok(n) => h.eat(&buf[..n]),
                }
            }
        }
    }
    Ok(format!("{:016x}", h.0))
}

fn collect_uris(v: &serde_json::Value, out: &mut Vec<String>) {
    match v {
        serde_json::Value::Object(map) => {
            for (k, v) in map {
                match v {
                    serde_json::Value::String(s) if k == "uri" && !s.starts_with("data:") => {
                        out.push(s.clone())
                    }
                    _ => collect_uris(v, out),
                }
            }
        }
        serde_json::Value::Array(a) => a.iter().for_each(|v| collect_uris(v, out)),
        _ => {}
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
    let mut pixels = Vec::with_capacity(n);
    for i in 0..n {
        let mut p = PixelStats {
            count: channels[0][i],
            ..Default::default()
        };
        for c in 0..3 {
            p.mean[c] = bits(channels[1 + 2 * c], channels[2 + 2 * c], i);
            p.m2[c] = bits(channels[7 + 2 * c], channels[8 + 2 * c], i);
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
        if p.count as u64 != expected {
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
    let film = Film::from_pixels(info.width, info.height, pixels)
        .expect("the pixel count was checked against the size");
    Ok(Part {
        path: path.to_path_buf(),
        info,
        film,
        metadata: image.attributes,
    })
}

/// Checks that the parts can be merged: same scene, settings, seed, version and size, and no
/// (pixel, sample) held twice. Returns the order to fold them in (by first sample index).
pub fn check_mergeable(parts: &[(PathBuf, PartInfo)]) -> Result<Vec<usize>, PartError> {
    let Some((p0, i0)) = parts.first() else {
        return Err(refused(Path::new("(no parts)"), "nothing to merge"));
    };
    for (p, i) in &parts[1..] {
        i0.check_same_image(p0, i, p)?;
    }
    for (a, (pa, ia)) in parts.iter().enumerate() {
        for (pb, ib) in &parts[a + 1..] {
            for ca in &ia.coverage {
                if let Some(cb) = ib.coverage.iter().find(|cb| ca.overlaps(cb)) {
                    return Err(refused(
                        pb,
                        format!(
                            "overlaps {}: samples {cb} against {ca} (each (pixel, sample) \
                             must come from one part)",
                            pa.display()
                        ),
                    ));
                }
            }
        }
    }
    let mut order: Vec<usize> = (0..parts.len()).collect();
    let first = |i: &PartInfo| i.coverage.iter().map(|c| c.start).min().unwrap_or(u32::MAX);
    order.sort_by_key(|&k| (first(&parts[k].1), k));
    Ok(order)
}

/// The merged header: the first part's attributes with the coverage, seconds, part count,
/// spp and backends of all of them.
pub fn merged_metadata(parts: &[(PathBuf, PartInfo, Metadata)], film: &Film) -> Metadata {
    let mut meta = parts[0].2.clone();
    let mut info = parts[0].1.clone();
    info.coverage = coalesce(
        parts
            .iter()
            .flat_map(|(_, i, _)| i.coverage.iter().copied())
            .collect(),
    );
    info.target = None;
    info.seconds = parts.iter().map(|(_, i, _)| i.seconds).sum();
    info.parts = parts.iter().map(|(_, i, _)| i.parts).sum();
    info.write_into(&mut meta);
    let spp = film.pixels().iter().map(|p| p.count).max().unwrap_or(0);
    meta.set("brume:spp", AttrValue::Int(spp.min(i32::MAX as u32) as i32));
    let mut backends: BTreeMap<String, ()> = BTreeMap::new();
    let mut interrupted = false;
    for (_, _, m) in parts {
        if let Some(b) = m.text("brume:backend") {
            for b in b.split(" + ") {
                backends.insert(b.to_string(), ());
            }
        }
        interrupted |= m.text("brume:interrupted") == Some("true");
    }
    meta.set(
        "brume:backend",
        AttrValue::Text(backends.into_keys().collect::<Vec<_>>().join(" + ")),
    );
    meta.set(
        "brume:interrupted",
        AttrValue::Text(interrupted.to_string()),
    );
    meta
}

/// Merges the parts at `paths`: headers first (every refusal before any pixel is read), then
/// each part's pixels in sample order folded into one film. Returns the film and its header;
/// the caller writes it (atomically). Memory: up to 9 films, whatever the number of parts.
pub fn merge_files(paths: &[PathBuf]) -> Result<(Film, Metadata), PartError> {
    let mut heads = Vec::with_capacity(paths.len());
    for p in paths {
        let (info, meta) = read_part_info(p)?;
        heads.push((p.clone(), info, meta));
    }
    let order = check_mergeable(
        &heads
            .iter()
            .map(|(p, i, _)| (p.clone(), i.clone()))
            .collect::<Vec<_>>(),
    )?;
    let mut film = Film::new(heads[0].1.width, heads[0].1.height);
    // Decoding dominates: read a few parts at once (rayon), fold them in sample order. At most
    // MAX_PARTS_IN_FLIGHT films are held besides the sum.
    const MAX_PARTS_IN_FLIGHT: usize = 8;
    let batch = rayon::current_num_threads().clamp(1, MAX_PARTS_IN_FLIGHT);
    for ks in order.chunks(batch) {
        use rayon::prelude::*;
        let parts: Vec<Result<Part, PartError>> =
            ks.par_iter().map(|&k| read_part(&heads[k].0)).collect();
        // The first refusal in sample order, whichever thread found it first.
        for (part, &k) in parts.into_iter().zip(ks) {
            let part = part?;
            // The header was read twice; a file changed in between is not the one checked.
            if part.info != heads[k].1 {
                return Err(refused(&heads[k].0, "changed while being merged"));
            }
            film.merge_film(&part.film);
        }
    }
    let meta = merged_metadata(&heads, &film);
    Ok((film, meta))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_regions_and_coverage_parse_and_coalesce() {
        assert_eq!(parse_range("3..9"), Ok((3, 9)));
        assert_eq!(parse_range("4..4"), Ok((4, 4)));
        assert!(parse_range("9..3").is_err());
        assert!(parse_range("3-9").is_err());
        assert_eq!(parse_region("0,1,2,3"), Ok([0, 1, 2, 3]));
        assert!(parse_region("2,1,2,3").is_err());
        let r = [0, 0, 4, 4];
        let c = |start, end| Coverage {
            start,
            end,
            region: r,
        };
        assert_eq!(coalesce(vec![c(4, 8), c(0, 4), c(8, 8)]), vec![c(0, 8)]);
        let items = vec![c(0, 2), c(5, 9)];
        assert_eq!(parse_coverage(&coverage_text(&items)), Ok(items));
        assert!(c(0, 4).overlaps(&c(3, 5)));
        assert!(!c(0, 4).overlaps(&c(4, 5)));
        let other = Coverage {
            start: 0,
            end: 4,
            region: [4, 0, 8, 4],
        };
        assert!(!c(0, 4).overlaps(&other));
    }
}
