//! Tile logs: JSON lines that parse back, totals that add up, atomic output, cost maps.
use brume::film::{
    cost_map_from_tiles, read_exr, read_tile_log, tiles, totals, write_cost_map, CostMetric,
    FilmError, Metadata, TileLogWriter, TileRecord,
};
use std::path::{Path, PathBuf};

fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("film_tile_log-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// Two passes over a 20x12 image in 8-pixel tiles with made-up but distinct counters.
fn records() -> Vec<TileRecord> {
    let mut out = Vec::new();
    for pass in 0..2 {
        for rect in tiles(20, 12, 8) {
            let mut r = TileRecord::new(pass, &rect);
            let k = rect.index as u64 + 1;
            r.counters.samples = rect.pixel_count() as u64 * 4;
            r.counters.wall_ns = 1_000_000 * k + pass as u64;
            r.counters.density_lookups = r.counters.samples * (10 + k);
            r.counters.null_collisions = 3 * k;
            r.counters.real_collisions = 5 * k;
            r.counters.shadow_lookups = r.counters.samples * k;
            r.counters.path_length_sum = r.counters.samples * 2 + k;
            r.counters.guard_fired = (k == 3) as u64;
            out.push(r);
        }
    }
    out
}

#[test]
fn lines_parse_back_and_totals_add_up() {
    let dir = scratch("round_trip");
    let path = dir.join("tiles.jsonl");
    let recs = records();
    let mut log = TileLogWriter::create(&path).unwrap();
    for r in &recs {
        log.append(r).unwrap();
    }
    assert!(!path.exists(), "the log appears only when finished");
    let written = log.finish().unwrap();
    assert_eq!(listing(&dir), ["tiles.jsonl"]);

    let text = std::fs::read_to_string(&path).unwrap();
    assert_eq!(text.lines().count(), recs.len());
    let first: serde_json::Value = serde_json::from_str(text.lines().next().unwrap()).unwrap();
    assert_eq!(first["tile"], 0);
    assert_eq!(first["density_lookups"], recs[0].counters.density_lookups);

    let back = read_tile_log(&path).unwrap();
    assert_eq!(back, recs);
    let t = totals(&back);
    assert_eq!(t, written);
    assert_eq!(t.records, recs.len() as u64);
    assert_eq!(t.counters.samples, 2 * 20 * 12 * 4);
    assert_eq!(
        t.counters.density_lookups,
        recs.iter().map(|r| r.counters.density_lookups).sum::<u64>()
    );
    assert_eq!(
        t.counters.wall_ns,
        recs.iter().map(|r| r.counters.wall_ns).sum::<u64>()
    );
    assert_eq!(t.counters.null_collisions, 2 * 3 * (1..=6).sum::<u64>());
    assert_eq!(t.counters.real_collisions, 2 * 5 * (1..=6).sum::<u64>());
    assert_eq!(
        t.counters.shadow_lookups,
        recs.iter().map(|r| r.counters.shadow_lookups).sum::<u64>()
    );
    assert_eq!(
        t.counters.path_length_sum,
        recs.iter().map(|r| r.counters.path_length_sum).sum::<u64>()
    );
    assert_eq!(t.counters.guard_fired, 2);
    assert_eq!(
        t.counters.mean_path_length(),
        t.counters.path_length_sum as f64 / t.counters.samples as f64
    );
}

#[test]
fn an_abandoned_log_leaves_nothing() {
    let dir = scratch("abandoned");
    let mut log = TileLogWriter::create(dir.join("tiles.jsonl")).unwrap();
    log.append(&records()[0]).unwrap();
    drop(log);
    assert!(listing(&dir).is_empty());
    let err = TileLogWriter::create(dir.join("missing/tiles.jsonl")).unwrap_err();
    assert!(err.to_string().contains("missing/tiles.jsonl"), "{err}");
}

#[test]
fn a_bad_line_is_named() {
    let dir = scratch("bad_line");
    let path = dir.join("tiles.jsonl");
    let good = serde_json::to_string(&records()[0]).unwrap();
    std::fs::write(&path, format!("{good}\n\n{{\"pass\": 1}}\n")).unwrap();
    let err = read_tile_log(&path).unwrap_err();
    assert!(
        matches!(err, FilmError::BadLogLine { line: 3, .. }),
        "{err}"
    );
    assert!(err.to_string().contains("tiles.jsonl:3"), "{err}");
    assert!(read_tile_log(dir.join("absent.jsonl")).is_err());
}

#[test]
fn cost_map_paints_per_sample_cost_over_each_tile() {
    let recs = records();
    let map = cost_map_from_tiles(20, 12, &recs, CostMetric::DensityLookups);
    // Tile k (1-based) does 10 + k lookups per sample in both passes.
    let ts = tiles(20, 12, 8);
    for rect in &ts {
        for y in rect.y0..rect.y1 {
            for x in rect.x0..rect.x1 {
                assert_eq!(map[(y * 20 + x) as usize], 10.0 + rect.index as f32 + 1.0);
            }
        }
    }
    // Time: both passes' nanoseconds over both passes' samples.
    let ns = cost_map_from_tiles(20, 12, &recs, CostMetric::Nanoseconds);
    let (r0, r1) = (&recs[0], &recs[ts.len()]);
    let expected = (r0.counters.wall_ns + r1.counters.wall_ns) as f64
        / (r0.counters.samples + r1.counters.samples) as f64;
    assert_eq!(ns[0], expected as f32);
    // No records: zeros.
    assert!(cost_map_from_tiles(4, 4, &[], CostMetric::Nanoseconds)
        .iter()
        .all(|&v| v == 0.0));

    let dir = scratch("cost_map");
    let path = dir.join("cost.exr");
    write_cost_map(
        &path,
        20,
        12,
        &recs,
        CostMetric::DensityLookups,
        &Metadata::new(),
    )
    .unwrap();
    let img = read_exr(&path).unwrap();
    assert_eq!(img.rgb.iter().map(|p| p[0]).collect::<Vec<_>>(), map);
    assert_eq!(
        img.attributes.text("brume:cost_units"),
        Some("density lookups per sample")
    );
    assert_eq!(
        img.attributes.text("brume:cost_metric"),
        Some("density_lookups")
    );
}
