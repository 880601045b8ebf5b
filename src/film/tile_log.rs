//! Per-tile performance records, one JSON object per line.
//!
//! A render log says where time and density lookups went, tile by tile and pass by pass, so
//! estimators can be compared by cost as well as by noise and a cost map can be drawn. JSON
//! lines keep the file appendable and readable by anything (`jq`, pandas).
use super::atomic::AtomicFile;
use super::error::FilmError;
use super::tiles::TileRect;
use serde::{Deserialize, Serialize};
use std::io::{BufRead, BufReader, Write};
use std::path::Path;

/// Work done rendering one tile in one pass. Counters are totals over all samples of the tile.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct TileRecord {
    /// Progressive pass number, from 0.
    pub pass: u32,
    /// Tile index ([`TileRect::index`]).
    pub tile: u32,
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
    /// Written as fields of the record itself (one flat JSON object per line).
    #[serde(flatten)]
    pub counters: TileCounters,
}

/// What rendering cost: totals over the samples of one tile in one pass ([`TileRecord`]), or
/// over many records ([`TileTotals`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct TileCounters {
    /// Camera samples taken (summed over the tile's pixels).
    pub samples: u64,
    /// Wall-clock time spent, in nanoseconds. Summed over tiles it is CPU-thread time, more
    /// than the render's elapsed time when tiles run in parallel.
    pub wall_ns: u64,
    /// Density grid lookups of every kind.
    pub density_lookups: u64,
    /// Null (fictitious) collisions: tentative collisions rejected by the real/null choice.
    pub null_collisions: u64,
    /// Real collisions: absorption or scattering events.
    pub real_collisions: u64,
    /// Density lookups made while estimating transmittance toward lights.
    pub shadow_lookups: u64,
    /// Sum over the paths of their length in scattering vertices; divided by `samples` it is
    /// the mean path length.
    pub path_length_sum: u64,
    /// How many times a safety guard (event or bounce cap) cut a path short.
    pub guard_fired: u64,
    /// Lookups where an analog estimator found the density above its majorant: the image is
    /// biased wherever this is non-zero (use a weighted estimator or a larger `b`).
    #[serde(default)]
    pub majorant_violations: u64,
    /// Emission-grid lookups (flame, temperature), made only in emissive scenes.
    #[serde(default)]
    pub emission_lookups: u64,
    /// Majorant segments walked by the free-flight loops (DDA or hierarchy steps), shadow
    /// rays included: the walk's cost next to `density_lookups`.
    #[serde(default)]
    pub majorant_segments: u64,
    /// Majorant segments walked by shadow rays.
    #[serde(default)]
    pub shadow_segments: u64,
}

impl std::ops::AddAssign<&TileCounters> for TileCounters {
    fn add_assign(&mut self, r: &TileCounters) {
        self.samples += r.samples;
        self.wall_ns += r.wall_ns;
        self.density_lookups += r.density_lookups;
        self.null_collisions += r.null_collisions;
        self.real_collisions += r.real_collisions;
        self.shadow_lookups += r.shadow_lookups;
        self.path_length_sum += r.path_length_sum;
        self.guard_fired += r.guard_fired;
        self.majorant_violations += r.majorant_violations;
        self.emission_lookups += r.emission_lookups;
        self.majorant_segments += r.majorant_segments;
        self.shadow_segments += r.shadow_segments;
    }
}

impl TileCounters {
    /// Density lookups per camera sample; 0 with no samples.
    pub fn lookups_per_sample(&self) -> f64 {
        ratio(self.density_lookups, self.samples)
    }

    /// Mean path length in scattering vertices per sample; 0 with no samples.
    pub fn mean_path_length(&self) -> f64 {
        ratio(self.path_length_sum, self.samples)
    }
}

impl TileRecord {
    /// A record for `rect` in `pass` with all counters at zero.
    pub fn new(pass: u32, rect: &TileRect) -> Self {
        TileRecord {
            pass,
            tile: rect.index,
            x0: rect.x0,
            y0: rect.y0,
            x1: rect.x1,
            y1: rect.y1,
            ..Default::default()
        }
    }

    /// The tile's rectangle.
    pub fn rect(&self) -> TileRect {
        TileRect {
            x0: self.x0,
            y0: self.y0,
            x1: self.x1,
            y1: self.y1,
            index: self.tile,
        }
    }
}

fn ratio(num: u64, den: u64) -> f64 {
    if den == 0 {
        0.0
    } else {
        num as f64 / den as f64
    }
}

/// Sums of the counters over a set of records.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct TileTotals {
    /// Number of records summed.
    pub records: u64,
    /// Their counters, summed (written as fields of the totals themselves).
    #[serde(flatten)]
    pub counters: TileCounters,
}

impl TileTotals {
    /// Sums `records`.
    pub fn over<'a>(records: impl IntoIterator<Item = &'a TileRecord>) -> Self {
        let mut t = TileTotals::default();
        for r in records {
            t.add(r);
        }
        t
    }

    /// Adds one record.
    pub fn add(&mut self, r: &TileRecord) {
        self.records += 1;
        self.counters += &r.counters;
    }
}

/// Sums the counters of `records` (shorthand for [`TileTotals::over`]).
pub fn totals(records: &[TileRecord]) -> TileTotals {
    TileTotals::over(records)
}

/// Writes tile records as JSON lines into a temporary file that becomes the log at
/// [`finish`](TileLogWriter::finish). A render that fails or panics drops the writer, which
/// removes the temporary file: a log on disk is always a complete one.
#[derive(Debug)]
pub struct TileLogWriter {
    out: AtomicFile,
    /// One line, reused: one write call per record is cheap next to rendering a tile.
    line: Vec<u8>,
    /// Running totals, so a long progressive render does not keep every record in memory.
    totals: TileTotals,
}

impl TileLogWriter {
    /// Starts a log that will appear at `path`.
    pub fn create(path: impl AsRef<Path>) -> Result<Self, FilmError> {
        Ok(Self {
            out: AtomicFile::create(path)?,
            line: Vec::new(),
            totals: TileTotals::default(),
        })
    }

    /// Appends one record as one line.
    pub fn append(&mut self, record: &TileRecord) -> Result<(), FilmError> {
        self.line.clear();
        serde_json::to_writer(&mut self.line, record)
            .expect("a TileRecord of plain integers always serialises");
        self.line.push(b'\n');
        let path = self.out.path().to_path_buf();
        self.out
            .file()
            .write_all(&self.line)
            .map_err(|e| FilmError::io("write", &path, e))?;
        self.totals.add(record);
        Ok(())
    }

    /// Totals of the records appended so far.
    pub fn totals(&self) -> TileTotals {
        self.totals
    }

    /// Syncs and renames the log into place; returns the totals of everything written.
    pub fn finish(self) -> Result<TileTotals, FilmError> {
        let totals = self.totals();
        self.out.commit()?;
        Ok(totals)
    }
}

/// Reads a tile log back. Blank lines are skipped; any other line that is not a record is an
/// error naming the file and line.
pub fn read_tile_log(path: impl AsRef<Path>) -> Result<Vec<TileRecord>, FilmError> {
    let path = path.as_ref();
    let file = std::fs::File::open(path).map_err(|e| FilmError::io("read", path, e))?;
    let mut records = Vec::new();
    for (i, line) in BufReader::new(file).lines().enumerate() {
        let line = line.map_err(|e| FilmError::io("read", path, e))?;
        if line.trim().is_empty() {
            continue;
        }
        let record = serde_json::from_str(&line).map_err(|source| FilmError::BadLogLine {
            path: path.to_path_buf(),
            line: i + 1,
            source,
        })?;
        records.push(record);
    }
    Ok(records)
}
