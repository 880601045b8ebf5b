//! `brume cycles`: render a Brume scene with Blender Cycles (bpy, Blender as a Python module)
//! for comparison, and optionally compare the result with a Brume render.
//!
//! The scene translation lives in `tools/cycles/brume_to_cycles.py`; this command finds a
//! Python that can `import bpy`, runs the script for `--runs` independent seeds, and merges
//! them into one EXR laid out like Brume's (beauty, `variance.R/G/B` = variance of the pixel
//! mean estimated across the runs, `samples.Y`). With `--against brume.exr` it prints the image
//! mean relative difference and an 8x8 block z-test (docs/CYCLES.md).
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::{anyhow, bail, Context, Result};
use clap::Args;

use brume::film::{read_exr, write_image, AttrValue, Image, Metadata};
use brume::study::stats::erfc;

/// One line that says how to get a Python with bpy.
const INSTALL_HINT: &str = "no Python with bpy found: run tools/cycles/ci.sh (Python 3.11 venv \
     tools/cycles/.venv with `pip install bpy==5.0.1`), or set BRUME_BPY_PYTHON to a python that \
     can `import bpy`";

#[derive(Args, Debug)]
pub struct CyclesArgs {
    /// The Brume scene (.gltf).
    pub scene: PathBuf,
    /// Output EXR (beauty RGBA; `variance.*` when --runs > 1; `samples.Y`).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Samples per pixel of each run.
    #[arg(long, default_value_t = 64)]
    pub spp: u32,
    #[arg(long, default_value_t = 320)]
    pub width: u32,
    #[arg(long, default_value_t = 240)]
    pub height: u32,
    /// Independent Cycles renders (seeds seed..seed+runs-1), averaged; their spread gives the
    /// variance layer, so use at least 4 for a block z-test.
    #[arg(long, default_value_t = 1)]
    pub runs: u32,
    #[arg(long, default_value_t = 0)]
    pub seed: u32,
    /// Cycles threads (default: all cores).
    #[arg(long)]
    pub threads: Option<u32>,
    #[arg(long, default_value_t = 256)]
    pub max_depth: u32,
    /// Compare with this Brume EXR (needs its variance layer) and print the agreement.
    #[arg(long)]
    pub against: Option<PathBuf>,
    /// Also save the Blender scene built from the glTF (.blend), for inspection.
    #[arg(long)]
    pub save_blend: Option<PathBuf>,
    /// Do not render: compare the existing --output with --against.
    #[arg(long, requires = "against")]
    pub reuse: bool,
}

/// A Python that imports bpy: `BRUME_BPY_PYTHON`, then `tools/cycles/.venv` (next to the
/// working directory or the source tree), then `python3` on the PATH.
pub fn find_bpy_python() -> Result<PathBuf> {
    if let Some(p) = std::env::var_os("BRUME_BPY_PYTHON") {
        let p = PathBuf::from(p);
        if imports_bpy(&p) {
            return Ok(p);
        }
        bail!("BRUME_BPY_PYTHON={} cannot `import bpy`", p.display());
    }
    let venv = Path::new("tools/cycles/.venv/bin/python");
    let candidates = [
        venv.to_path_buf(),
        Path::new(env!("CARGO_MANIFEST_DIR")).join(venv),
        PathBuf::from("python3"),
    ];
    candidates
        .into_iter()
        .find(|p| imports_bpy(p))
        .ok_or_else(|| anyhow!(INSTALL_HINT))
}

fn imports_bpy(python: &Path) -> bool {
    Command::new(python)
        .args(["-c", "import bpy"])
        .output()
        .is_ok_and(|o| o.status.success())
}

/// The translation script: `BRUME_CYCLES_SCRIPT`, else `tools/cycles/brume_to_cycles.py` in
/// the working directory or the source tree.
fn script_path() -> Result<PathBuf> {
    if let Some(p) = std::env::var_os("BRUME_CYCLES_SCRIPT") {
        return Ok(PathBuf::from(p));
    }
    let rel = Path::new("tools/cycles/brume_to_cycles.py");
    [
        rel.to_path_buf(),
        Path::new(env!("CARGO_MANIFEST_DIR")).join(rel),
    ]
    .into_iter()
    .find(|p| p.is_file())
    .ok_or_else(|| anyhow!("{} not found", rel.display()))
}

pub fn run(args: &CyclesArgs) -> Result<()> {
    if args.runs == 0 || args.spp == 0 {
        bail!("--runs and --spp must be at least 1");
    }
    if args.reuse {
        let a = compare(
            &read_exr(args.against.as_ref().unwrap())?,
            &read_exr(&args.output)?,
            8,
            0.001,
        )?;
        println!("{a}");
        return Ok(());
    }
    let python = find_bpy_python()?;
    let script = script_path()?;
    let tmp = std::env::temp_dir().join(format!("brume-cycles-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).with_context(|| format!("creating {}", tmp.display()))?;
    let stem = tmp.join("cycles.exr");
    let mut cmd = Command::new(&python);
    cmd.arg(&script)
        .arg(&args.scene)
        .arg("-o")
        .arg(&stem)
        .args(["--spp", &args.spp.to_string()])
        .args(["--width", &args.width.to_string()])
        .args(["--height", &args.height.to_string()])
        .args(["--seed", &args.seed.to_string()])
        .args(["--runs", &args.runs.to_string()])
        .args(["--max-depth", &args.max_depth.to_string()]);
    if let Some(t) = args.threads {
        cmd.args(["--threads", &t.to_string()]);
    }
    if let Some(b) = &args.save_blend {
        cmd.arg("--save-blend").arg(b);
    }
    let started = Instant::now();
    let out = cmd
        .output()
        .with_context(|| format!("running {}", python.display()))?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    if !out.status.success() {
        let stderr = String::from_utf8_lossy(&out.stderr);
        let tail: Vec<&str> = stdout.lines().chain(stderr.lines()).collect();
        bail!(
            "Cycles failed ({}):\n{}",
            out.status,
            tail[tail.len().saturating_sub(20)..].join("\n")
        );
    }
    let mut render_seconds = Vec::new();
    let mut files = Vec::new();
    for line in stdout.lines() {
        let f: Vec<&str> = line.split_whitespace().collect();
        if f.len() == 4 && f[0] == "render_seconds" {
            render_seconds.push(f[2].parse::<f64>().unwrap_or(f64::NAN));
            files.push(PathBuf::from(f[3]));
        }
    }
    if files.len() != args.runs as usize {
        bail!(
            "expected {} Cycles images, the script reported {}",
            args.runs,
            files.len()
        );
    }
    let images = files
        .iter()
        .map(read_exr)
        .collect::<Result<Vec<_>, _>>()
        .context("reading Cycles output")?;
    let total: f64 = render_seconds.iter().sum();
    let mut meta = Metadata::new();
    meta.set("brume:renderer", AttrValue::Text("cycles (bpy 5.0)".into()))
        .set("brume:spp", AttrValue::Int((args.spp * args.runs) as i32))
        .set("brume:cycles_runs", AttrValue::Int(args.runs as i32))
        .set("brume:render_seconds", AttrValue::Double(total));
    // Cycles' own timings, summed over the runs (each run's EXR has them as stamp metadata).
    if let Some(t) = images
        .iter()
        .map(|i| CyclesTimes::from_metadata(&i.attributes))
        .collect::<Option<Vec<_>>>()
    {
        let sum = |f: fn(&CyclesTimes) -> f64| t.iter().map(f).sum::<f64>();
        meta.set("brume:seconds", AttrValue::Double(sum(|t| t.total)))
            .set(
                "brume:cycles_setup_seconds",
                AttrValue::Double(sum(|t| t.total - t.render)),
            )
            .set(
                "brume:cycles_path_tracing_seconds",
                AttrValue::Double(sum(|t| t.render)),
            )
            .set(
                "brume:cycles_sync_seconds",
                AttrValue::Double(sum(|t| t.sync)),
            );
    }
    meta.set(
        "brume:scene",
        AttrValue::Text(args.scene.display().to_string()),
    );
    let merged = merge_runs(&images, args.spp, meta)?;
    write_image(&args.output, &merged)?;
    let _ = std::fs::remove_dir_all(&tmp);
    eprintln!(
        "cycles: {} run(s) x {} spp, {}x{}, render {:.2} s (per run {}), wall {:.2} s",
        args.runs,
        args.spp,
        args.width,
        args.height,
        total,
        render_seconds
            .iter()
            .map(|s| format!("{s:.2}"))
            .collect::<Vec<_>>()
            .join(" "),
        started.elapsed().as_secs_f64()
    );
    if let Some(brume_path) = &args.against {
        let brume = read_exr(brume_path)?;
        let a = compare(&brume, &merged, 8, 0.001)?;
        println!("{a}");
    }
    Ok(())
}

/// The timings Cycles writes into each render's EXR (`cycles.<view layer>.total_time`,
/// `render_time`, `synchronization_time`, as `[HH:]MM:SS.cc`), in seconds. `total` runs from
/// the start of the render session: scene and device update (BVH, volume octree, images) and
/// then path tracing (`render`); `sync` is Blender's conversion of its data to Cycles, timed
/// separately.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CyclesTimes {
    pub total: f64,
    pub render: f64,
    pub sync: f64,
}

impl CyclesTimes {
    pub fn from_metadata(meta: &Metadata) -> Option<Self> {
        let field = |name: &str| {
            meta.iter()
                .find(|(k, _)| k.starts_with("cycles.") && k.ends_with(name))
                .and_then(|(_, v)| match v {
                    AttrValue::Text(t) => parse_cycles_time(t),
                    _ => None,
                })
        };
        Some(CyclesTimes {
            total: field(".total_time")?,
            render: field(".render_time")?,
            sync: field(".synchronization_time").unwrap_or(0.0),
        })
    }
}

/// Blender's `[[HH:]MM:]SS.ff` time stamps in seconds.
pub fn parse_cycles_time(t: &str) -> Option<f64> {
    t.trim().split(':').try_fold(0.0, |acc, part| {
        Some(acc * 60.0 + part.parse::<f64>().ok()?)
    })
}

/// Averages independent runs; with two or more, the variance of the mean is the unbiased
/// sample variance across runs divided by their number.
pub fn merge_runs(images: &[Image], spp: u32, attributes: Metadata) -> Result<Image> {
    let first = images.first().ok_or_else(|| anyhow!("no images"))?;
    let (w, h) = (first.width, first.height);
    if images.iter().any(|i| i.width != w || i.height != h) {
        bail!("Cycles runs differ in size");
    }
    let k = images.len() as f64;
    let n = w * h;
    let mut rgb = vec![[0f32; 3]; n];
    let mut var = vec![[0f32; 3]; n];
    for p in 0..n {
        for c in 0..3 {
            let mean = images.iter().map(|i| i.rgb[p][c] as f64).sum::<f64>() / k;
            let ss: f64 = images
                .iter()
                .map(|i| (i.rgb[p][c] as f64 - mean).powi(2))
                .sum();
            rgb[p][c] = mean as f32;
            var[p][c] = if k > 1.0 {
                (ss / (k - 1.0) / k) as f32
            } else {
                0.0
            };
        }
    }
    Ok(Image {
        width: w,
        height: h,
        rgb,
        alpha: Some(vec![1.0; n]),
        variance: (k > 1.0).then_some(var),
        samples: Some(vec![spp as f32 * k as f32; n]),
        attributes,
    })
}

/// Agreement of two renders of the same scene.
#[derive(Debug, Clone)]
pub struct Agreement {
    /// (mean(b) - mean(a)) / mean(a) over all pixels, per channel and for R+G+B.
    pub mean_rel_diff: [f64; 4],
    /// z-score of the R+G+B image-mean difference.
    pub mean_z: f64,
    pub blocks: usize,
    pub failed_blocks: usize,
    /// Largest |z| of any block and channel.
    pub max_block_z: f64,
}

impl std::fmt::Display for Agreement {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let m = self.mean_rel_diff;
        write!(
            f,
            "mean_rel_diff {:+.4} (R {:+.4} G {:+.4} B {:+.4}) mean_z {:+.2} \
             blocks_failed {}/{} ({:.2} %) max_block_z {:.2}",
            m[3],
            m[0],
            m[1],
            m[2],
            self.mean_z,
            self.failed_blocks,
            self.blocks,
            100.0 * self.failed_blocks as f64 / self.blocks.max(1) as f64,
            self.max_block_z
        )
    }
}

/// Image mean relative difference of `b` against `a`, and a z-test per `block`x`block` block
/// and channel with both variance layers; a block fails when any channel rejects at the
/// Sidak-corrected level for three channels, so the block test is at `alpha`.
pub fn compare(a: &Image, b: &Image, block: usize, alpha: f64) -> Result<Agreement> {
    if a.width != b.width || a.height != b.height {
        bail!(
            "sizes differ: {}x{} vs {}x{}",
            a.width,
            a.height,
            b.width,
            b.height
        );
    }
    let (va, vb) = match (&a.variance, &b.variance) {
        (Some(x), Some(y)) => (x, y),
        _ => bail!("both images need a variance layer (Cycles: --runs >= 2)"),
    };
    let n = a.width * a.height;
    let mut sum = [[0f64; 4]; 2];
    let mut var_sum = 0f64;
    for p in 0..n {
        for c in 0..3 {
            sum[0][c] += a.rgb[p][c] as f64;
            sum[1][c] += b.rgb[p][c] as f64;
            var_sum += va[p][c] as f64 + vb[p][c] as f64;
        }
    }
    for s in &mut sum {
        s[3] = s[0] + s[1] + s[2];
    }
    let mean_rel_diff = std::array::from_fn(|c| (sum[1][c] - sum[0][c]) / sum[0][c]);
    let mean_z = (sum[1][3] - sum[0][3]) / var_sum.sqrt();

    let alpha_channel = 1.0 - (1.0 - alpha).powf(1.0 / 3.0);
    let z_crit = normal_quantile(1.0 - alpha_channel / 2.0);
    let (bw, bh) = (a.width / block, a.height / block);
    let (mut failed, mut max_z) = (0, 0f64);
    for by in 0..bh {
        for bx in 0..bw {
            let mut d = [0f64; 3];
            let mut v = [0f64; 3];
            let mut sum_a = [0f64; 3];
            for y in by * block..(by + 1) * block {
                for x in bx * block..(bx + 1) * block {
                    let p = y * a.width + x;
                    for c in 0..3 {
                        d[c] += b.rgb[p][c] as f64 - a.rgb[p][c] as f64;
                        sum_a[c] += a.rgb[p][c] as f64;
                        v[c] += va[p][c] as f64 + vb[p][c] as f64;
                    }
                }
            }
            let mut fail = false;
            for c in 0..3 {
                // Float rounding (a constant background, 0.3 vs 0.30000001 across runs)
                // must not count: a variance floor at 1e-6 of the block's value.
                let scale = sum_a[c].abs() + (sum_a[c] + d[c]).abs();
                let v_eff = v[c] + (1e-6 * scale).powi(2);
                let z = if v_eff > 0.0 {
                    d[c] / v_eff.sqrt()
                } else if d[c] == 0.0 {
                    0.0
                } else {
                    f64::INFINITY
                };
                max_z = max_z.max(z.abs());
                fail |= z.abs() > z_crit;
            }
            failed += fail as usize;
        }
    }
    Ok(Agreement {
        mean_rel_diff,
        mean_z,
        blocks: bw * bh,
        failed_blocks: failed,
        max_block_z: max_z,
    })
}

/// Standard normal quantile by bisection on the CDF (erfc by Numerical Recipes' Chebyshev
/// fit, relative error < 1.2e-7).
fn normal_quantile(p: f64) -> f64 {
    let cdf = |z: f64| 0.5 * erfc(-z / std::f64::consts::SQRT_2);
    let (mut lo, mut hi) = (-40.0, 40.0);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if cdf(mid) < p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cycles_time_stamps_parse() {
        assert_eq!(parse_cycles_time("00:01.25"), Some(1.25));
        assert_eq!(parse_cycles_time("01:02:03.50"), Some(3723.5));
        assert_eq!(parse_cycles_time("x"), None);
        let m = Metadata::new()
            .with(
                "cycles.ViewLayer.total_time",
                AttrValue::Text("00:03.00".into()),
            )
            .with(
                "cycles.ViewLayer.render_time",
                AttrValue::Text("00:02.25".into()),
            );
        assert_eq!(
            CyclesTimes::from_metadata(&m),
            Some(CyclesTimes {
                total: 3.0,
                render: 2.25,
                sync: 0.0
            })
        );
    }

    #[test]
    fn normal_quantile_matches_tables() {
        assert!((erfc(0.5) - 0.4795001).abs() < 1e-6);
        assert!((erfc(-1.0) - 1.8427008).abs() < 1e-6);
        assert!((normal_quantile(0.975) - 1.959964).abs() < 1e-4);
        assert!((normal_quantile(0.9995) - 3.290527).abs() < 1e-4);
    }
}
