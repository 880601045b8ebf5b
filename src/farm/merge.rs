//! Merging parts: checking that they are parts of one image and hold no (pixel, sample)
//! twice, then folding their exact states together (Chan et al.'s pairwise update).
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::coverage::coalesce;
use super::part::{read_part, read_part_info, refused, Part, PartError, PartInfo};
use crate::film::{AttrValue, Film, Metadata};

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
    // Every part keeps the same passes: they are part of the settings key.
    let names = super::part::pass_names(&heads[0].2);
    let mut film = Film::with_passes(heads[0].1.width, heads[0].1.height, &names);
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
