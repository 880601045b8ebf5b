//! `brume bench`: figures for the speed targets. Benchmarks print; they never assert.
pub mod accel;
pub mod adaptive;
pub mod blur;
pub mod env;
pub mod gpu;
pub mod majorants;
pub mod passes;
pub mod peers;
pub mod walk;

use std::path::PathBuf;
use std::time::Instant;

use crate::volume::check::SplitMix64;
use crate::volume::{load_grid, ConversionPolicy};
use anyhow::Result;

use super::render_cpu;
use brume_ffi::{ReadOptions, SampleOrder, VdbFile};
use clap::Subcommand;
use majorants::{adaptive_build, majorant_modes, Rounds};

#[derive(Subcommand)]
pub enum Which {
    /// CPU path tracer: specialised vs generic samples/s on every example scene, then every
    /// estimator with global vs local majorants on the cloud (samples/s, lookups per path,
    /// null collisions per real collision).
    Render {
        /// Scenes for the specialisation table (default: every scenes/*.gltf).
        scenes: Vec<PathBuf>,
        #[arg(long, default_value_t = 16)]
        spp: u32,
        #[arg(long, default_value_t = 160)]
        width: u32,
        #[arg(long, default_value_t = 120)]
        height: u32,
        /// Side of the square cloud render for the estimator table.
        #[arg(long, default_value_t = 256)]
        cloud_size: u32,
        #[arg(long, default_value_t = 8)]
        cloud_spp: u32,
        /// Only the environment-map section (HDR sky vs constant sky, sampling ablation).
        #[arg(long)]
        env_only: bool,
        /// Only the majorant-mode table (global, leaf, culled, adaptive side by side) and the
        /// hierarchy's build figures.
        #[arg(long)]
        majorants_only: bool,
        /// Samples per pixel of the environment-map section's timed renders.
        #[arg(long, default_value_t = 32)]
        env_spp: u32,
        /// Rounds of the majorant-mode table (each renders every mode once, in turn): more
        /// rounds give steadier times on a busy machine.
        #[arg(long, default_value_t = 3)]
        runs: usize,
        /// Seed of the majorant-mode table's first round (round `r` renders seed
        /// `first_seed + r`): a rerun with other seeds shows whether its variance column is a
        /// few fireflies' (its `top 0.1%` column says when to suspect it).
        #[arg(long, default_value_t = 0)]
        first_seed: u32,
    },
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
    /// The majorant walks alone on random rays through each example grid: ns per segment
    /// and per ray for the global, per-leaf and adaptive walks, and ns per trilinear lookup.
    Walk {
        /// .vdb files (default: every example grid in scenes/vdb).
        files: Vec<PathBuf>,
        #[arg(long, default_value = "density")]
        grid: String,
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
    /// What motion blur costs: the scene with its shutter against the shutter closed (time per
    /// sample, density lookups per sample and per real collision, majorant violations).
    Blur {
        #[arg(default_value = "scenes/plume_blur.gltf")]
        scene: PathBuf,
        #[arg(long, default_value_t = 240)]
        width: u32,
        #[arg(long, default_value_t = 320)]
        height: u32,
        #[arg(long, default_value_t = 32)]
        spp: u32,
        /// Rounds (each renders both); the best time of each is reported.
        #[arg(long, default_value_t = 3)]
        runs: usize,
    },
    /// What each kind of pass costs: the scene rendered with `--passes light`, `data` and
    /// `lights` against the beauty alone (time per sample).
    Passes {
        #[arg(default_value = "scenes/cornell_smoke.gltf")]
        scene: PathBuf,
        #[arg(long, default_value_t = 160)]
        width: u32,
        #[arg(long, default_value_t = 120)]
        height: u32,
        #[arg(long, default_value_t = 16)]
        spp: u32,
        /// Rounds (each renders both); the best time of each is reported.
        #[arg(long, default_value_t = 3)]
        runs: usize,
    },
    /// What adaptive sampling saves: the time fixed sample counts take to reach the RMSE of an
    /// adaptive render (`--noise-threshold`), against a reference render.
    Adaptive {
        #[arg(default_value = "scenes/cloud.gltf")]
        scene: PathBuf,
        #[arg(long, default_value_t = 96)]
        width: u32,
        #[arg(long, default_value_t = 72)]
        height: u32,
        /// The noise threshold of the adaptive render.
        #[arg(long, default_value_t = 0.02)]
        threshold: f32,
        /// The most samples a pixel takes (the fixed renders double from 16 up to it).
        #[arg(long, default_value_t = 1024)]
        spp: u32,
        /// Samples per pixel of the reference.
        #[arg(long, default_value_t = 8192)]
        reference_spp: u32,
    },
    /// The CPU's closest-hit accelerators, the BVH against Embree: build time, memory and
    /// rays per second (one thread) for camera, incoherent shadow and incoherent bounce rays,
    /// as a markdown table.
    Accel {
        /// Scenes to measure (default: every scenes/*.gltf).
        scenes: Vec<PathBuf>,
        /// Rays of each kind, drawn from a fixed seed.
        #[arg(long, default_value_t = 200_000)]
        rays: usize,
        /// Runs per accelerator and kind; the best is reported.
        #[arg(long, default_value_t = 3)]
        runs: usize,
        /// Triangles of a random triangle soup measured after the scenes (0: none).
        #[arg(long, default_value_t = 100_000)]
        soup: usize,
        /// Instead of the example scenes and `--soup`, soups of 10 to 300k triangles, and the
        /// smallest from which Embree is faster than the BVH for all three kinds of rays
        /// (what `--accel auto` switches on).
        #[arg(long)]
        sweep: bool,
    },
    /// Brume against Mitsuba 3 and Blender Cycles 5 (each skipped with a one-line reason when
    /// not installed): render time, per-pixel variance from two seeds, efficiency
    /// 1 / (time x variance), the ratios, and the image mean against Mitsuba's with its z-score.
    Peers(peers::PeersArgs),
}

pub fn run(which: Which) -> Result<()> {
    match which {
        Which::Render {
            scenes,
            spp,
            width,
            height,
            cloud_size,
            cloud_spp,
            env_only,
            majorants_only,
            env_spp,
            runs,
            first_seed,
        } => {
            let rounds = Rounds {
                runs: runs.max(1),
                first_seed,
            };
            if majorants_only {
                let scenes = if scenes.is_empty() {
                    example_scenes()?
                } else {
                    scenes
                };
                majorant_modes(&scenes, width, height, spp, rounds)?;
                return adaptive_build();
            }
            if !env_only {
                render_bench(scenes, spp, width, height, cloud_size, cloud_spp, rounds)?;
            }
            env::env_map_bench(
                width,
                height,
                env_spp,
                &|sc: &crate::scene::Scene, st: &crate::render::RenderSettings| render_cpu(sc, st),
            )
        }
        Which::Lookups {
            files,
            grid,
            points,
            runs,
        } => lookups(files, &grid, points, runs),
        Which::Walk { files, grid } => walk::run(files, &grid),
        Which::Gpu {
            scene,
            width,
            height,
            spp,
        } => gpu::run(&scene, width, height, spp),
        Which::Blur {
            scene,
            width,
            height,
            spp,
            runs,
        } => blur::run(&scene, width, height, spp, runs),
        Which::Passes {
            scene,
            width,
            height,
            spp,
            runs,
        } => passes::run(&scene, width, height, spp, runs),
        Which::Adaptive {
            scene,
            width,
            height,
            threshold,
            spp,
            reference_spp,
        } => adaptive::run(&scene, (width, height), threshold, spp, reference_spp),
        Which::Accel {
            scenes,
            rays,
            runs,
            soup,
            sweep,
        } => {
            if sweep {
                return accel::sweep(&scenes, rays, runs);
            }
            let scenes = if scenes.is_empty() {
                example_scenes()?
            } else {
                scenes
            };
            accel::run(&scenes, rays, runs, &[soup])
        }
        Which::Peers(args) => peers::run(&args),
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
        "{:<28} {:>14} {:>14} {:>8}  points",
        "grid", "brume M/s", "openvdb M/s", "ratio"
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

/// Largest per-pixel z-score between two renders of the same scene (independent or not).
fn worst_z(a: &crate::film::Film, b: &crate::film::Film) -> f64 {
    let mut worst = 0f64;
    for y in 0..a.height() {
        for x in 0..a.width() {
            let (ma, mb) = (a.mean(x, y), b.mean(x, y));
            let (va, vb) = (a.variance_of_mean(x, y), b.variance_of_mean(x, y));
            for c in 0..3 {
                let d = (ma[c] - mb[c]).abs() as f64;
                let v = (va[c] + vb[c]) as f64;
                if d > 0.0 {
                    worst = worst.max(if v > 0.0 { d / v.sqrt() } else { f64::INFINITY });
                }
            }
        }
    }
    worst
}

/// Every `scenes/*.gltf`, sorted.
fn example_scenes() -> Result<Vec<PathBuf>> {
    let mut v: Vec<PathBuf> = std::fs::read_dir("scenes")?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "gltf"))
        .collect();
    v.sort();
    Ok(v)
}

fn render_bench(
    scenes: Vec<PathBuf>,
    spp: u32,
    width: u32,
    height: u32,
    cloud_size: u32,
    cloud_spp: u32,
    rounds: Rounds,
) -> Result<()> {
    use crate::render::{Estimator, MajorantMode, RenderSettings};
    let scenes = if scenes.is_empty() {
        example_scenes()?
    } else {
        scenes
    };
    println!(
        "specialised vs generic CPU path ({width}x{height}, {spp} spp, {} threads)",
        rayon::current_num_threads()
    );
    println!(
        "{:<22} {:<44} {:>12} {:>12} {:>8}  images",
        "scene", "features", "spec. S/s", "generic S/s", "speedup"
    );
    for path in &scenes {
        let scene = crate::scene::load(path)?;
        let base = RenderSettings {
            width,
            height,
            spp,
            ..RenderSettings::default()
        };
        // Warm caches and the thread pool once, then time each variant.
        render_cpu(
            &scene,
            &RenderSettings {
                spp: 1,
                ..base.clone()
            },
        )?;
        let special = render_cpu(&scene, &base)?;
        let generic = render_cpu(
            &scene,
            &RenderSettings {
                generic: true,
                ..base.clone()
            },
        )?;
        let samples = (width * height * spp) as f64;
        let z = worst_z(&special.film, &generic.film);
        println!(
            "{:<22} {:<44} {:>12.0} {:>12.0} {:>7.2}x  {}",
            path.file_name().unwrap_or_default().to_string_lossy(),
            special.features.name(),
            samples / special.seconds,
            samples / generic.seconds,
            generic.seconds / special.seconds,
            if z == 0.0 {
                "identical".to_string()
            } else {
                format!("worst pixel z {z:.2}")
            }
        );
    }
    let cloud = crate::scene::load(std::path::Path::new("scenes/cloud.gltf"))?;
    println!();
    println!("estimators on scenes/cloud.gltf ({cloud_size}x{cloud_size}, {cloud_spp} spp)");
    println!(
        "{:<24} {:<8} {:>12} {:>14} {:>14}",
        "estimator", "bounds", "samples/s", "lookups/path", "null/real"
    );
    let mut delta_lookups = [0f64; MajorantMode::ALL.len()];
    for estimator in Estimator::ALL {
        for (k, majorant) in MajorantMode::ALL.into_iter().enumerate() {
            let s = RenderSettings {
                width: cloud_size,
                height: cloud_size,
                spp: cloud_spp,
                estimator,
                majorant,
                ..RenderSettings::default()
            };
            let out = render_cpu(&cloud, &s)?;
            let t = crate::film::totals(&out.records);
            let samples = t.counters.samples as f64;
            let lookups = t.counters.density_lookups as f64 / samples;
            if estimator == Estimator::Delta {
                delta_lookups[k] = lookups;
            }
            println!(
                "{:<24} {:<8} {:>12.0} {:>14.2} {:>14.2}",
                estimator.name(),
                majorant.name(),
                samples / out.seconds,
                lookups,
                t.counters.null_collisions as f64 / (t.counters.real_collisions as f64).max(1.0),
            );
        }
    }
    println!(
        "per-leaf majorants cut delta tracking's density lookups per path by {:.2}x on the cloud (culled: {:.2}x, adaptive: {:.2}x)",
        delta_lookups[0] / delta_lookups[1].max(1e-12),
        delta_lookups[0] / delta_lookups[2].max(1e-12),
        delta_lookups[0] / delta_lookups[3].max(1e-12)
    );
    majorant_modes(&scenes, width, height, spp, rounds)?;
    adaptive_build()?;
    Ok(())
}
