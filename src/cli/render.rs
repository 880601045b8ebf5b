//! `brume render`: a scene file to an EXR, with tile logs and a cost map.
use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use anyhow::{anyhow, Context, Result};

use brume::backend::cpu::{self, RenderOutput};
use brume::farm::context::PartContext;
use brume::film::passes::PassLayers;
use brume::film::{totals, write_cost_map, write_exr_with_state, Film, TileLogWriter};
use brume::render::light_groups::LightGroups;
use brume::render::{RenderScene, RenderSettings};
use brume::scene::{self, LoadOptions};

pub use super::render_args::{thread_count, Backend, RenderArgs};
use super::viewer::{self, Viewer};

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
            eprintln!("gpu geometry: {}", timings.geometry);
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
