//! `brume bench peers`: Brume against Mitsuba 3 and Blender Cycles 5 on the same scenes, same
//! resolution, samples per pixel, threads and seeds, in one table.
//!
//! Each renderer renders every scene once per seed. From those images:
//! - seconds: the render time each renderer reports (Brume: the render loop, scene loading and
//!   preparation excluded; Mitsuba: what `brume mitsuba` writes to its EXR; Cycles: its own
//!   `total_time`, which includes the per-render set-up, shown separately as `set-up s`);
//! - per-pixel variance: [`stats::seed_variance`], `mean((A - B)^2) / 2` for two seeds, and
//!   the share of it in the worst 0.1 % of pixel values (`top 0.1 %`): near 1, a few fireflies
//!   set it and every efficiency from it ([`stats::SeedVariance::top_share`]);
//! - efficiency `1 / (seconds x per-pixel variance)`;
//! - Brume / peer efficiency and the per-sample variance ratio (variance x spp, Brume / peer);
//! - the image mean and its difference from Mitsuba's with a z-score
//!   ([`stats::image_mean`] estimates each mean's variance from the seeds).
//!
//! A peer that is not installed (or whose `brume` subcommand does not exist in this build) is
//! skipped with a one-line reason.
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{anyhow, bail, Context, Result};
use clap::Args;

use crate::film::{read_exr, write_image, AttrValue, Image, Metadata};
use crate::scene::lights::LIGHT_DIRECTIONAL;
use crate::study::stats::{self, ImageMean};

const RENDERERS: [&str; 15] = [
    "brume",
    "brume-baseline",
    "brume-event",
    "brume-no-rr-guard",
    "brume-leaf",
    "brume-global",
    "brume-independent",
    "brume-spectral",
    "brume-decomposition",
    "brume-uniform-lights",
    "brume-sky-every-event",
    "brume-distance",
    "brume-collisions",
    "mitsuba",
    "cycles",
];

/// Brume's variants for ablations: each changes one default (`brume-baseline` changes five
/// at once: absorption events, per-leaf majorants, independent samples, no early roulette,
/// uniform light selection).
fn brume_variant(name: &str, s: &mut crate::render::RenderSettings) -> bool {
    use crate::render::{Absorption, MajorantMode, SamplerKind};
    match name {
        "brume" => {}
        "brume-baseline" => {
            s.absorption = Absorption::Event;
            s.rr_throughput = 0.0;
            s.majorant = MajorantMode::Leaf;
            s.sampler = SamplerKind::Independent;
            s.light_selection = crate::render::LightSelection::Uniform;
        }
        "brume-event" => s.absorption = Absorption::Event,
        "brume-no-rr-guard" => s.rr_throughput = 0.0,
        "brume-leaf" => s.majorant = MajorantMode::Leaf,
        "brume-global" => s.majorant = MajorantMode::Global,
        "brume-independent" => s.sampler = SamplerKind::Independent,
        "brume-spectral" => s.force_spectral = true,
        "brume-decomposition" => s.estimator = crate::render::Estimator::Decomposition,
        "brume-uniform-lights" => {
            s.light_selection = crate::render::LightSelection::Uniform;
        }
        "brume-sky-every-event" => {
            s.light_selection = crate::render::LightSelection::GuidedFullSky;
        }
        "brume-distance" => s.volume_sampling = crate::render::VolumeSampling::Distance,
        "brume-collisions" => s.media_lights = false,
        _ => return false,
    }
    true
}

/// The example scenes the table is about (one row per renderer each).
pub const DEFAULT_SCENES: [&str; 3] = [
    "scenes/plume_sun.gltf",
    "scenes/plume_sky.gltf",
    "scenes/dense_fog.gltf",
];

#[derive(Args, Debug)]
pub struct PeersArgs {
    /// Scenes (default: scenes/plume_sun.gltf, scenes/plume_sky.gltf, scenes/dense_fog.gltf).
    pub scenes: Vec<PathBuf>,
    #[arg(long, default_value_t = 256)]
    pub width: u32,
    #[arg(long, default_value_t = 256)]
    pub height: u32,
    #[arg(long, default_value_t = 64)]
    pub spp: u32,
    /// Threads for every renderer.
    #[arg(long, default_value_t = 2)]
    pub threads: u32,
    /// Seeds per renderer and scene (0, 1, ...); at least 2.
    #[arg(long, default_value_t = 2)]
    pub seeds: u32,
    /// Folder for the images (SCENE/RENDERER-seedS.exr) and peers.md.
    #[arg(long, default_value = "out/peers")]
    pub out: PathBuf,
    /// Renderers to run, of brume, its ablation variants (brume-baseline: absorption events,
    /// per-leaf majorants, independent sampler, no early roulette, uniform light selection;
    /// brume-event, brume-no-rr-guard, brume-leaf,
    /// brume-global, brume-independent, brume-spectral, brume-decomposition,
    /// brume-uniform-lights, brume-sky-every-event, brume-distance (free-flight distances
    /// only, no equiangular sampling), brume-collisions (emitting media found by paths only,
    /// not sampled as lights): one default changed each), mitsuba, cycles (default: brume,
    /// mitsuba, cycles).
    #[arg(long, value_delimiter = ',', default_value = "brume,mitsuba,cycles")]
    pub renderers: Vec<String>,
    /// Measure variance and means over the pixels `[X0, X1) x [Y0, Y1)` only (e.g. the ground
    /// under a fire); every renderer still renders the whole image.
    #[arg(long, value_name = "X0,Y0,X1,Y1", value_parser = parse_window)]
    pub window: Option<[u32; 4]>,
    /// Leave out of the statistics the 5 x 5 pixels around each point or spot light the
    /// camera sees: a point light's glow in a medium falls off as 1 / d across the image, so
    /// under uniform pixel jitter (the peers', and Brume's with `--volume-sampling distance`)
    /// the pixel holding it has an infinite variance, and it would set every figure.
    #[arg(long)]
    pub mask_lights: bool,
}

/// The pixels the statistics take, row by row: `--window`'s, less `--mask-lights`' (`None`:
/// every pixel).
fn kept_pixels(scene: &Path, args: &PeersArgs) -> Result<Option<Vec<bool>>> {
    if args.window.is_none() && !args.mask_lights {
        return Ok(None);
    }
    let (w, h) = (args.width as usize, args.height as usize);
    let [x0, y0, x1, y1] = args.window.map_or([0, 0, w, h], |b| b.map(|v| v as usize));
    let mut kept: Vec<bool> = (0..w * h)
        .map(|i| (x0..x1).contains(&(i % w)) && (y0..y1).contains(&(i / w)))
        .collect();
    if args.mask_lights {
        let s = crate::scene::load(scene)?;
        let pinhole = s.camera.pinhole();
        let positional = s.lights.iter().filter(|l| l.kind != LIGHT_DIRECTIONAL);
        for l in positional {
            let aspect = w as f32 / h as f32;
            let Some(f) = pinhole.film_point(glam::Vec3::from(l.position), aspect) else {
                continue;
            };
            let (px, py) = (
                (f.x * w as f32).floor() as i64,
                (f.y * h as f32).floor() as i64,
            );
            for y in py - 2..=py + 2 {
                for x in px - 2..=px + 2 {
                    if (0..w as i64).contains(&x) && (0..h as i64).contains(&y) {
                        kept[y as usize * w + x as usize] = false;
                    }
                }
            }
        }
    }
    Ok(Some(kept))
}

/// `X0,Y0,X1,Y1`.
fn parse_window(s: &str) -> Result<[u32; 4], String> {
    let v: Vec<u32> = s
        .split(',')
        .map(|x| x.trim().parse::<u32>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("'{s}': {e}"))?;
    match v[..] {
        [x0, y0, x1, y1] if x0 < x1 && y0 < y1 => Ok([x0, y0, x1, y1]),
        _ => Err(format!("'{s}' is not X0,Y0,X1,Y1 with X0 < X1 and Y0 < Y1")),
    }
}

/// One renderer's renders of one scene.
struct Row {
    renderer: &'static str,
    seconds: f64,
    /// Fixed per-render set-up included in `seconds` (Cycles), when the renderer reports it.
    setup: Option<f64>,
    variance: f64,
    /// The share of `variance` in the worst 0.1 % of pixel values.
    top_share: f64,
    mean: ImageMean,
    spp: u32,
}

impl Row {
    fn efficiency(&self) -> f64 {
        1.0 / (self.seconds * self.variance)
    }
    fn per_sample_variance(&self) -> f64 {
        self.variance * self.spp as f64
    }
}

/// The renders of one renderer (one image per seed), or why there are none.
enum Outcome {
    Done(Row),
    Skipped(String),
}

pub fn run(args: &PeersArgs) -> Result<()> {
    if args.seeds < 2 {
        bail!("--seeds must be at least 2 (the variance comes from the spread across seeds)");
    }
    if args.spp == 0 || args.width == 0 || args.height == 0 || args.threads == 0 {
        bail!("--spp, --width, --height and --threads must be at least 1");
    }
    if let Some([_, _, x1, y1]) = args.window {
        if x1 > args.width || y1 > args.height {
            bail!(
                "--window ends outside the {}x{} image",
                args.width,
                args.height
            );
        }
    }
    for r in &args.renderers {
        if !RENDERERS.contains(&r.as_str()) {
            bail!("unknown renderer {r:?} (one of {})", RENDERERS.join(", "));
        }
    }
    let scenes: Vec<PathBuf> = if args.scenes.is_empty() {
        DEFAULT_SCENES.iter().map(PathBuf::from).collect()
    } else {
        args.scenes.clone()
    };
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let mut table = Table::default();
    let mut skipped: Vec<String> = Vec::new();
    for scene in &scenes {
        let name = scene
            .file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .into_owned();
        let dir = args.out.join(scene.file_stem().unwrap_or_default());
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        let kept = kept_pixels(scene, args)?;
        let mut rows = Vec::new();
        for renderer in RENDERERS {
            if !args.renderers.iter().any(|r| r == renderer) {
                continue;
            }
            let outcome = match renderer {
                "mitsuba" => peer_renders("mitsuba", scene, &dir, args, &kept)?,
                "cycles" => peer_renders("cycles", scene, &dir, args, &kept)?,
                brume => brume_renders(scene, &dir, args, brume, &kept)?,
            };
            match outcome {
                Outcome::Done(row) => {
                    eprintln!(
                        "{name}: {renderer}: {:.2} s, per-pixel variance {:.3e}, mean {:.5}",
                        row.seconds, row.variance, row.mean.mean
                    );
                    rows.push(row);
                }
                Outcome::Skipped(why) => {
                    let line = format!("{renderer}: skipped ({why})");
                    eprintln!("{name}: {line}");
                    if !skipped.contains(&line) {
                        skipped.push(line);
                    }
                }
            }
        }
        table.add(&name, &rows);
    }
    let mut window = args.window.map_or(String::new(), |[x0, y0, x1, y1]| {
        format!(", statistics over pixels [{x0}, {x1}) x [{y0}, {y1})")
    });
    if args.mask_lights {
        window.push_str(", the 5 x 5 pixels around each point and spot light in view left out");
    }
    let header = format!(
        "{}x{}, {} spp, {} threads, seeds 0..{} per renderer and scene{window}",
        args.width,
        args.height,
        args.spp,
        args.threads,
        args.seeds - 1
    );
    let mut md = String::new();
    writeln!(md, "{header}\n")?;
    md.push_str(&table.text);
    if !skipped.is_empty() {
        md.push('\n');
        for s in &skipped {
            writeln!(md, "- {s}")?;
        }
    }
    print!("{md}");
    let path = args.out.join("peers.md");
    std::fs::write(&path, &md).with_context(|| format!("writing {}", path.display()))?;
    eprintln!("wrote {}", path.display());
    Ok(())
}

/// The markdown table, one block of rows per scene.
struct Table {
    text: String,
}

impl Default for Table {
    fn default() -> Self {
        Table {
            text: "| scene | renderer | seconds | set-up s | per-pixel variance | top 0.1 % | efficiency | \
                   Brume/peer efficiency | per-sample variance Brume/peer | mean | mean diff vs \
                   Mitsuba (z) | Brume mean diff vs peer (z) |\n\
                   |---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n"
                .to_string(),
        }
    }
}

impl Table {
    fn add(&mut self, scene: &str, rows: &[Row]) {
        let brume = rows.iter().find(|r| r.renderer == "brume");
        let mitsuba = rows.iter().find(|r| r.renderer == "mitsuba");
        for r in rows {
            let diff = |a: &Row, b: &Row| {
                let (d, z) = a.mean.difference(&b.mean);
                format!("{:+.3} % (z {:+.2})", 100.0 * d / b.mean.mean, z)
            };
            let (eff_ratio, var_ratio, brume_diff) = match brume {
                Some(b) if !r.renderer.starts_with("brume") => {
                    let mut eff = sig3(b.efficiency() / r.efficiency());
                    // The peer's fixed set-up left out: what longer renders tend to.
                    if let Some(setup) = r.setup.filter(|&s| s < r.seconds) {
                        let without = 1.0 / ((r.seconds - setup) * r.variance);
                        let _ = write!(eff, " ({} without set-up)", sig3(b.efficiency() / without));
                    }
                    (
                        eff,
                        sig3(b.per_sample_variance() / r.per_sample_variance()),
                        diff(b, r),
                    )
                }
                _ => ("".into(), "".into(), "".into()),
            };
            let vs_mitsuba = match mitsuba {
                Some(m) if r.renderer != "mitsuba" => diff(r, m),
                _ => "".into(),
            };
            let _ = writeln!(
                self.text,
                "| {scene} | {} | {} | {} | {:.3e} | {:.0} % | {:.3e} | {eff_ratio} | {var_ratio} | {:.5} | {vs_mitsuba} | {brume_diff} |",
                r.renderer,
                sig3(r.seconds),
                r.setup.map_or(String::new(), sig3),
                r.variance,
                100.0 * r.top_share,
                r.efficiency(),
                r.mean.mean,
            );
        }
    }
}

/// Brume in this process: one render per seed on a pool of `--threads` threads; the time is
/// the render loop's own (scene loading and preparation excluded, as `brume render` reports).
fn brume_renders(
    scene_path: &Path,
    dir: &Path,
    args: &PeersArgs,
    name: &'static str,
    kept: &Option<Vec<bool>>,
) -> Result<Outcome> {
    use crate::render::{Estimator, MajorantMode, RenderScene, RenderSettings};
    let scene = crate::scene::load(scene_path)?;
    scene
        .validate()
        .map_err(|e| anyhow!("{}: {e}", scene_path.display()))?;
    let mut base = RenderSettings {
        width: args.width,
        height: args.height,
        spp: args.spp,
        ..RenderSettings::default()
    };
    if let Some(e) = &scene.render.estimator {
        base.estimator = e.parse::<Estimator>().map_err(|e| anyhow!(e))?;
    }
    if let Some(m) = &scene.render.majorant {
        base.majorant = m.parse::<MajorantMode>().map_err(|e| anyhow!(e))?;
    }
    if let Some(d) = scene.render.max_depth {
        base.max_depth = d;
    }
    if !brume_variant(name, &mut base) {
        bail!("unknown Brume variant {name}");
    }
    let rs = RenderScene::prepare(&scene, &base).map_err(|e| anyhow!(e))?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads as usize)
        .build()?;
    let mut images = Vec::new();
    let mut seconds = Vec::new();
    for seed in 0..args.seeds {
        let s = RenderSettings {
            seed,
            ..base.clone()
        };
        let out = pool.install(|| {
            crate::backend::cpu::render(
                &rs,
                &s,
                &std::sync::atomic::AtomicBool::new(false),
                &|_, _, _| {},
            )
        });
        let mut meta = Metadata::new();
        meta.set("brume:renderer", AttrValue::Text(name.into()))
            .set("brume:seconds", AttrValue::Double(out.seconds))
            .set("brume:seed", AttrValue::Int(seed as i32))
            .set("brume:spp", AttrValue::Int(out.spp as i32));
        let image = Image::from_film(&out.film, &meta);
        write_image(dir.join(format!("{name}-seed{seed}.exr")), &image)?;
        seconds.push(out.seconds);
        images.push(image);
    }
    Ok(Outcome::Done(row(
        name, &images, &seconds, None, args, kept,
    )?))
}

/// Mitsuba or Cycles through `brume mitsuba` / `brume cycles` (this executable), one process
/// per seed; the seconds come from the EXR each writes.
fn peer_renders(
    which: &'static str,
    scene: &Path,
    dir: &Path,
    args: &PeersArgs,
    kept: &Option<Vec<bool>>,
) -> Result<Outcome> {
    let exe = std::env::current_exe().context("finding the brume executable")?;
    let mut images = Vec::new();
    let mut seconds = Vec::new();
    let mut setups = Vec::new();
    for seed in 0..args.seeds {
        let out = dir.join(format!("{which}-seed{seed}.exr"));
        let mut cmd = Command::new(&exe);
        cmd.arg(which)
            .arg(scene)
            .arg("-o")
            .arg(&out)
            .args(["--spp", &args.spp.to_string()])
            .args(["--width", &args.width.to_string()])
            .args(["--height", &args.height.to_string()])
            .args(["--seed", &seed.to_string()])
            .args(["--threads", &args.threads.to_string()]);
        if which == "cycles" {
            cmd.args(["--runs", "1"]);
        }
        let _ = std::fs::remove_file(&out);
        let o = cmd
            .output()
            .with_context(|| format!("running {} {which}", exe.display()))?;
        if !o.status.success() {
            return Ok(Outcome::Skipped(failure_reason(which, &o.stderr)));
        }
        let image =
            read_exr(&out).with_context(|| format!("reading {which}'s {}", out.display()))?;
        let (s, setup) = reported_seconds(which, &image.attributes).ok_or_else(|| {
            anyhow!(
                "{}: no render time in its metadata (brume:seconds or brume:render_seconds)",
                out.display()
            )
        })?;
        if (image.width, image.height) != (args.width as usize, args.height as usize) {
            bail!(
                "{}: {}x{}, expected {}x{}",
                out.display(),
                image.width,
                image.height,
                args.width,
                args.height
            );
        }
        seconds.push(s);
        if let Some(x) = setup {
            setups.push(x);
        }
        images.push(image);
    }
    let setup = (setups.len() == seconds.len()).then(|| stats::mean_std(&setups).0);
    Ok(Outcome::Done(row(
        which, &images, &seconds, setup, args, kept,
    )?))
}

/// The seconds a peer reports, and the set-up part of them when it says so. Cycles:
/// `brume:seconds` is Cycles' own total (set-up + path tracing), `brume:cycles_setup_seconds`
/// its set-up. Mitsuba: `brume:seconds`, else `brume:render_seconds`.
fn reported_seconds(which: &str, meta: &Metadata) -> Option<(f64, Option<f64>)> {
    let num = |k: &str| match meta.get(k)? {
        AttrValue::Double(v) => Some(*v),
        AttrValue::Float(v) => Some(*v as f64),
        AttrValue::Int(v) => Some(*v as f64),
        AttrValue::Text(t) => t.trim().parse().ok(),
    };
    let total = num("brume:seconds").or_else(|| num("brume:render_seconds"))?;
    let setup = if which == "cycles" {
        num("brume:cycles_setup_seconds")
    } else {
        num("brume:setup_seconds")
    };
    Some((total, setup))
}

/// One line saying why a peer did not run: an unknown subcommand (this build has no
/// `brume mitsuba`), or the command's own error line (e.g. no Python with bpy).
fn failure_reason(which: &str, stderr: &[u8]) -> String {
    let text = String::from_utf8_lossy(stderr);
    if text.contains("unrecognized subcommand") {
        return format!("this brume has no `{which}` subcommand");
    }
    let line = text
        .lines()
        .map(str::trim)
        .find(|l| l.starts_with("error:"))
        .or_else(|| text.lines().map(str::trim).rfind(|l| !l.is_empty()))
        .unwrap_or("failed with no message");
    line.trim_start_matches("error:").trim().to_string()
}

/// Three significant digits, without an exponent between 0.001 and 10^4.
fn sig3(x: f64) -> String {
    if !x.is_finite() || x == 0.0 {
        return format!("{x}");
    }
    let mag = x.abs().log10().floor() as i32;
    if (-3..4).contains(&mag) {
        format!("{:.*}", (2 - mag).max(0) as usize, x)
    } else {
        format!("{x:.2e}")
    }
}

/// The pixels of `image` that `kept` keeps (all of them without it).
fn kept_of(image: &Image, kept: &Option<Vec<bool>>) -> Vec<[f32; 3]> {
    match kept {
        None => image.rgb.clone(),
        Some(k) => (image.rgb.iter().zip(k))
            .filter(|(_, &k)| k)
            .map(|(p, _)| *p)
            .collect(),
    }
}

fn row(
    renderer: &'static str,
    images: &[Image],
    seconds: &[f64],
    setup: Option<f64>,
    args: &PeersArgs,
    kept: &Option<Vec<bool>>,
) -> Result<Row> {
    let spp = args.spp;
    let pixels: Vec<Vec<[f32; 3]>> = images.iter().map(|i| kept_of(i, kept)).collect();
    let rgb: Vec<&[[f32; 3]]> = pixels.iter().map(|p| p.as_slice()).collect();
    let variance = stats::seed_variance_profile(&rgb, stats::TOP_FRACTION)
        .map_err(|e| anyhow!("{renderer}: {e}"))?;
    let mean = stats::image_mean(&rgb).map_err(|e| anyhow!("{renderer}: {e}"))?;
    Ok(Row {
        renderer,
        seconds: stats::mean_std(seconds).0,
        setup,
        variance: variance.pooled,
        top_share: variance.top_share,
        mean,
        spp,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ratios_keep_three_significant_digits() {
        assert_eq!(sig3(0.01234), "0.0123");
        assert_eq!(sig3(2.4), "2.40");
        assert_eq!(sig3(625.507), "626");
        assert_eq!(sig3(12345.0), "1.23e4");
    }

    #[test]
    fn failure_reasons_are_one_line() {
        let clap = b"error: unrecognized subcommand 'mitsuba'\n\nUsage: brume <COMMAND>\n";
        assert_eq!(
            failure_reason("mitsuba", clap),
            "this brume has no `mitsuba` subcommand"
        );
        let own = b"warning: x\nerror: no Python with bpy found: run tools/cycles/ci.sh\n";
        assert_eq!(
            failure_reason("cycles", own),
            "no Python with bpy found: run tools/cycles/ci.sh"
        );
        assert_eq!(failure_reason("cycles", b""), "failed with no message");
    }

    #[test]
    fn seconds_come_from_the_metadata() {
        let m = Metadata::new()
            .with("brume:seconds", AttrValue::Double(3.5))
            .with("brume:cycles_setup_seconds", AttrValue::Double(1.25));
        assert_eq!(reported_seconds("cycles", &m), Some((3.5, Some(1.25))));
        assert_eq!(reported_seconds("mitsuba", &m), Some((3.5, None)));
        let m = Metadata::new().with("brume:render_seconds", AttrValue::Double(2.0));
        assert_eq!(reported_seconds("mitsuba", &m), Some((2.0, None)));
        assert_eq!(reported_seconds("mitsuba", &Metadata::new()), None);
    }
}
