//! `brume info`: what a file holds, and how well Brume's per-leaf bounds fit it.
use std::path::Path;

use anyhow::{bail, Result};
use brume_ffi::{GridClass, GridInfo, VdbFile};

use brume::volume::{load_grid_from, ConversionPolicy};

pub fn run(path: &Path, layout: bool) -> Result<()> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    match ext.as_str() {
        "vdb" => vdb(path, layout),
        "gltf" | "glb" => {
            let scene = brume::scene::load(path)?;
            scene
                .validate()
                .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
            print!("{scene}");
            for w in &scene.warnings {
                println!("warning: {w}");
            }
            Ok(())
        }
        other => bail!(
            "{}: unknown file type '.{other}' (expected .vdb, .gltf or .glb)",
            path.display()
        ),
    }
}

fn class_name(c: GridClass) -> &'static str {
    match c {
        GridClass::FogVolume => "fog volume",
        GridClass::LevelSet => "level set",
        GridClass::Staggered => "staggered",
        GridClass::Unknown => "unknown class",
    }
}

fn print_facts(g: &GridInfo) {
    let vs = g.voxel_size;
    println!(
        "  voxel size        {:.6} x {:.6} x {:.6}",
        vs[0], vs[1], vs[2]
    );
    if g.is_affine {
        println!("  world_from_index  (row-major; world = M * (i, j, k, 1))");
        for row in &g.world_from_index {
            println!(
                "                    [{:>11.6} {:>11.6} {:>11.6} {:>11.6}]",
                row[0], row[1], row[2], row[3]
            );
        }
    } else {
        println!("  world_from_index  non-affine (frustum) map: Brume cannot render this grid");
    }
    match g.active_bbox {
        Some((lo, hi)) => println!(
            "  active bbox       {lo:?} .. {hi:?} ({} x {} x {} voxels)",
            hi[0] - lo[0] + 1,
            hi[1] - lo[1] + 1,
            hi[2] - lo[2] + 1
        ),
        None => println!("  active bbox       empty (no active values)"),
    }
    println!(
        "  active voxels     {} ({} leaves, {} tiles)",
        g.active_voxel_count, g.leaf_count, g.tile_count
    );
    if let Some(b) = g.background {
        println!("  background        {b}");
    }
    for (k, t, v) in &g.metadata {
        println!("  meta {k:<16} {v} ({t})");
    }
}

fn vdb(path: &Path, layout: bool) -> Result<()> {
    let file = VdbFile::open(path)?;
    println!("{}: {} grid(s)", path.display(), file.grids().len());
    for (k, t, v) in file.metadata() {
        println!("file meta {k:<16} {v} ({t})");
    }
    for g in file.grids() {
        println!(
            "grid '{}': {}, {}",
            g.name,
            g.value_type,
            class_name(g.class)
        );
        print_facts(g);
        if !layout {
            continue;
        }
        if g.value_type != "float" {
            println!("  brume layout      none: only float grids can be rendered");
            continue;
        }
        match load_grid_from(&file, &g.name, ConversionPolicy::default()) {
            Ok(loaded) => {
                for w in &loaded.warnings {
                    println!("  warning           {w}");
                }
                let s = loaded.grid.stats();
                let d = loaded.grid.dims;
                println!(
                    "  brume layout      {} x {} x {} cells of 8^3 voxels: {} bricks, {:.1} % constant cells, {:.2} MiB",
                    d[0],
                    d[1],
                    d[2],
                    s.brick_count,
                    100.0 * s.constant_fraction,
                    s.total_bytes() as f64 / (1 << 20) as f64
                );
                let b = loaded.bounds.stats();
                println!(
                    "  global bounds     min {} max {}",
                    b.global_min, b.global_max
                );
                println!(
                    "  leaf tightness    mean leaf majorant / global max = {:.4}",
                    b.mean_max_over_global
                );
                println!("  empty leaf cells  {:.1} %", 100.0 * b.empty_fraction);
                let wb = loaded.grid.world_bounds();
                println!(
                    "  world bounds      {:?} .. {:?}",
                    wb.min.to_array(),
                    wb.max.to_array()
                );
            }
            Err(e) => println!("  brume layout      not convertible: {e}"),
        }
    }
    Ok(())
}
