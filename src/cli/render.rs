//! `brume render`: a scene file to an EXR, with tile logs and a cost map.
use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use anyhow::{anyhow, Context, Result};
use clap::Args;

use brume::backend::cpu::{self, RenderOutput};
use brume::farm::context::PartContext;
use brume::film::passes::PassLayers;
use brume::film::{totals, write_cost_map, write_exr_with_state, CostMetric, Film, TileLogWriter};
use brume::render::light_groups::LightGroups;
use brume::render::{
    Absorption, BlackbodyModel, Estimator, MajorantMode, RenderScene, RenderSettings, SamplerKind,
    ShadowEstimator,
};
use brume::scene::{self, LoadOptions, SceneRenderSettings};

use super::viewer::{self, Viewer};

#[derive(Args, Clone, Debug)]
pub struct RenderArgs {
    /// The scene (.gltf or .glb), or a bare .vdb (rendered in a scene made for it).
    pub scene: PathBuf,
    /// With a .vdb scene: write the scene made for it to this .gltf.
    #[arg(long, value_name = "SCENE.gltf")]
    pub save_scene: Option<PathBuf>,
    /// Output EXR (beauty RGBA, variance.RGB, samples.Y, render metadata). A run of `#` in
    /// its file name (and in --tile-log's and --cost-map's) is replaced by the frame.
    #[arg(short, long)]
    pub output: PathBuf,
    /// The frame whose files a sequence reads (a medium `uri` with a run of `#`, such as
    /// `smoke_####.vdb`); default: the scene's BRUME_render frame, else 1.
    #[arg(long, allow_hyphen_values = true, conflicts_with = "frames")]
    pub frame: Option<i32>,
    /// Render frames A..B (both included) one after another, each as with --frame; every
    /// frame's files are checked before the first is rendered. `scene`: the scene's
    /// BRUME_render frameRange.
    #[arg(long, value_name = "A..B", value_parser = scene::sequence::FrameChoice::parse, allow_hyphen_values = true, conflicts_with = "resume")]
    pub frames: Option<scene::sequence::FrameChoice>,
    /// The shutter in frames around the frame's time, OPEN,CLOSE (such as -0.25,0.25):
    /// each sample's time is uniform in it. Overrides the scene's BRUME_render shutter;
    /// 0,0 renders without motion blur.
    #[arg(long, value_name = "OPEN,CLOSE", value_parser = scene::Shutter::parse, allow_hyphen_values = true)]
    pub shutter: Option<scene::Shutter>,
    /// opaque (the environment seen straight through is in the colour, alpha 1) or
    /// transparent (it is left out and alpha is the pixel's coverage: a premultiplied RGBA
    /// to lay over a plate; the environment still lights the scene). Default: the scene's
    /// BRUME_render filmTransparent, else opaque.
    #[arg(long, value_enum)]
    pub film: Option<FilmMode>,
    /// What the EXR holds beside the beauty: a comma-separated list of beauty (the default),
    /// light (the light passes: emission, background, volume.direct, volume.indirect,
    /// surface.direct, surface.indirect, which add up to the beauty), data (the denoiser's
    /// albedo and normal, and depth, with Cycles' conventions), lights (a light group per glTF
    /// light, the environment, the emissive surfaces and each emitting medium, which add up to
    /// the beauty) and all (every one).
    #[arg(long, value_name = "LIST", value_parser = super::passes::parse)]
    pub passes: Option<super::passes::PassChoice>,
    /// Adaptive sampling: a pixel stops taking samples once the standard error of its mean is
    /// below E times the mean (such as 0.01), decided at pass boundaries, so a render is the
    /// same from its seed and on a resume; --spp is then the most a pixel takes (CPU backend;
    /// split on a farm by region, not by samples).
    #[arg(long, value_name = "E")]
    pub noise_threshold: Option<f32>,
    /// Samples every pixel takes before adaptive sampling may stop it (default 16).
    #[arg(long, value_name = "N", requires = "noise_threshold")]
    pub min_spp: Option<u32>,
    /// Samples per pixel (default 16, or unlimited with --time).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Wall-clock budget in seconds; no new pass starts after it.
    #[arg(long)]
    pub time: Option<f64>,
    /// Image width (default: the scene's BRUME_render width, else 320).
    #[arg(long)]
    pub width: Option<u32>,
    /// Image height (default: the scene's BRUME_render height, else 240).
    #[arg(long)]
    pub height: Option<u32>,
    /// Free-flight estimator: delta, weighted-delta, decomposition, weighted-decomposition
    /// (default: the scene's BRUME_render estimator, else delta).
    #[arg(long)]
    pub estimator: Option<Estimator>,
    /// Majorant scale b of the weighted estimators (sigma_maj = b * bound).
    #[arg(long)]
    pub b: Option<f32>,
    /// Minorant fraction m of the decomposition estimators (control = m * bound).
    #[arg(long)]
    pub m: Option<f32>,
    /// Majorants: global (one bound), leaf (per-leaf cells, 3D-DDA), culled (one global
    /// segment, its tentative collisions culled by the per-leaf bound at their point) or
    /// adaptive (whichever of those or a merged hierarchy `volume::adaptive` models cheapest;
    /// `local` is an alias); default adaptive.
    #[arg(long)]
    pub majorant: Option<MajorantMode>,
    /// Shadow-ray transmittance: auto, ratio, residual-ratio.
    #[arg(long, default_value = "auto")]
    pub shadow: ShadowEstimator,
    /// Spectral tracking even for grey media (chromatic media always use it).
    #[arg(long)]
    pub spectral: bool,
    /// Absorption at real collisions in media: weight (every real collision scatters and the
    /// throughput takes the RGB albedo; default) or event (the analog form of the seed
    /// paper's estimators: absorption ends the path).
    #[arg(long, default_value = "weight")]
    pub absorption: Absorption,
    /// A temperature grid's blackbody between voxels: temperature (the blackbody of the
    /// interpolated temperature, the continuous field) or voxels (each voxel's blackbody,
    /// blended: Cycles' model, for comparing with it). Default: the scene's BRUME_render
    /// blackbody, else temperature.
    #[arg(long)]
    pub blackbody: Option<BlackbodyModel>,
    /// Light choice of next-event estimation at medium events: guided (by each light's
    /// unoccluded contribution through the phase function, a constant sky mostly left to the
    /// continuation ray; default), guided-full-sky (the same, the sky estimated at every
    /// event) or uniform.
    #[arg(long, default_value = "guided")]
    pub light_selection: brume::render::LightSelection,
    /// Scattering distances towards point and spot lights in media: mis (free flight and
    /// equiangular sampling weighed by multiple importance sampling; default), distance (free
    /// flight alone) or equiangular. Scenes without such lights render by free flight.
    #[arg(long, default_value = "mis")]
    pub volume_sampling: brume::render::VolumeSampling,
    /// Emitting media as lights: on (next-event estimation towards points of the emitting
    /// media, weighed against the emission paths meet by MIS; default) or off (only paths
    /// that meet the emission find it).
    #[arg(long, value_name = "on|off", default_value = "on", value_parser = parse_on_off, action = clap::ArgAction::Set)]
    pub media_lights: bool,
    /// Russian roulette also before the 8th bounce once the throughput's largest channel is
    /// below this (0 disables; default 0.5).
    #[arg(long)]
    pub rr_throughput: Option<f32>,
    /// Run the unspecialised path (all effects enabled) to measure what specialisation saves.
    #[arg(long)]
    pub generic: bool,
    #[arg(long)]
    pub seed: Option<u32>,
    /// What drives pixel jitter, light, scattering and roulette decisions: sobol
    /// (Owen-scrambled, the default) or independent (the PCG stream of each sample).
    #[arg(long)]
    pub sampler: Option<SamplerKind>,
    /// How next-event estimation draws environment-map directions: importance (by the
    /// map's luminance, the default) or uniform (the ablation baseline).
    #[arg(long, value_enum, default_value_t)]
    pub env_sampling: brume::render::envmap::EnvSampling,
    /// Worker threads (default: $SLURM_CPUS_PER_TASK under Slurm, else all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Render only sample indices START..END (half-open) of every pixel, with the random
    /// numbers and Sobol points a whole render uses for them: a part for `brume merge`.
    #[arg(long, value_name = "START..END", value_parser = parse_samples, conflicts_with_all = ["spp", "time"])]
    pub samples: Option<(u32, u32)>,
    /// Render only the pixels in [x0, x1) x [y0, y1) (CPU backend).
    #[arg(long, value_name = "x0,y0,x1,y1", value_parser = parse_region)]
    pub region: Option<[u32; 4]>,
    /// Write the accumulated image (to --output, atomically) every SECONDS, at the first pass
    /// boundary after it; SIGTERM and Ctrl-C also write what has accumulated (CPU backend).
    #[arg(long, value_name = "SECONDS")]
    pub checkpoint: Option<f64>,
    /// Continue this checkpoint (or part) from the sample index it reached to the target
    /// (--samples END or --spp): the same image as an uninterrupted render, bit for bit.
    #[arg(long, value_name = "PART.exr")]
    pub resume: Option<PathBuf>,
    /// Longest path in scattering events (default 256).
    #[arg(long)]
    pub max_depth: Option<u32>,
    /// Render through this camera (glTF camera or node name).
    #[arg(long)]
    pub camera: Option<String>,
    /// Per-tile performance log, one JSON line per tile per pass.
    #[arg(long)]
    pub tile_log: Option<PathBuf>,
    /// Cost heat map (EXR, per sample per tile; what it counts: --cost-metric).
    #[arg(long)]
    pub cost_map: Option<PathBuf>,
    /// What the cost map counts per sample: lookups (density lookups), segments (majorant
    /// segments, the DDA/hierarchy steps), time (nanoseconds), nulls (null collisions),
    /// shadow-lookups, path-length.
    #[arg(long, default_value = "lookups")]
    pub cost_metric: CostMetricArg,
    #[arg(long, default_value_t = 16)]
    pub tile_size: u32,
    /// gpu (wgpu wavefront), cpu (rayon reference) or auto: the GPU when an adapter exists
    /// and supports the scene, else the CPU with a one-line reason.
    #[arg(long, default_value = "auto")]
    pub backend: Backend,
    /// The CPU backend's ray-query accelerator for static triangles: auto (default: embree
    /// from 300 static triangles on, where it is faster, else bvh; bvh with a warning where
    /// Embree cannot be built), bvh (the obvhs CWBVH) or embree (Intel Embree 3 chooses the
    /// triangle, Brume's own triangle test gives the hit, so images agree). Scenes with moving
    /// meshes, and the GPU backend, use the BVH. Scenes that place some mesh more than once
    /// store each mesh once under its placements: embree then builds Embree's instances over
    /// them, bvh a two-level BVH. The render prints which it used.
    #[arg(long, default_value = "auto")]
    pub accel: brume::render::settings::Accel,
    /// Show the image in the tev viewer listening at HOST:PORT (start `tev` first; its
    /// default is 127.0.0.1:14158) as the render converges: the mean after a pass, at most
    /// every half second, and the final image, one tev image per output file, with the passes
    /// the render keeps. The render never waits for the viewer:
    /// if it cannot be reached or goes away, one warning line says so and the render goes on.
    #[arg(long, value_name = "HOST:PORT", value_parser = brume::film::display::parse_address)]
    pub display_server: Option<String>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum CostMetricArg {
    Lookups,
    Segments,
    Time,
    Nulls,
    ShadowLookups,
    PathLength,
}

impl CostMetricArg {
    pub fn metric(self) -> CostMetric {
        match self {
            CostMetricArg::Lookups => CostMetric::DensityLookups,
            CostMetricArg::Segments => CostMetric::Segments,
            CostMetricArg::Time => CostMetric::Nanoseconds,
            CostMetricArg::Nulls => CostMetric::NullCollisions,
            CostMetricArg::ShadowLookups => CostMetric::ShadowLookups,
            CostMetricArg::PathLength => CostMetric::PathLength,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Backend {
    Auto,
    Gpu,
    Cpu,
}

/// What the film does with the environment the camera sees straight through.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum FilmMode {
    Opaque,
    Transparent,
}

impl RenderArgs {
    /// Brume's defaults, then the scene's `BRUME_render` values, then the command line.
    pub fn settings(&self, scene: &SceneRenderSettings) -> Result<RenderSettings> {
        let mut s = RenderSettings::default();
        s.width = self.width.or(scene.width).unwrap_or(s.width);
        s.height = self.height.or(scene.height).unwrap_or(s.height);
        s.time_limit = self.time;
        s.spp = self
            .spp
            .or(if self.time.is_some() { None } else { scene.spp })
            .unwrap_or(if self.time.is_some() { 0 } else { 16 });
        s.estimator = self
            .estimator
            .or(parse_opt::<Estimator>(&scene.estimator)?)
            .unwrap_or(s.estimator);
        s.b = self.b.or(scene.b).unwrap_or(s.b);
        s.m = self.m.or(scene.m);
        s.majorant = self
            .majorant
            .or(parse_opt::<MajorantMode>(&scene.majorant)?)
            .unwrap_or(s.majorant);
        s.shadow = self.shadow;
        s.force_spectral = self.spectral;
        s.absorption = self.absorption;
        s.blackbody = self
            .blackbody
            .or(parse_opt::<BlackbodyModel>(&scene.blackbody)?)
            .unwrap_or(s.blackbody);
        s.rr_throughput = self.rr_throughput.unwrap_or(s.rr_throughput);
        s.generic = self.generic;
        s.seed = self.seed.or(scene.seed).unwrap_or(s.seed);
        s.sampler = self
            .sampler
            .or(parse_opt::<SamplerKind>(&scene.sampler)?)
            .unwrap_or(s.sampler);
        s.max_depth = self.max_depth.or(scene.max_depth).unwrap_or(s.max_depth);
        s.env_sampling = self.env_sampling;
        s.light_selection = self.light_selection;
        s.volume_sampling = self.volume_sampling;
        s.media_lights = self.media_lights;
        s.tile_size = self.tile_size;
        s.light_passes = self.passes.is_some_and(|p| p.light);
        s.data_passes = self.passes.is_some_and(|p| p.data);
        s.noise_threshold = self.noise_threshold;
        s.min_spp = self.min_spp.unwrap_or(s.min_spp);
        s.film_transparent = match self.film {
            Some(f) => f == FilmMode::Transparent,
            None => scene.film_transparent.unwrap_or(false),
        };
        if let Some((start, end)) = self.samples {
            if start == end {
                return Err(anyhow!(
                    "--samples {start}..{end} is empty: nothing to render"
                ));
            }
            s.sample_start = start;
            s.spp = end;
        }
        s.region = self.region;
        s.accel = self.accel;
        Ok(s)
    }
}

fn parse_samples(s: &str) -> Result<(u32, u32), String> {
    brume::farm::parse_range(s)
}

fn parse_region(s: &str) -> Result<[u32; 4], String> {
    brume::farm::parse_region(s)
}

/// The worker count: `--threads`, else `SLURM_CPUS_PER_TASK` (Slurm without cgroups lets a
/// task see every core of the node, but it was allocated only these), else every core.
pub fn thread_count(flag: Option<usize>) -> (usize, &'static str) {
    if let Some(n) = flag.filter(|&n| n > 0) {
        return (n, "--threads");
    }
    if let Some(n) = std::env::var("SLURM_CPUS_PER_TASK")
        .ok()
        .and_then(|v| v.trim().parse::<usize>().ok())
        .filter(|&n| n > 0)
    {
        return (n, "SLURM_CPUS_PER_TASK");
    }
    (
        std::thread::available_parallelism().map_or(1, |n| n.get()),
        "all cores",
    )
}

fn parse_opt<T: std::str::FromStr<Err = String>>(v: &Option<String>) -> Result<Option<T>> {
    v.as_deref()
        .map(str::parse)
        .transpose()
        .map_err(|e: String| anyhow!(e))
}

/// A render's result and what the output's header says of it: the backend and the GPU variant.
type Rendered = (RenderOutput, String, Option<String>);

pub fn run(args: &RenderArgs) -> Result<()> {
    let display = args.display_server.as_deref().map(viewer::connect);
    let rendered = render_all(args, display.as_ref());
    if let Some(display) = display {
        display.close(viewer::FLUSH);
    }
    rendered
}

/// Renders the scene, or each frame of `--frames`, showing each in `display` where given.
fn render_all(args: &RenderArgs, display: Option<&brume::film::Display>) -> Result<()> {
    if let Some(made) =
        scene::bare_vdb::prepare(&args.scene, args.save_scene.as_deref()).map_err(|e| anyhow!(e))?
    {
        let scene = made.path().to_path_buf();
        let args = RenderArgs {
            scene,
            save_scene: None,
            ..args.clone()
        };
        return render_all(&args, display);
    }
    if let Some(frames) = args.frames {
        let (a, b) = frames.resolve(&args.scene)?;
        return render_frames(args, a, b, display);
    }
    let mut scene = load_scene(args)?;
    let args = &args.for_frame(scene.frame);
    let mut settings = args
        .settings(&scene.render)
        .with_context(|| format!("{}: BRUME_render", args.scene.display()))?;
    if args.passes.is_some_and(|p| p.lights) {
        settings.light_groups = LightGroups::of(&scene).map_err(|e| anyhow!(e))?.names;
    }
    let viewer = display.map(|d| Viewer::new(d, &args.output, settings.film_transparent));
    settings
        .validate()
        .map_err(|e| anyhow!("invalid settings: {e}"))?;
    let cpu_only = args.checkpoint.is_some()
        || args.resume.is_some()
        || args.region.is_some()
        || settings.noise_threshold.is_some();
    if cpu_only && args.backend == Backend::Gpu {
        return Err(anyhow!(
            "--backend gpu: --checkpoint, --resume, --region and --noise-threshold run on \
             the CPU backend only"
        ));
    }
    check_outputs(args)?;
    super::render_report::report_accel(&mut scene, settings.accel, args.backend == Backend::Gpu)?;
    let rs = RenderScene::prepare(&scene, &settings).map_err(|e| anyhow!(e))?;
    let features = if settings.generic {
        brume::render::FeatureFlags::ALL
    } else {
        rs.features
    };
    super::render_report::report_plan(&scene, &rs, &settings, features);
    let stop = stop_on_signal();
    let (threads, threads_from) = thread_count(args.threads);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    let threads = pool.current_num_threads();
    eprintln!("threads: {threads} (from {threads_from})");
    let part = PartContext::new(
        &args.scene,
        scene.frame,
        &settings,
        args.camera.as_deref(),
        scene.shutter,
    )?;
    let resume = match &args.resume {
        Some(path) => Some(part.resume_from(path, &settings)?),
        None => None,
    };
    if let Some((_, cpu::Resume { reached, .. })) = &resume {
        eprintln!(
            "resume: {} holds samples {}..{reached}; rendering {reached}..{}",
            args.resume.as_ref().unwrap().display(),
            settings.sample_start,
            settings.spp
        );
    }
    let bar = progress_bar(&settings);
    let progress = |spp: u32, _target: u32, secs: f64| match &bar {
        Some(b) => b.set_position(spp as u64),
        None => eprintln!("pass done: {spp} spp, {secs:.2} s"),
    };
    let earlier = resume.as_ref().map_or(0.0, |(s, _)| *s);
    let on_gpu = match choose_gpu(args, cpu_only, &rs, &settings)? {
        Some(ctx) => render_on_gpu(
            args,
            &ctx,
            &rs,
            &settings,
            &stop,
            &progress,
            viewer.as_ref(),
        )?,
        None => None,
    };
    let (mut out, backend, variant) = match on_gpu {
        Some(done) => done,
        None => {
            let backend = format!("cpu ({threads} threads)");
            let run = CpuRun {
                args,
                rs: &rs,
                settings: &settings,
                part: &part,
                features,
                earlier,
                stop: &stop,
                viewer: viewer.as_ref(),
            };
            let resume = resume.map(|(_, r)| r);
            let out = pool.install(|| run.render(resume, &backend, &progress))?;
            (out, backend, None)
        }
    };
    out.seconds += earlier;
    if let Some(v) = &viewer {
        v.last(&out.film);
    }
    let written = write_outputs(args, &part, &settings, &out, &backend, variant.as_deref());
    if let Some(v) = &viewer {
        v.flush();
    }
    written
}

/// Prints the process's peak resident memory (Linux's `VmHWM`; nothing elsewhere): what a
/// render of this scene needs, the geometry and the grids included.
fn report_peak_memory() {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    let peak = status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().strip_suffix("kB"))
        .and_then(|kb| kb.trim().parse::<f64>().ok());
    if let Some(kb) = peak {
        eprintln!("peak memory: {:.1} MiB resident", kb / 1024.0);
    }
}

/// Renders frames `a..=b` one after another as `--frame` would, once every frame's files are
/// known to exist; several frames need a run of `#` in each output's file name.
fn render_frames(
    args: &RenderArgs,
    a: i32,
    b: i32,
    display: Option<&brume::film::Display>,
) -> Result<()> {
    if b > a {
        for p in args.outputs() {
            let name = p.file_name().and_then(|n| n.to_str()).unwrap_or_default();
            if !scene::sequence::is_sequence(name) {
                return Err(anyhow!(
                    "--frames {a}..{b} writes {} images: put a run of # for the frame number \
                     in {} (such as out_####.exr)",
                    b - a + 1,
                    p.display()
                ));
            }
        }
    }
    scene::sequence::check_files(&args.scene, a, b)?;
    for frame in a..=b {
        eprintln!("frame {frame}");
        let args = RenderArgs {
            frame: Some(frame),
            frames: None,
            ..args.clone()
        };
        render_all(&args, display)?;
    }
    Ok(())
}

impl RenderArgs {
    /// The files the render writes: the image, and the tile log and cost map if asked for.
    fn outputs(&self) -> impl Iterator<Item = &PathBuf> {
        [
            Some(&self.output),
            self.tile_log.as_ref(),
            self.cost_map.as_ref(),
        ]
        .into_iter()
        .flatten()
    }

    /// These arguments with every output's run of `#` replaced by `frame`.
    fn for_frame(&self, frame: i32) -> RenderArgs {
        let at = |p: &PathBuf| scene::sequence::path_for_frame(p, frame);
        RenderArgs {
            output: at(&self.output),
            tile_log: self.tile_log.as_ref().map(at),
            cost_map: self.cost_map.as_ref().map(at),
            ..self.clone()
        }
    }
}

/// The scene, validated, with its warnings printed.
fn load_scene(args: &RenderArgs) -> Result<brume::scene::Scene> {
    let scene = scene::load_with(
        &args.scene,
        &LoadOptions {
            camera: args.camera.clone(),
            frame: args.frame,
            shutter: args.shutter,
        },
    )?;
    scene
        .validate()
        .map_err(|e| anyhow!("{}: {e}", args.scene.display()))?;
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    Ok(scene)
}

/// Fails on unwritable outputs before the render is spent.
fn check_outputs(args: &RenderArgs) -> Result<()> {
    for p in args.outputs() {
        brume::film::check_writable(p)?;
    }
    Ok(())
}

/// The flag a render polls between tiles: set by Ctrl-C and by SIGTERM (what Slurm and farm
/// managers send before a kill; ctrlc's `termination` feature), so the render stops after the
/// current tiles and writes what has accumulated at whole passes. A second signal kills as
/// usual.
fn stop_on_signal() -> Arc<AtomicBool> {
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    let _ = ctrlc::set_handler(move || {
        if flag.swap(true, Ordering::SeqCst) {
            std::process::exit(130);
        }
        eprintln!("\ninterrupted: finishing, writing what has accumulated");
    });
    stop
}

/// A progress bar over the samples to render, on a terminal only.
fn progress_bar(settings: &RenderSettings) -> Option<indicatif::ProgressBar> {
    std::io::stderr().is_terminal().then(|| {
        let bar = indicatif::ProgressBar::new(
            settings.spp.saturating_sub(settings.sample_start).max(1) as u64,
        );
        bar.set_style(
            indicatif::ProgressStyle::with_template(
                "{bar:40} {pos}/{len} spp  {elapsed_precise} eta {eta}",
            )
            .expect("static template"),
        );
        bar
    })
}

/// The GPU when asked for, or when auto finds a usable one; `None` for the CPU, saying why.
fn choose_gpu(
    args: &RenderArgs,
    cpu_only: bool,
    rs: &RenderScene,
    settings: &RenderSettings,
) -> Result<Option<brume::backend::gpu::GpuContext>> {
    Ok(match args.backend {
        Backend::Cpu => None,
        Backend::Auto if cpu_only => None,
        Backend::Gpu | Backend::Auto => match brume::backend::gpu::GpuContext::new() {
            // A software adapter (Mesa's llvmpipe) runs the wavefront kernels on the same CPU
            // cores, an order of magnitude slower than the CPU backend: auto skips it.
            Ok(ctx)
                if args.backend == Backend::Auto
                    && ctx.adapter_info.device_type == wgpu::DeviceType::Cpu =>
            {
                eprintln!("backend: cpu (the only GPU adapter, {}, is a software rasterizer; --backend gpu forces it)", ctx.adapter_info.name);
                None
            }
            Ok(ctx) => match brume::backend::gpu::supports_with(rs, settings) {
                Ok(()) => Some(ctx),
                Err(why) if args.backend == Backend::Gpu => {
                    return Err(anyhow!("--backend gpu: {why}"))
                }
                Err(why) => {
                    eprintln!("backend: cpu ({why})");
                    None
                }
            },
            Err(e) if args.backend == Backend::Gpu => return Err(anyhow!("--backend gpu: {e}")),
            Err(e) => {
                eprintln!("backend: cpu (no usable GPU: {e})");
                None
            }
        },
    })
}

/// The render on `ctx`; `None` where auto falls back to the CPU (the scene exceeds the
/// device's limits, found while kernels and buffers are set up, before any sample).
fn render_on_gpu(
    args: &RenderArgs,
    ctx: &brume::backend::gpu::GpuContext,
    rs: &RenderScene,
    settings: &RenderSettings,
    stop: &AtomicBool,
    progress: &(dyn Fn(u32, u32, f64) + Sync),
    viewer: Option<&Viewer>,
) -> Result<Option<Rendered>> {
    eprintln!("backend: gpu ({})", ctx.describe());
    let mut show = |film: &Film, passes: Option<&PassLayers>| {
        if let Some(v) = viewer {
            v.pass_with(film, passes);
        }
    };
    let rendered =
        brume::backend::gpu::render::render_observed(ctx, rs, settings, stop, progress, &mut show);
    match rendered {
        Ok((out, timings)) => {
            eprintln!("gpu variant: {}", timings.variant);
            Ok(Some((
                out,
                format!("wgpu: {}", ctx.describe()),
                Some(timings.variant),
            )))
        }
        Err(brume::backend::gpu::render::GpuRenderError::Limits(why))
            if args.backend == Backend::Auto =>
        {
            eprintln!("backend: cpu (the GPU's limits: {why})");
            Ok(None)
        }
        Err(e) => Err(e.into()),
    }
}

/// A render on the CPU backend and what its checkpoints and the viewer need.
struct CpuRun<'a> {
    args: &'a RenderArgs,
    rs: &'a RenderScene<'a>,
    settings: &'a RenderSettings,
    part: &'a PartContext,
    features: brume::render::FeatureFlags,
    /// Render seconds of the checkpoint resumed from.
    earlier: f64,
    stop: &'a AtomicBool,
    /// Where each pass's image is shown (`--display-server`).
    viewer: Option<&'a Viewer<'a>>,
}

impl CpuRun<'_> {
    /// Renders (from `resume` where given), writing a checkpoint every `--checkpoint` seconds
    /// at the first pass boundary after it. A checkpoint that cannot be written (a full disk)
    /// stops the render and is the error: going on would spend the rest of it with nothing
    /// kept.
    fn render(
        &self,
        resume: Option<cpu::Resume>,
        backend: &str,
        progress: &(dyn Fn(u32, u32, f64) + Sync),
    ) -> Result<RenderOutput> {
        let (args, settings) = (self.args, self.settings);
        let mut last = std::time::Instant::now();
        let mut checkpoint_error = None;
        let mut observer = |view: &cpu::PassView| {
            if let Some(v) = self.viewer {
                v.pass(view.film);
            }
            let Some(every) = args.checkpoint else { return };
            if last.elapsed().as_secs_f64() < every || checkpoint_error.is_some() {
                return;
            }
            let meta = self.part.metadata(
                settings,
                view.spp,
                self.earlier + view.seconds,
                backend,
                None,
                true,
                self.features,
            );
            match write_exr_with_state(&args.output, view.film, &meta) {
                Ok(()) => eprintln!(
                    "checkpoint: {} at sample {}",
                    args.output.display(),
                    settings.sample_start + view.spp
                ),
                Err(e) => {
                    checkpoint_error = Some(e);
                    self.stop.store(true, Ordering::SeqCst);
                }
            }
            last = std::time::Instant::now();
        };
        let out = cpu::render_resumed(
            self.rs,
            settings,
            resume,
            self.stop,
            progress,
            &mut observer,
        );
        match checkpoint_error {
            Some(e) => Err(anyhow!(e).context("writing a checkpoint")),
            None => Ok(out),
        }
    }
}

fn write_outputs(
    args: &RenderArgs,
    part: &PartContext,
    settings: &RenderSettings,
    out: &RenderOutput,
    backend: &str,
    gpu_variant: Option<&str>,
) -> Result<()> {
    let meta = part.metadata(
        settings,
        out.spp,
        out.seconds,
        backend,
        gpu_variant,
        out.interrupted,
        out.features,
    );
    // With the accumulator state, so any render can be merged or resumed exactly.
    write_exr_with_state(&args.output, &out.film, &meta)?;
    let t = totals(&out.records);
    if let Some(path) = &args.tile_log {
        let mut w = TileLogWriter::create(path)?;
        for r in &out.records {
            w.append(r)?;
        }
        w.finish()?;
    }
    if let Some(path) = &args.cost_map {
        write_cost_map(
            path,
            settings.width,
            settings.height,
            &out.records,
            args.cost_metric.metric(),
            &meta,
        )?;
    }
    super::render_report::report_totals(&args.output, settings, out, &t);
    report_peak_memory();
    Ok(())
}

/// `on` or `off`.
fn parse_on_off(s: &str) -> Result<bool, String> {
    match s {
        "on" => Ok(true),
        "off" => Ok(false),
        other => Err(format!("'{other}' is not on or off")),
    }
}
