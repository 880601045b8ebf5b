//! Light passes of a reference render beside Brume's: Cycles' passes mapped onto Brume's
//! [`LIGHT_PASSES`], merged across runs as the beauty is, written as `<pass>.R/G/B` and
//! `<pass>.variance.R/G/B` layers, and compared pass by pass with a Brume render's.
use std::path::Path;

use anyhow::{anyhow, bail, Context, Result};

use crate::film::exr_io::PASSES_ATTRIBUTE;
use crate::film::passes::LIGHT_PASSES;
use crate::film::{read_exr_channels, ExrChannels, Image, Metadata};

use super::agreement::compare;
use super::merge::merge_runs;

/// One pass of a render: its name and its image (mean, variance of the mean, samples).
pub type PassImage = (String, Image);

/// One run's passes: name and value per pixel.
pub type RunPasses = Vec<(String, Vec<[f32; 3]>)>;

/// A Cycles pass (by name) times its colour pass, if it has one.
type Term = (&'static str, Option<&'static str>);

/// Cycles' passes making up each of Brume's light passes, as sums of `light x colour`. Cycles
/// divides a surface's Direct and Indirect passes by its Color pass (their product is the
/// light), and splits surfaces into Diffuse, Glossy and Transmission, which Brume keeps as
/// one; volume passes hold the light itself.
const CYCLES_LIGHT_PASSES: [(&str, &[Term]); 6] = [
    ("emission", &[("Emission", None)]),
    ("background", &[("Environment", None)]),
    ("volume.direct", &[("Volume Direct", None)]),
    ("volume.indirect", &[("Volume Indirect", None)]),
    (
        "surface.direct",
        &[
            ("Diffuse Direct", Some("Diffuse Color")),
            ("Glossy Direct", Some("Glossy Color")),
            ("Transmission Direct", Some("Transmission Color")),
        ],
    ),
    (
        "surface.indirect",
        &[
            ("Diffuse Indirect", Some("Diffuse Color")),
            ("Glossy Indirect", Some("Glossy Color")),
            ("Transmission Indirect", Some("Transmission Color")),
        ],
    ),
];

/// Brume's light passes of one Cycles run (a multilayer EXR whose view layer holds the
/// passes `tools/cycles/brume_to_cycles.py --passes light` turns on), per pixel.
pub fn cycles_light_passes(path: &Path) -> Result<RunPasses> {
    let exr = read_exr_channels(path)?;
    let layer = exr
        .by_name
        .keys()
        .find_map(|k| k.strip_suffix("Combined.R"))
        .ok_or_else(|| {
            anyhow!(
                "{}: no Combined pass: not a Cycles multilayer EXR",
                path.display()
            )
        })?
        .to_string();
    let n = exr.width * exr.height;
    let rgb = |pass: &str| rgb_layer(path, &exr, &format!("{layer}{pass}"));
    debug_assert_eq!(CYCLES_LIGHT_PASSES.map(|p| p.0), LIGHT_PASSES);
    let mut out = Vec::new();
    for (name, terms) in CYCLES_LIGHT_PASSES {
        let mut sum = vec![[0f32; 3]; n];
        for (light, colour) in terms {
            let light = rgb(light)?;
            let colour = match colour {
                Some(c) => rgb(c)?,
                None => vec![[1.0; 3]; n],
            };
            for ((s, l), k) in sum.iter_mut().zip(&light).zip(&colour) {
                for c in 0..3 {
                    s[c] += l[c] * k[c];
                }
            }
        }
        out.push((name.to_string(), sum));
    }
    Ok(out)
}

/// Merges each pass across independent runs as [`merge_runs`] merges the beauty.
pub fn merge_pass_runs(
    runs: &[RunPasses],
    size: (usize, usize),
    spp: u32,
) -> Result<Vec<PassImage>> {
    let Some(first) = runs.first() else {
        return Ok(Vec::new());
    };
    let image = |rgb: Vec<[f32; 3]>| Image {
        width: size.0,
        height: size.1,
        rgb,
        alpha: None,
        variance: None,
        samples: None,
        attributes: Metadata::new(),
    };
    let mut out = Vec::new();
    for (k, (name, _)) in first.iter().enumerate() {
        let images: Vec<Image> = runs.iter().map(|r| image(r[k].1.clone())).collect();
        let mut merged = merge_runs(&images, spp, Metadata::new())?;
        merged.alpha = None;
        out.push((name.clone(), merged));
    }
    Ok(out)
}

/// The `<pass>.R/G/B` and `<pass>.variance.R/G/B` channels of `passes`, to write beside the
/// beauty, and the [`PASSES_ATTRIBUTE`] naming them.
pub fn pass_channels(passes: &[PassImage]) -> (Vec<(String, Vec<f32>)>, String) {
    let mut channels = Vec::new();
    for (name, image) in passes {
        for (c, ch) in ["R", "G", "B"].into_iter().enumerate() {
            channels.push((
                format!("{name}.{ch}"),
                image.rgb.iter().map(|p| p[c]).collect(),
            ));
            if let Some(v) = &image.variance {
                channels.push((
                    format!("{name}.variance.{ch}"),
                    v.iter().map(|p| p[c]).collect(),
                ));
            }
        }
    }
    let names: Vec<&str> = passes.iter().map(|(n, _)| n.as_str()).collect();
    (channels, names.join(" "))
}

/// The passes an EXR lists in [`PASSES_ATTRIBUTE`], each with its variance: a reference's
/// from its `<pass>.variance.*` layers, a Brume render's from its exact accumulator state.
pub fn read_passes(path: &Path, meta: &Metadata) -> Result<Vec<PassImage>> {
    let Some(list) = meta.text(PASSES_ATTRIBUTE) else {
        return Ok(Vec::new());
    };
    let names: Vec<String> = list.split_whitespace().map(str::to_string).collect();
    let exr = read_exr_channels(path)?;
    let has_variance = |name: &str| exr.by_name.contains_key(&format!("{name}.variance.R"));
    if names.iter().all(|n| has_variance(n)) {
        return names
            .iter()
            .map(|n| Ok((n.clone(), pass_from_channels(path, &exr, n)?)))
            .collect();
    }
    let part = crate::farm::read_part(path)
        .with_context(|| format!("reading the passes' state of {}", path.display()))?;
    let film = &part.film;
    let Some(layers) = film.passes() else {
        bail!("{}: lists passes but holds none", path.display());
    };
    let pixels = film.pixels();
    let mut out = Vec::new();
    for (k, name) in layers.names().iter().enumerate() {
        let f32s = |v: [f64; 3]| v.map(|x| x as f32);
        out.push((
            name.clone(),
            Image {
                width: film.width() as usize,
                height: film.height() as usize,
                rgb: (0..pixels.len()).map(|i| f32s(layers.mean(i, k))).collect(),
                alpha: None,
                variance: Some(
                    (0..pixels.len())
                        .map(|i| f32s(layers.variance_of_mean(i, k, pixels[i].count)))
                        .collect(),
                ),
                samples: Some(pixels.iter().map(|p| p.count as f32).collect()),
                attributes: Metadata::new(),
            },
        ));
    }
    Ok(out)
}

/// Layer `prefix`'s `R`, `G` and `B` channels of `exr` (read from `path`), per pixel.
fn rgb_layer(path: &Path, exr: &ExrChannels, prefix: &str) -> Result<Vec<[f32; 3]>> {
    let c = |ch: &str| {
        exr.by_name
            .get(&format!("{prefix}.{ch}"))
            .ok_or_else(|| anyhow!("{}: no {prefix}.{ch} channel", path.display()))
    };
    let (r, g, b) = (c("R")?, c("G")?, c("B")?);
    Ok((0..r.len()).map(|i| [r[i], g[i], b[i]]).collect())
}

/// Pass `name` read from its mean and variance layers.
fn pass_from_channels(path: &Path, exr: &ExrChannels, name: &str) -> Result<Image> {
    let triple = |prefix: &str| rgb_layer(path, exr, prefix);
    Ok(Image {
        width: exr.width,
        height: exr.height,
        rgb: triple(name)?,
        alpha: None,
        variance: Some(triple(&format!("{name}.variance"))?),
        samples: exr.by_name.get("samples.Y").cloned(),
        attributes: Metadata::new(),
    })
}

/// One line per pass the two renders share: `pass <name> <agreement>`, or that the pass is
/// zero in both (nothing to compare).
pub fn compare_passes(brume: &[PassImage], reference: &[PassImage]) -> Result<Vec<String>> {
    let mut lines = Vec::new();
    for (name, b) in brume {
        let Some((_, r)) = reference.iter().find(|(n, _)| n == name) else {
            continue;
        };
        let zero = |i: &Image| i.rgb.iter().flatten().all(|&v| v == 0.0);
        if zero(b) && zero(r) {
            lines.push(format!("pass {name} zero in both"));
            continue;
        }
        lines.push(format!("pass {name} {}", compare(b, r, 8, 0.001)?));
    }
    Ok(lines)
}
