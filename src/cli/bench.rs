//! `brume bench`: figures for the speed targets. Benchmarks print; they never assert.
use std::path::PathBuf;
use std::time::Instant;

use anyhow::Result;
use brume::volume::check::SplitMix64;
use brume::volume::{load_grid, ConversionPolicy};
use brume_ffi::{ReadOptions, SampleOrder, VdbFile};
use clap::Subcommand;

#[derive(Subcommand)]
pub enum Which {
    /// Trilinear lookups per second: Brume's brick layout against OpenVDB's accessor +
    /// BoxSampler (through the shim, one batch call), on the same points.
    Lookups {
        /// .vdb files to measure (default: every example grid in scenes/vdb).
        files: Vec<PathBuf>,
        #[arg(long, default_value = "density")]
        grid: String,
        /// Points per run.
        #[arg(long, default_value_t = 2_000_000)]
        points: usize,
        /// Runs per method; the best is reported.
        #[arg(long, default_value_t = 5)]
        runs: usize,
    },
    /// Samples per second of the GPU wavefront integrator against the CPU backend.
    Gpu {
        /// Scene to render.
        #[arg(default_value = "scenes/cloud.gltf")]
        scene: PathBuf,
        #[arg(long, default_value_t = 512)]
        width: u32,
        #[arg(long, default_value_t = 512)]
        height: u32,
        #[arg(long, default_value_t = 4)]
        spp: u32,
    },
}

pub fn run(which: Which) -> Result<()> {
    match which {
        Which::Lookups {
            files,
            grid,
            points,
            runs,
        } => lookups(files, &grid, points, runs),
        Which::Gpu {
            scene,
            width,
            height,
            spp,
        } => super::bench_gpu::run(&scene, width, height, spp),
    }
}

fn best_of(runs: usize, mut f: impl FnMut()) -> f64 {
    (0..runs.max(1))
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

fn lookups(files: Vec<PathBuf>, grid_name: &str, n: usize, runs: usize) -> Result<()> {
    let files = if files.is_empty() {
        ["cloud", "smoke", "fire", "sphere_fog", "tiles"]
            .iter()
            .map(|f| PathBuf::from(format!("scenes/vdb/{f}.vdb")))
            .collect()
    } else {
        files
    };
    println!(
        "{:<28} {:>14} {:>14} {:>8}  {}",
        "grid", "brume M/s", "openvdb M/s", "ratio", "points"
    );
    for path in files {
        let loaded = load_grid(&path, grid_name, ConversionPolicy::default())?;
        let vdb = VdbFile::open(&path)?.open_float_grid(
            grid_name,
            ReadOptions {
                level_set_to_fog: true,
            },
        )?;
        let b = loaded.grid.index_bounds();
        let (lo, hi) = (b.min.as_dvec3(), b.max.as_dvec3());
        // Two access patterns: points along random rays (as tracking reads them) and
        // uniformly random points (cache-hostile).
        for pattern in ["rays", "random"] {
            let mut rng = SplitMix64(7);
            let mut pts = Vec::with_capacity(n);
            while pts.len() < n {
                if pattern == "random" {
                    pts.push([
                        rng.range(lo.x, hi.x),
                        rng.range(lo.y, hi.y),
                        rng.range(lo.z, hi.z),
                    ]);
                } else {
                    let o = [
                        rng.range(lo.x, hi.x),
                        rng.range(lo.y, hi.y),
                        rng.range(lo.z, hi.z),
                    ];
                    let d = rng.unit_vector();
                    for s in 0..64 {
                        let t = s as f64 * 0.37;
                        pts.push([o[0] + t * d.x, o[1] + t * d.y, o[2] + t * d.z]);
                    }
                }
            }
            pts.truncate(n);
            let mut out_b = vec![0f32; n];
            let mut out_v = vec![0f32; n];
            let tb = best_of(runs, || {
                loaded.grid.sample_trilinear_batch(&pts, &mut out_b)
            });
            let tv = best_of(runs, || {
                vdb.sample_into(&pts, SampleOrder::Trilinear, &mut out_v)
                    .expect("OpenVDB sampling")
            });
            let mismatches = out_b
                .iter()
                .zip(&out_v)
                .filter(|(a, b)| (**a - **b).abs() > 1e-6 * b.abs().max(1e-30))
                .count();
            println!(
                "{:<28} {:>14.1} {:>14.1} {:>7.2}x  {} {pattern}{}",
                format!(
                    "{} ({pattern})",
                    path.file_stem().unwrap_or_default().to_string_lossy()
                ),
                n as f64 / tb / 1e6,
                n as f64 / tv / 1e6,
                tv / tb,
                n,
                if mismatches > 0 {
                    format!(" ({mismatches} values differ!)")
                } else {
                    String::new()
                }
            );
        }
    }
    println!("ratio = Brume lookups/s over OpenVDB lookups/s (single thread, best of {runs} runs)");
    Ok(())
}
