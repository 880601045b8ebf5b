//! `brume study scene.gltf`: error against time for a sweep of estimator configurations.
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{anyhow, Context, Result};
use clap::Args;

use brume::film::{read_exr, write_image, Image};
use brume::render::{RenderScene, RenderSettings};
use brume::scene;
use brume::study::plot::{self, Bar, Curve};
use brume::study::report::{self, markdown, sig, summarize};
use brume::study::run::{
    default_sweep, reference_cache_path, reference_noise_rmse, render_reference, run_config,
    seed_for, Checkpoint, StudyConfig,
};

#[derive(Args, Debug, Clone)]
pub struct StudyArgs {
    /// The scene (.gltf or .glb).
    pub scene: PathBuf,
    /// Output folder (created): checkpoints.csv, summary.md, summary.json, plots, the cached
    /// reference.
    #[arg(long, default_value = "study")]
    pub out: PathBuf,
    /// Wall-clock budget per render, seconds.
    #[arg(long, default_value_t = 10.0)]
    pub budget: f64,
    /// Renders per configuration, each with its own seed.
    #[arg(long, default_value_t = 1)]
    pub repeats: u32,
    /// Reference EXR (same size as the study). Default: an analog delta tracking render with
    /// per-leaf majorants, cached in --out.
    #[arg(long, conflicts_with = "reference_spp")]
    pub reference: Option<PathBuf>,
    /// Samples per pixel of the rendered reference.
    #[arg(long)]
    pub reference_spp: Option<u32>,
    /// Image width (default 128, or the reference's).
    #[arg(long)]
    pub width: Option<u32>,
    /// Image height (default 96, or the reference's).
    #[arg(long)]
    pub height: Option<u32>,
    /// A configuration, ESTIMATOR[:b=B][:m=M][:global|local][:noise=E[:min-spp=N]]
    /// (repeatable); noise=E samples adaptively as `brume render --noise-threshold E
    /// --min-spp N` (N default 16), and beside the same configuration without it the report
    /// gives the ratio of their times to the target RMSE. Default: the seed paper's sweep
    /// (weighted delta b = 0.25..1, weighted decomposition m = 0.01..0.05, delta; global and
    /// per-leaf majorants).
    #[arg(long = "config")]
    pub configs: Vec<String>,
    /// Target RMSE of the time-to-target column (default: twice the lowest mean RMSE at the
    /// budget, or the highest RMSE an adaptive render ended at where that is higher).
    #[arg(long)]
    pub target_rmse: Option<f64>,
    /// First seed; render i of repeat r uses seed + 1000 r + i.
    #[arg(long, default_value_t = 1)]
    pub seed: u32,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Render nothing: rebuild the summaries and plots from --out's checkpoints.csv (e.g. with
    /// another --target-rmse). --budget and --repeats should match the run that wrote it.
    #[arg(long)]
    pub replot: bool,
}

/// Default reference samples per pixel: at 128x96 on the cloud about a minute on two cores,
/// giving a reference noise RMSE several times below the 10 s renders' error.
pub const DEFAULT_REFERENCE_SPP: u32 = 4096;

pub fn run(args: &StudyArgs) -> Result<()> {
    let configs = checked_configs(args)?;
    if args.replot {
        return replot(args);
    }
    let given_ref = match &args.reference {
        Some(p) => Some(read_exr(p).with_context(|| "reading the reference")?),
        None => None,
    };
    let (width, height) = study_size(args, given_ref.as_ref())?;
    let scene = scene::load(&args.scene)?;
    scene
        .validate()
        .map_err(|e| anyhow!("{}: {e}", args.scene.display()))?;
    let base = RenderSettings {
        width,
        height,
        ..RenderSettings::default()
    };
    base.validate()
        .map_err(|e| anyhow!("invalid settings: {e}"))?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let rs = RenderScene::new(&scene, false).map_err(|e| anyhow!(e))?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.unwrap_or(0))
        .build()?;
    let threads = pool.current_num_threads();

    let (reference, reference_desc) = match given_ref {
        Some(r) => (
            r,
            format!("`{}`", args.reference.as_ref().unwrap().display()),
        ),
        None => {
            let spp = args.reference_spp.unwrap_or(DEFAULT_REFERENCE_SPP);
            let path = reference_cache_path(&args.out, &args.scene, width, height, spp)
                .with_context(|| format!("reading {}", args.scene.display()))?;
            let desc = format!("analog delta tracking, per-leaf majorants, {spp} spp");
            (
                load_or_render_reference(&pool, &rs, &base, spp, &path)?,
                desc,
            )
        }
    };
    let points = run_sweep(args, &configs, &pool, &rs, &base, &reference)?;
    write_reports(
        args,
        &points,
        &configs,
        width,
        height,
        &reference_desc,
        reference_noise_rmse(&reference),
        threads,
    )
}

/// The configurations to sweep (`--config`, else the default sweep), after checking the
/// budget, the repeat count and that no configuration is given twice.
fn checked_configs(args: &StudyArgs) -> Result<Vec<StudyConfig>> {
    if !(args.budget > 0.0 && args.budget.is_finite()) {
        return Err(anyhow!(
            "--budget {} must be a positive number of seconds",
            args.budget
        ));
    }
    if args.repeats == 0 {
        return Err(anyhow!("--repeats must be at least 1"));
    }
    let configs: Vec<StudyConfig> = if args.configs.is_empty() {
        default_sweep()
    } else {
        args.configs
            .iter()
            .map(|s| StudyConfig::parse(s))
            .collect::<Result<_, _>>()
            .map_err(|e| anyhow!(e))?
    };
    for (i, c) in configs.iter().enumerate() {
        if configs[..i].iter().any(|d| d.label == c.label) {
            return Err(anyhow!("configuration {:?} is given twice", c.label));
        }
    }
    Ok(configs)
}

/// The study's image size: --width and --height, defaulting to a given reference's size
/// (which they must then match), else 128x96.
fn study_size(args: &StudyArgs, given_ref: Option<&Image>) -> Result<(u32, u32)> {
    Ok(match (given_ref, args.width, args.height) {
        (Some(r), w, h) => {
            let size = (w.unwrap_or(r.width as u32), h.unwrap_or(r.height as u32));
            if size != (r.width as u32, r.height as u32) {
                return Err(anyhow!(
                    "the reference {} is {}x{}, the study asks for {}x{}",
                    args.reference.as_ref().unwrap().display(),
                    r.width,
                    r.height,
                    size.0,
                    size.1
                ));
            }
            size
        }
        (None, w, h) => (w.unwrap_or(128), h.unwrap_or(96)),
    })
}

/// Renders every configuration `args.repeats` times for the budget and returns all their
/// checkpoints, rewriting `checkpoints.csv` in `--out` after each render.
fn run_sweep(
    args: &StudyArgs,
    configs: &[StudyConfig],
    pool: &rayon::ThreadPool,
    rs: &RenderScene,
    base: &RenderSettings,
    reference: &Image,
) -> Result<Vec<Checkpoint>> {
    let (width, height) = (base.width, base.height);
    let threads = pool.current_num_threads();
    let total = configs.len() * args.repeats as usize;
    eprintln!(
        "study: {} configurations x {} repeat(s) x {} s at {width}x{height} on {threads} thread(s): about {:.0} s",
        configs.len(),
        args.repeats,
        args.budget,
        total as f64 * args.budget
    );
    let csv = args.out.join("checkpoints.csv");
    let mut points: Vec<Checkpoint> = Vec::new();
    // Repeats outside configurations: a slow spell on a shared machine then spreads over all
    // configurations instead of hitting one.
    for repeat in 0..args.repeats {
        for (i, cfg) in configs.iter().enumerate() {
            let seed = seed_for(args.seed, i, repeat);
            let p =
                pool.install(|| run_config(rs, base, cfg, args.budget, repeat, seed, reference));
            if let Some(last) = p.last() {
                let spp = if cfg.adaptive_sampling.is_some() {
                    format!("{:.1} spp a pixel (at most {})", last.mean_spp, last.spp)
                } else {
                    format!("{} spp", last.spp)
                };
                eprintln!(
                    "  [{}/{}] {} (repeat {repeat}, seed {seed}): {spp} in {:.2} s, RMSE {}",
                    repeat as usize * configs.len() + i + 1,
                    total,
                    cfg.label,
                    last.seconds,
                    sig(last.rmse)
                );
            }
            points.extend(p);
            // Saved after every render, so an interrupted study keeps what it measured.
            report::write_csv(&csv, &points)?;
        }
    }
    Ok(points)
}

/// Summaries and plots from the checkpoints of an earlier run (`--replot`).
fn replot(args: &StudyArgs) -> Result<()> {
    let csv = args.out.join("checkpoints.csv");
    let points = report::read_csv(&csv).map_err(|e| anyhow!(e))?;
    let mut configs: Vec<StudyConfig> = Vec::new();
    for p in &points {
        if !configs.iter().any(|c| c.label == p.config) {
            configs.push(StudyConfig::from_label(&p.config).map_err(|e| anyhow!(e))?);
        }
    }
    let repeats = points.iter().map(|p| p.repeat + 1).max().unwrap_or(0);
    if repeats != args.repeats {
        eprintln!("note: {} has {repeats} repeat(s)", csv.display());
    }
    // The reference and resolution are not in the CSV: keep what the summary says.
    let old: serde_json::Value = std::fs::read_to_string(args.out.join("summary.json"))
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok())
        .unwrap_or_default();
    let width = old["width"].as_u64().unwrap_or(0) as u32;
    let height = old["height"].as_u64().unwrap_or(0) as u32;
    let reference = old["reference"].as_str().unwrap_or("unknown").to_string();
    let threads = old["threads"].as_u64().unwrap_or(0) as usize;
    let args = StudyArgs {
        repeats,
        ..args.clone()
    };
    write_reports(
        &args,
        &points,
        &configs,
        width,
        height,
        &reference,
        old["reference_noise_rmse"].as_f64(),
        threads,
    )
}

#[allow(clippy::too_many_arguments)]
fn write_reports(
    args: &StudyArgs,
    points: &[Checkpoint],
    configs: &[StudyConfig],
    width: u32,
    height: u32,
    reference_desc: &str,
    reference_noise: Option<f64>,
    threads: usize,
) -> Result<()> {
    let csv = args.out.join("checkpoints.csv");
    let summary = summarize(
        points,
        configs,
        args.target_rmse,
        &args.scene.display().to_string(),
        width,
        height,
        args.budget,
        args.repeats,
        reference_desc,
        reference_noise,
        threads,
    );
    let mut md = format!("# Study: {}\n\n", args.scene.display());
    md += &markdown(&summary);
    md += "\n![RMSE against time](rmse_vs_time.svg)\n\n![Efficiency](efficiency.svg)\n";
    report::write_text(&args.out.join("summary.md"), &md)?;
    report::write_json(&args.out.join("summary.json"), &summary)?;

    let files = write_plots(&args.out, &summary, points)?;
    if plot::text_available().is_none() {
        eprintln!("note: no TrueType font found (set BRUME_FONT=file.ttf): plots have no text");
    }
    println!("{}", markdown(&summary));
    println!(
        "wrote {}, {}, {} and {}",
        csv.display(),
        args.out.join("summary.md").display(),
        args.out.join("summary.json").display(),
        files
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(())
}

fn load_or_render_reference(
    pool: &rayon::ThreadPool,
    rs: &RenderScene,
    base: &RenderSettings,
    spp: u32,
    path: &Path,
) -> Result<Image> {
    if path.is_file() {
        eprintln!("reference: cached {}", path.display());
        return Ok(read_exr(path)?);
    }
    eprintln!("reference: rendering {spp} spp (analog delta, per-leaf majorants) ...");
    let t = Instant::now();
    let (img, secs) = pool.install(|| render_reference(rs, base, spp));
    write_image(path, &img)?;
    eprintln!(
        "reference: {} in {:.1} s (wall {:.1} s)",
        path.display(),
        secs,
        t.elapsed().as_secs_f64()
    );
    Ok(img)
}

/// Colour index per configuration: configurations that differ only in majorant mode share a
/// colour ([`StudyConfig::family`]).
fn colours(configs: &[StudyConfig]) -> Vec<usize> {
    let mut keys: Vec<String> = Vec::new();
    configs
        .iter()
        .map(|c| {
            let key = c.family();
            match keys.iter().position(|k| *k == key) {
                Some(i) => i,
                None => {
                    keys.push(key);
                    keys.len() - 1
                }
            }
        })
        .collect()
}

fn write_plots(
    out: &Path,
    summary: &report::StudySummary,
    points: &[Checkpoint],
) -> Result<Vec<PathBuf>> {
    let configs: Vec<StudyConfig> = summary.configs.iter().map(|c| c.config.clone()).collect();
    let col = colours(&configs);
    let curves: Vec<Curve> = summary
        .configs
        .iter()
        .zip(&col)
        .map(|(c, &colour)| {
            // Mean over repeats, pass by pass (passes have the same spp in every repeat).
            let mut acc: Vec<(f64, f64, usize)> = Vec::new();
            let mut pass = 0;
            let mut last_repeat = None;
            for p in points.iter().filter(|p| p.config == c.config.label) {
                if last_repeat != Some(p.repeat) {
                    last_repeat = Some(p.repeat);
                    pass = 0;
                }
                if acc.len() <= pass {
                    acc.push((0.0, 0.0, 0));
                }
                acc[pass].0 += p.seconds;
                acc[pass].1 += p.rmse;
                acc[pass].2 += 1;
                pass += 1;
            }
            Curve {
                label: c.config.label.clone(),
                // Only passes every repeat reached, so the mean is over the same renders.
                points: acc
                    .iter()
                    .filter(|a| a.2 == c.repeats)
                    .map(|a| (a.0 / a.2 as f64, a.1 / a.2 as f64))
                    .collect(),
                colour,
                dashed: c.config.majorant.is_local(),
            }
        })
        .collect();
    let title = format!(
        "RMSE vs time: {} ({}x{}, {} s, {} repeat(s))",
        Path::new(&summary.scene)
            .file_name()
            .map_or(summary.scene.clone(), |f| f.to_string_lossy().into_owned()),
        summary.width,
        summary.height,
        summary.budget_seconds,
        summary.repeats
    );
    let mut files =
        plot::rmse_vs_time(&out.join("rmse_vs_time"), &title, &curves).map_err(|e| anyhow!(e))?;
    let bars: Vec<Bar> = summary
        .configs
        .iter()
        .zip(&col)
        .map(|(c, &colour)| Bar {
            label: c.config.label.clone(),
            value: c.efficiency,
            colour,
        })
        .collect();
    files.extend(
        plot::efficiency_bars(&out.join("efficiency"), "Efficiency 1/(time x MSE)", &bars)
            .map_err(|e| anyhow!(e))?,
    );
    Ok(files)
}
