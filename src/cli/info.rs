//! `brume info`: what a file holds, and how well Brume's per-leaf bounds fit it.
use std::path::Path;

use anyhow::{bail, Result};
use brume_ffi::{GridClass, GridInfo, VdbFile};

use brume::volume::{
    load_grid_from, load_vector_grid_from, AdaptiveMajorants, AdaptiveShape, ConversionPolicy,
    CostModel, LeafBounds,
};

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
            println!("{}", scene.geometry_stats().report(&scene.timings));
            for w in &scene.warnings {
                println!("warning: {w}");
            }
            // The adaptive majorants as a render builds them (for each medium's own density
            // scale and voxel size).
            let rs =
                brume::render::RenderScene::new(&scene, false).map_err(|e| anyhow::anyhow!(e))?;
            for (i, m) in rs.vdb.iter().enumerate() {
                print_adaptive(
                    &format!("medium {i}"),
                    &m.adaptive,
                    m.sigma_t_bound,
                    brume::render::prepare::index_per_t(&m.density),
                );
                // What the adaptive mode walks (an emitting medium keeps the cells for its
                // free flights where the model chose culling: `WalkPlan::of`).
                let adaptive = brume::render::MajorantMode::Adaptive;
                println!(
                    "medium {i} adaptive walks: free flights {}, shadow rays {}{}",
                    m.walk(adaptive).free.name(),
                    m.walk(adaptive).shadow.name(),
                    if m.emission.is_some() && m.adaptive.shape == AdaptiveShape::Culled {
                        " (emitting: free flights per leaf cell, not culled)"
                    } else {
                        ""
                    }
                );
                let g = &m.density.grid;
                print_voxel_bounds(&format!("medium {i}"), &g.grid, &g.bounds);
                if let Some(r) = m.emission.as_ref().and_then(|e| e.region) {
                    let b = r.bounds;
                    println!(
                        "medium {i} emission region (Cycles' volume box: the grids' active voxels, [min - 1, max + 2]; density index space): [{:.1}, {:.1}, {:.1}] .. [{:.1}, {:.1}, {:.1}]",
                        b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z
                    );
                }
                if let (Some(w), Some(_)) = (&m.walk_bounds, &m.blur) {
                    let mean = |b: &brume::volume::LeafBounds| {
                        b.cells.iter().map(|c| c.max as f64).sum::<f64>()
                            / b.cells.len().max(1) as f64
                    };
                    println!(
                        "medium {i} velocity blur: walk bounds dilated over the shutter by each cell's speed bound: {} cells (the density's {}), mean cell bound {:.4} (the density's {:.4}), world bounds {:?}; no per-voxel culling",
                        w.cells.len(),
                        g.bounds.cells.len(),
                        mean(w),
                        mean(&g.bounds),
                        m.world_bounds,
                    );
                } else if let Some(w) = &m.walk_bounds {
                    let raised = w
                        .cells
                        .iter()
                        .zip(&g.bounds.cells)
                        .filter(|(w, d)| w.max > d.max)
                        .count();
                    let floor = brume::render::emission_bounds::emission_floor(
                        w.dims,
                        m.sigma_t_bound,
                        brume::render::prepare::index_per_t(&m.density),
                    )
                    .unwrap_or(0.0)
                        * m.sigma_t_bound;
                    println!(
                        "medium {i} emission: its walks sample wherever it may emit: {raised} of {} leaf cells raised (to at most the emission floor {floor:.4} per metre, in proportion to their emission bound; their voxels with them: {} cells' voxels floored over the density's per-voxel table, shared, not copied)",
                        w.cells.len(),
                        w.voxel_floor.iter().filter(|&&f| f > 0).count(),
                    );
                }
                println!(
                    "medium {i} voxel culling: {} (thins where the collisions it culls save more lookups than its reads cost)",
                    if m.voxel_culling_pays { "on" } else { "off" }
                );
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

/// Where a Vec3 grid's components sit: OpenVDB's staggered class puts component `a` on the
/// voxel's lower face along `a`; every other class reads as cell-centred.
fn vector_class_name(c: GridClass) -> &'static str {
    match c {
        GridClass::Staggered => "staggered (components on the voxel's lower faces)",
        _ => "cell-centred",
    }
}

/// A Vec3 grid in Brume's layout: bricks, memory and the speed its lookups can reach.
fn print_vector_layout(file: &VdbFile, g: &GridInfo) {
    let v = match load_vector_grid_from(file, &g.name, ConversionPolicy::default()) {
        Ok(v) => v,
        Err(e) => {
            println!("  brume layout      not convertible: {e}");
            return;
        }
    };
    let d = v.dims();
    println!(
        "  brume layout      3 components over {} x {} x {} cells of 8^3 voxels: {} bricks, {:.2} MiB (speed bounds included)",
        d[0],
        d[1],
        d[2],
        v.brick_count(),
        v.memory_bytes() as f64 / (1 << 20) as f64
    );
    println!("  background        {:?}", v.background);
    println!(
        "  max speed         {:.6} in the grid's value units (world units per unit time) = {:.6} voxels per unit time (per-leaf-cell bounds)",
        v.speed.max_speed(),
        v.max_index_speed()
    );
}

/// The per-voxel culling bounds' memory, build time (rebuilt here to time it) and tightness.
fn print_voxel_bounds(label: &str, grid: &brume::volume::SparseGrid, bounds: &LeafBounds) {
    let start = std::time::Instant::now();
    let q = brume::volume::bounds::build_voxel_q(grid, &bounds.cells);
    let seconds = start.elapsed().as_secs_f64();
    let mean = q.iter().map(|&v| v as f64).sum::<f64>() / q.len().max(1) as f64 / 255.0;
    println!(
        "{label} per-voxel bounds: {:.1} KiB (a byte a brick voxel), built in {:.2} ms; mean voxel bound / cell bound {:.3}, collisions kept {:.3}{}",
        bounds.voxel_q.len() as f64 / 1024.0,
        1e3 * seconds,
        mean,
        brume::volume::voxel_bounds::kept_fraction(grid, bounds),
        if brume::volume::VoxelCulling::new(bounds, &grid.cells, 1.0).is_some() {
            ""
        } else {
            " (not used: no bricks, or the global minimum is not 0)"
        }
    );
}

/// The adaptive hierarchy's shape, model costs, build time and memory.
fn print_adaptive(label: &str, a: &AdaptiveMajorants, scale: f32, index_per_t: f32) {
    if a.nodes.is_empty() {
        // A grid of background only (an empty frame of a simulation): nothing to bound.
        println!("{label} adaptive majorants: none (the grid holds no voxels)");
        return;
    }
    let s = a.stats(scale, index_per_t, a.cost);
    let levels: Vec<String> = s
        .nodes_per_level
        .iter()
        .enumerate()
        .filter(|(_, &n)| n > 0)
        .map(|(l, n)| format!("{n} x {}^3", 8 << l))
        .collect();
    println!(
        "{label} adaptive majorants: {} merged nodes ({}; {}), built in {:.2} ms, {:.1} KiB; model cost per ray: adaptive {:.2}, per-leaf {:.2}, global {:.2}, culled {}",
        s.nodes_per_level.iter().sum::<u64>(),
        levels.join(", "),
        match a.shape {
            AdaptiveShape::OneNode => "walked as the global bound",
            AdaptiveShape::AllLeaves if a.shadow_culled => {
                "walked as the per-leaf DDA, shadow rays as the global bound culled by the leaf cells"
            }
            AdaptiveShape::AllLeaves => "walked as the per-leaf DDA",
            AdaptiveShape::Mixed => "walked by the hierarchy",
            AdaptiveShape::Culled => "walked as the global bound, culled by the leaf cells",
        },
        1e3 * s.build_seconds,
        s.memory_bytes as f64 / 1024.0,
        s.cost_adaptive,
        s.cost_leaf,
        s.cost_global,
        if s.cost_culled.is_finite() {
            format!("{:.2}", s.cost_culled)
        } else {
            "- (the global minimum is not 0)".to_string()
        }
    );
}

fn vdb(path: &Path, layout: bool) -> Result<()> {
    let file = VdbFile::open(path)?;
    println!("{}: {} grid(s)", path.display(), file.grids().len());
    for (k, t, v) in file.metadata() {
        println!("file meta {k:<16} {v} ({t})");
    }
    for g in file.grids() {
        let vector = brume_ffi::VEC3_VALUE_TYPES.contains(&g.value_type.as_str());
        println!(
            "grid '{}': {}, {}",
            g.name,
            g.value_type,
            if vector {
                vector_class_name(g.class)
            } else {
                class_name(g.class)
            }
        );
        print_facts(g);
        if !layout {
            continue;
        }
        if vector {
            print_vector_layout(&file, g);
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
                // A bare grid has no density scale: build for Blender's default (Density 1,
                // sigma_t = 1 per unit value per metre).
                let index_per_t = 1.0 / loaded.grid.voxel_size.x.max(1e-30) as f32;
                let a =
                    AdaptiveMajorants::build(&loaded.bounds, 1.0, index_per_t, CostModel::DEFAULT);
                print_adaptive("  adaptive (density 1)", &a, 1.0, index_per_t);
                print_voxel_bounds(" ", &loaded.grid, &loaded.bounds);
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
