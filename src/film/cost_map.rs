//! Cost heat maps: where in the image the renderer spent its work.
//!
//! A map holds, per pixel, the cost of one camera sample there: a tile's counter summed over
//! all passes, divided by the tile's samples summed over all passes, painted over the tile.
//! Tiles are the resolution of the log; a per-pixel counter array gives a sharper map through
//! [`per_sample`]. Pixels no record covers, and tiles with no samples, read 0.
use super::error::FilmError;
use super::exr_io::write_exr_single;
use super::metadata::{AttrValue, Metadata, PREFIX};
use super::tile_log::{TileRecord, TileTotals};
use std::collections::BTreeMap;
use std::path::Path;

/// What a cost map measures. Every metric is per camera sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CostMetric {
    /// Density grid lookups per sample (all lookups, shadow rays included).
    DensityLookups,
    /// Wall-clock nanoseconds per sample.
    Nanoseconds,
    /// Null collisions per sample.
    NullCollisions,
    /// Density lookups on shadow rays per sample.
    ShadowLookups,
    /// Scattering vertices per sample (mean path length).
    PathLength,
    /// Majorant segments (DDA or hierarchy steps) per sample, shadow rays included.
    Segments,
}

impl CostMetric {
    /// Short name, written to the map's header as `brume:cost_metric`.
    pub fn name(self) -> &'static str {
        match self {
            CostMetric::DensityLookups => "density_lookups",
            CostMetric::Nanoseconds => "wall_ns",
            CostMetric::NullCollisions => "null_collisions",
            CostMetric::ShadowLookups => "shadow_lookups",
            CostMetric::PathLength => "path_length",
            CostMetric::Segments => "majorant_segments",
        }
    }

    /// Units of the map's values, written to the header as `brume:cost_units`.
    pub fn units(self) -> &'static str {
        match self {
            CostMetric::DensityLookups => "density lookups per sample",
            CostMetric::Nanoseconds => "nanoseconds per sample",
            CostMetric::NullCollisions => "null collisions per sample",
            CostMetric::ShadowLookups => "shadow density lookups per sample",
            CostMetric::PathLength => "scattering vertices per sample",
            CostMetric::Segments => "majorant segments per sample",
        }
    }

    /// The metric over a set of records; 0 with no samples.
    pub fn per_sample(self, t: &TileTotals) -> f64 {
        let numerator = match self {
            CostMetric::DensityLookups => t.counters.density_lookups,
            CostMetric::Nanoseconds => t.counters.wall_ns,
            CostMetric::NullCollisions => t.counters.null_collisions,
            CostMetric::ShadowLookups => t.counters.shadow_lookups,
            CostMetric::PathLength => t.counters.path_length_sum,
            CostMetric::Segments => t.counters.majorant_segments,
        };
        if t.counters.samples == 0 {
            0.0
        } else {
            numerator as f64 / t.counters.samples as f64
        }
    }
}

/// A `width * height` map (row-major from the top-left) of `metric` per sample, from per-tile
/// records; passes of the same tile are summed first. Parts of tiles outside the image are
/// ignored.
pub fn cost_map_from_tiles(
    width: u32,
    height: u32,
    records: &[TileRecord],
    metric: CostMetric,
) -> Vec<f32> {
    // Sum each tile's passes; keyed by rectangle so the painting order is fixed.
    let mut per_tile: BTreeMap<(u32, u32, u32, u32), TileTotals> = BTreeMap::new();
    for r in records {
        per_tile.entry((r.y0, r.x0, r.y1, r.x1)).or_default().add(r);
    }
    let mut map = vec![0.0f32; width as usize * height as usize];
    for ((y0, x0, y1, x1), totals) in per_tile {
        let value = metric.per_sample(&totals) as f32;
        for y in y0..y1.min(height) {
            let row = y as usize * width as usize;
            for x in x0..x1.min(width) {
                map[row + x as usize] = value;
            }
        }
    }
    map
}

/// A per-pixel map from per-pixel counters: `counts[i] / samples[i]`, 0 where a pixel has no
/// samples.
///
/// # Panics
/// If the slices differ in length.
pub fn per_sample(counts: &[u64], samples: &[u32]) -> Vec<f32> {
    assert_eq!(
        counts.len(),
        samples.len(),
        "one count and one sample number per pixel"
    );
    counts
        .iter()
        .zip(samples)
        .map(|(&c, &n)| {
            if n == 0 {
                0.0
            } else {
                (c as f64 / n as f64) as f32
            }
        })
        .collect()
}

/// Writes the tile cost map for `metric` as a one-channel (`Y`) EXR, atomically, with
/// `brume:cost_metric` and `brume:cost_units` added to `metadata`.
pub fn write_cost_map(
    path: impl AsRef<Path>,
    width: u32,
    height: u32,
    records: &[TileRecord],
    metric: CostMetric,
    metadata: &Metadata,
) -> Result<(), FilmError> {
    let map = cost_map_from_tiles(width, height, records, metric);
    let metadata = metadata
        .clone()
        .with(
            format!("{PREFIX}cost_metric"),
            AttrValue::Text(metric.name().into()),
        )
        .with(
            format!("{PREFIX}cost_units"),
            AttrValue::Text(metric.units().into()),
        );
    write_exr_single(path, width as usize, height as usize, &map, &metadata)
}
