//! `brume render`'s arguments and the render settings they make.
use std::path::PathBuf;

use anyhow::{anyhow, Result};
use clap::Args;

use brume::film::CostMetric;
use brume::render::{
    Absorption, BlackbodyModel, Estimator, MajorantMode, RenderSettings, SamplerKind,
    ShadowEstimator,
};
use brume::scene::{self, SceneRenderSettings};

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
    /// Russian roulette also before the 8th bounce, from the 3rd on, once the throughput's
    /// largest channel is below this (0 disables; default 0.5).
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
    /// them, bvh (and the GPU) a two-level BVH. The render prints which it used.
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

/// `on` or `off`.
fn parse_on_off(s: &str) -> Result<bool, String> {
    match s {
        "on" => Ok(true),
        "off" => Ok(false),
        other => Err(format!("'{other}' is not on or off")),
    }
}
