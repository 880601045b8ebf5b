//! The wavefront path tracer on wgpu: the same physics as `integrator::path::radiance`,
//! scheduled as a graph of kernels over queues of paths (Laine et al. 2013, "Megakernels
//! considered harmful"; pbrt-v4's and Cycles' GPU integrators).
//!
//! The stages are named once, in [`Stage`]; each is one WGSL entry point in its own file under
//! `shaders/stages/`, opening with a comment that names the Rust code it mirrors. A fixed number
//! of path slots ([`WAVEFRONT_SIZE`]) holds [`GpuPathState`]s; a stage consumes the slots in its
//! input queue and appends each to the queue of the stage that handles it next. Queue lengths
//! live in atomic counters and become `dispatch_workgroups_indirect` arguments on the GPU
//! (`kernels/queues.wgsl`), so the host only reads two counters per iteration to know when a
//! batch is finished. Finished slots are regenerated with the batch's next camera sample until
//! every pixel of the batch has its samples.
//!
//! One iteration (parity `p` picks the double-buffered medium and done queues):
//!
//! ```text
//! reset -> Generate -> Intersect -> SampleMedium -> ScatterMedium -> ShadeSurface
//!       -> TraceShadow -> SamplePhase -> Escape -> Accumulate
//! ```
//!
//! Each path keeps its own stream `Rng::new(pixel, sample, seed)` and draws from it in the
//! CPU's order (the shadow stage runs before the direction stage for that reason). The
//! fixed-layout decisions (jitter, light selection and sample, lobe, direction, roulette) come
//! from `shaders/common/sobol.wgsl` by dimension block when `settings.sampler` is Sobol (the
//! `SAMPLER_SOBOL` specialisation), the path's pixel and sample index following from its batch
//! entry, so the path state does not grow. Results agree
//! with the CPU statistically, and with the same seed nearly bit for bit (rounding of WGSL's
//! transcendentals may flip a rare decision).
//!
//! What runs: everything the CPU integrator does for one VDB medium (every estimator, both
//! majorant modes, spectral tracking of chromatic media, volume emission), homogeneous media
//! in closed meshes (grey and chromatic), opaque, dielectric and null-interface surfaces over
//! obvhs' CWBVH, punctual, environment and area lights with NEE and MIS, Russian roulette and
//! the collision guard. [`supports`] refuses more than one VDB medium with a one-line reason.
//! The scene's [`FeatureFlags`] choose the stages ([`Stage::for_features`]) and the WGSL
//! variant ([`variant_name`]): the code of a missing feature is cut at assembly.
//!
//! Timing: one compute pass per stage dispatch. With timestamp queries
//! ([`GpuContext::timestamp_queries`]) each pass records its GPU start and end
//! ([`TimingSource::TimestampQueries`]); without them every stage is submitted alone and timed
//! on the host's clock ([`TimingSource::WallClock`]).
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use bytemuck::Zeroable;
use glam::Vec3;

use super::device::{byte_size, GpuContext, GpuGrid};
use super::shader::{self, Module, Spec};
use crate::backend::cpu::{pass_sizes, Progress, RenderOutput};
use crate::film::{Film, TileRecord, TileRect};
use crate::gpu_types::{
    GpuAreaLight, GpuControlMode, GpuEmissionParams, GpuEstimator, GpuGridInfo,
    GpuHomogeneousMedium, GpuMajorantMode, GpuPathState, GpuQueue, GpuShadowRay, GpuTrackingParams,
    GpuTriangle, GpuWavefrontCounters, GpuWavefrontParams, GpuWideCounter, SURFACE_DIELECTRIC,
    SURFACE_NULL, SURFACE_OPAQUE,
};
use crate::integrator::blackbody;
use crate::integrator::media::{GridField, TrackingConfig, VdbMedium};
use crate::integrator::prepare::SurfaceKind;
use crate::integrator::settings::Absorption;
use crate::integrator::{
    Estimator, FeatureFlags, MajorantMode, RenderScene, RenderSettings, SamplerKind,
};
use crate::volume::SparseGrid;

/// Path slots in flight.
pub const WAVEFRONT_SIZE: u32 = 1 << 16;

/// Camera samples per batch at most (one sample buffer entry of 16 bytes each).
pub const MAX_BATCH_SAMPLES: u64 = 1 << 22;

/// The wavefront stages, in the order an iteration runs them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Stage {
    /// Camera rays for free slots (`tile::render_tile`, `Camera::generate_ray`).
    Generate,
    /// The first surface along each ray (`TriangleBvh::closest_hit` over obvhs' CWBVH).
    Intersect,
    /// Free flight up to that surface through the homogeneous medium the path is in or the
    /// VDB medium it crosses (`path::sample_media`, `media::sample_vdb`,
    /// `media::sample_homogeneous`), gathering volume emission.
    SampleMedium,
    /// Depth limit and next-event estimation at a medium scattering event.
    ScatterMedium,
    /// Emission, null interfaces, smooth dielectrics and next-event estimation at opaque
    /// surfaces (the surface half of `path::radiance`).
    ShadeSurface,
    /// Shadow-ray transmittance through media and null interfaces (`path::transmittance`).
    TraceShadow,
    /// The next direction (phase function or BSDF) and Russian roulette.
    SamplePhase,
    /// Environment light for rays that leave the scene.
    Escape,
    /// A finished path's radiance to its camera sample's entry.
    Accumulate,
}

impl Stage {
    pub const COUNT: usize = 9;
    pub const ALL: [Stage; Stage::COUNT] = [
        Stage::Generate,
        Stage::Intersect,
        Stage::SampleMedium,
        Stage::ScatterMedium,
        Stage::ShadeSurface,
        Stage::TraceShadow,
        Stage::SamplePhase,
        Stage::Escape,
        Stage::Accumulate,
    ];

    pub fn name(self) -> &'static str {
        self.module().label
    }

    /// The WGSL module (its last file is the stage's, its entry point the stage's).
    pub fn module(self) -> Module {
        match self {
            Stage::Generate => shader::STAGE_GENERATE_MODULE,
            Stage::Intersect => shader::STAGE_INTERSECT_MODULE,
            Stage::SampleMedium => shader::STAGE_SAMPLE_MEDIUM_MODULE,
            Stage::ScatterMedium => shader::STAGE_SCATTER_MEDIUM_MODULE,
            Stage::ShadeSurface => shader::STAGE_SHADE_SURFACE_MODULE,
            Stage::TraceShadow => shader::STAGE_TRACE_SHADOW_MODULE,
            Stage::SamplePhase => shader::STAGE_SAMPLE_PHASE_MODULE,
            Stage::Escape => shader::STAGE_ESCAPE_MODULE,
            Stage::Accumulate => shader::STAGE_ACCUMULATE_MODULE,
        }
    }

    /// The queue the stage consumes in an iteration of parity `parity`. (The intersect stage
    /// only annotates the paths of the medium queue, which the medium stage then consumes.)
    pub fn input_queue(self, parity: u32) -> GpuQueue {
        let pick = |a: GpuQueue, b: GpuQueue| if parity == 0 { a } else { b };
        match self {
            Stage::Generate => pick(GpuQueue::Done0, GpuQueue::Done1),
            Stage::Intersect | Stage::SampleMedium => pick(GpuQueue::Medium0, GpuQueue::Medium1),
            Stage::ScatterMedium => GpuQueue::Scatter,
            Stage::ShadeSurface => GpuQueue::Surface,
            Stage::TraceShadow => GpuQueue::Shadow,
            Stage::SamplePhase => GpuQueue::Phase,
            Stage::Escape => GpuQueue::Escape,
            Stage::Accumulate => pick(GpuQueue::Done1, GpuQueue::Done0),
        }
    }

    /// Whether the indirect arguments must be recomputed before this stage: a stage since
    /// the last computation may have appended to its input queue. (The phase queue is
    /// complete when the shadow stage's arguments are computed, whatever the stage list: only
    /// the scatter and surface stages, both earlier, append to it.)
    fn needs_args(self) -> bool {
        self != Stage::SamplePhase
    }

    /// The stages a scene with `features` needs: kernels for effects the scene lacks are not
    /// dispatched (no intersection or surface shading without surfaces, no medium scattering
    /// without media, nothing between generation and escape with neither).
    pub fn for_features(features: FeatureFlags) -> Vec<Stage> {
        let media = features.heterogeneous || features.homogeneous;
        let surfaces = features.surfaces;
        Stage::ALL
            .into_iter()
            .filter(|s| match s {
                Stage::Generate | Stage::Escape | Stage::Accumulate => true,
                Stage::Intersect | Stage::ShadeSurface => surfaces,
                Stage::ScatterMedium => media,
                Stage::SampleMedium | Stage::TraceShadow | Stage::SamplePhase => media || surfaces,
            })
            .collect()
    }
}

/// How [`GpuTimings`] were measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimingSource {
    /// GPU timestamps at the start and end of each stage's compute pass.
    TimestampQueries,
    /// Host clock around each stage submitted alone and waited for.
    WallClock,
}

/// Per-stage GPU time of one batch.
#[derive(Clone, Debug, PartialEq)]
pub struct BatchTimings {
    /// Index into [`RenderOutput::records`].
    pub record: usize,
    /// Wavefront iterations the batch took.
    pub iterations: u32,
    /// Nanoseconds per stage, in [`Stage::ALL`] order (0 for stages not dispatched).
    pub stage_ns: [u64; Stage::COUNT],
}

/// Timings of a GPU render, per batch and stage.
#[derive(Clone, Debug, PartialEq)]
pub struct GpuTimings {
    pub source: TimingSource,
    pub batches: Vec<BatchTimings>,
    /// The WGSL variant: the features the kernels were specialised for.
    pub variant: String,
    pub adapter: String,
}

impl GpuTimings {
    /// Nanoseconds per stage over the whole render.
    pub fn stage_totals(&self) -> [u64; Stage::COUNT] {
        let mut t = [0u64; Stage::COUNT];
        for b in &self.batches {
            for (a, x) in t.iter_mut().zip(b.stage_ns) {
                *a += x;
            }
        }
        t
    }
}

/// Why the GPU did not render.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum GpuRenderError {
    /// The scene needs a feature the GPU integrator does not have (one line, for the CPU
    /// fallback message).
    #[error("GPU backend: {0}")]
    Unsupported(String),
    /// The scene's data exceed the device's limits.
    #[error("GPU backend: {0}")]
    Limits(String),
    /// wgpu reported an error (validation, device).
    #[error("GPU backend: {0}")]
    Device(String),
}

/// Whether the GPU integrator renders `rs` exactly as the CPU would, else a one-line reason.
pub fn supports(rs: &RenderScene) -> Result<(), String> {
    if rs
        .lights
        .environment
        .as_ref()
        .is_some_and(|e| e.map.is_some())
    {
        return Err("an environment map; the GPU integrator samples a constant sky only".into());
    }
    if rs.vdb.len() > 1 {
        return Err(format!(
            "{} VDB media; the GPU integrator binds one grid",
            rs.vdb.len()
        ));
    }
    if rs.scene.triangles.len() >= crate::scene::NO_INDEX as usize {
        return Err(format!(
            "{} triangles; the GPU integrator indexes fewer than 2^32",
            rs.scene.triangles.len()
        ));
    }
    Ok(())
}

/// The WGSL variant name of `features`: the effects the kernels are specialised for, in
/// `FeatureFlags` order (`surfaces`, `vdb`, `homogeneous`, `emission`, `spectral`), e.g.
/// `wavefront[surfaces+vdb+emission]`.
pub fn variant_name(features: FeatureFlags) -> String {
    let f = effective(features);
    let on: Vec<&str> = [
        (f.surfaces, "surfaces"),
        (f.heterogeneous, "vdb"),
        (f.homogeneous, "homogeneous"),
        (f.emission, "emission"),
        (f.chromatic, "spectral"),
    ]
    .into_iter()
    .filter(|(b, _)| *b)
    .map(|(_, n)| n)
    .collect();
    if on.is_empty() {
        "wavefront[empty]".into()
    } else {
        format!("wavefront[{}]", on.join("+"))
    }
}

/// The flags the kernels are specialised for: `features` less what cannot apply (emission
/// and spectral tracking need a medium).
fn effective(features: FeatureFlags) -> FeatureFlags {
    let media = features.heterogeneous || features.homogeneous;
    FeatureFlags {
        emission: features.emission && features.heterogeneous,
        chromatic: features.chromatic && media,
        absorption: features.absorption && media,
        ..features
    }
}

fn specs(features: FeatureFlags, sampler: SamplerKind) -> Vec<Spec> {
    let f = effective(features);
    vec![
        Spec::bool("SAMPLER_SOBOL", sampler == SamplerKind::Sobol),
        Spec::bool("FEATURE_SURFACES", f.surfaces),
        Spec::bool("FEATURE_HOMOGENEOUS", f.homogeneous),
        Spec::bool("FEATURE_HETEROGENEOUS", f.heterogeneous),
        Spec::bool("FEATURE_CHROMATIC", f.chromatic),
        Spec::bool("FEATURE_EMISSION", f.emission),
    ]
}

/// The `(group, binding)` pairs `module`'s entry point uses, from naga's analysis (the same
/// one wgpu derives the pipeline layout from).
fn used_bindings(module: &Module, specs: &[Spec]) -> Result<Vec<(u32, u32)>, String> {
    let source = module.source(specs);
    let m = naga::front::wgsl::parse_str(&source).map_err(|e| e.emit_to_string(&source))?;
    let info = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::default(),
    )
    .validate(&m)
    .map_err(|e| e.emit_to_string(&source))?;
    let ep = m
        .entry_points
        .iter()
        .position(|e| e.name == module.entry_point)
        .ok_or_else(|| format!("no entry point {}", module.entry_point))?;
    let fi = info.get_entry_point(ep);
    Ok(m.global_variables
        .iter()
        .filter(|(h, _)| !fi[*h].is_empty())
        .filter_map(|(_, v)| v.binding.as_ref().map(|b| (b.group, b.binding)))
        .collect())
}

/// A pipeline and its bind groups for both parities.
struct Kernel {
    pipeline: wgpu::ComputePipeline,
    groups: [Vec<wgpu::BindGroup>; 2],
}

/// Every buffer of a render.
struct Buffers {
    params: [wgpu::Buffer; 2],
    paths: wgpu::Buffer,
    queues: wgpu::Buffer,
    counters: wgpu::Buffer,
    shadows: wgpu::Buffer,
    lights: wgpu::Buffer,
    samples: wgpu::Buffer,
    args: wgpu::Buffer,
    /// `GpuEmissionParams` (zero when the medium does not emit).
    emission: wgpu::Buffer,
    /// `blackbody::table()` as vec4 rows.
    blackbody: wgpu::Buffer,
    /// obvhs' CWBVH nodes (one zero node when the scene has no triangles).
    bvh_nodes: wgpu::Buffer,
    /// `GpuTriangle`s in the BVH's primitive order.
    bvh_triangles: wgpu::Buffer,
    /// The scene's materials, as loaded.
    materials: wgpu::Buffer,
    /// `GpuAreaLight`s: the area lights' selection CDF.
    area_lights: wgpu::Buffer,
    /// `GpuHomogeneousMedium`s, indexed like `RenderScene::homogeneous`.
    homogeneous: wgpu::Buffer,
    /// Bound in place of the grid's buffers when the scene has no VDB medium (the kernels
    /// specialised without one never read them).
    no_grid: (wgpu::Buffer, wgpu::Buffer),
    readback: wgpu::Buffer,
    timestamps: Option<(wgpu::QuerySet, wgpu::Buffer)>,
}

impl Buffers {
    fn get<'a>(
        &'a self,
        grid: Option<&'a GpuGrid>,
        parity: usize,
        g: u32,
        b: u32,
    ) -> Option<&'a wgpu::Buffer> {
        let (no_info, no_data) = &self.no_grid;
        Some(match (g, b) {
            (0, 0) => grid.map_or(no_info, |g| &g.info_buffer),
            (0, 1) => grid.map_or(no_data, |g| &g.cells),
            (0, 2) => grid.map_or(no_data, |g| &g.bricks),
            (0, 3) => grid.map_or(no_data, |g| &g.constants),
            (0, 4) => grid.map_or(no_data, |g| &g.bounds),
            (0, 5) => &self.emission,
            (0, 6) => &self.blackbody,
            (1, 0) => &self.params[parity],
            (1, 1) => &self.paths,
            (1, 2) => &self.queues,
            (1, 3) => &self.counters,
            (1, 4) => &self.shadows,
            (1, 5) => &self.lights,
            (1, 6) => &self.samples,
            (1, 7) => &self.args,
            (1, 8) => &self.bvh_nodes,
            (1, 9) => &self.bvh_triangles,
            (1, 10) => &self.materials,
            (1, 11) => &self.area_lights,
            (1, 12) => &self.homogeneous,
            _ => return None,
        })
    }
}

fn kernel(
    ctx: &GpuContext,
    module: &Module,
    specs: &[Spec],
    bufs: &Buffers,
    grid: Option<&GpuGrid>,
) -> Result<Kernel, GpuRenderError> {
    let dev = |e: String| GpuRenderError::Device(format!("{}: {e}", module.label));
    let pipeline = ctx.pipeline(module, specs).map_err(dev)?;
    let used = used_bindings(module, specs).map_err(dev)?;
    // Every binding but the uniforms (grid header, emission, blackbody table, params) is a
    // storage buffer.
    let storage = used
        .iter()
        .filter(|u| !matches!(u, (0, 0) | (0, 5) | (0, 6) | (1, 0)))
        .count() as u32;
    if storage > ctx.limits.max_storage_buffers_per_shader_stage {
        return Err(GpuRenderError::Limits(format!(
            "{} binds {storage} storage buffers; the device allows {} per stage",
            module.label, ctx.limits.max_storage_buffers_per_shader_stage
        )));
    }
    let max_group = used.iter().map(|u| u.0 + 1).max().unwrap_or(0);
    let scope = ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
    let mut groups: [Vec<wgpu::BindGroup>; 2] = [Vec::new(), Vec::new()];
    for (parity, out) in groups.iter_mut().enumerate() {
        for g in 0..max_group {
            let mut entries = Vec::new();
            for &(ug, ub) in used.iter().filter(|u| u.0 == g) {
                let buffer = bufs.get(grid, parity, ug, ub).ok_or_else(|| {
                    dev(format!(
                        "binding ({ug}, {ub}) has no buffer (no grid uploaded?)"
                    ))
                })?;
                entries.push(wgpu::BindGroupEntry {
                    binding: ub,
                    resource: buffer.as_entire_binding(),
                });
            }
            out.push(ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(module.label),
                layout: &pipeline.get_bind_group_layout(g),
                entries: &entries,
            }));
        }
    }
    if let Some(e) = pollster::block_on(scope.pop()) {
        return Err(dev(e.to_string()));
    }
    Ok(Kernel { pipeline, groups })
}

fn affine_rows(m: glam::Affine3A) -> [[f32; 4]; 3] {
    let (a, t) = (m.matrix3, m.translation);
    let row = |r: usize| [a.col(0)[r], a.col(1)[r], a.col(2)[r], t[r]];
    [row(0), row(1), row(2)]
}

/// The estimator ids and tracking parameters of `rs`'s medium under `cfg`, as the CPU's
/// `sample_vdb` / `transmittance_vdb` choose them.
fn medium_params(
    rs: &RenderScene,
    cfg: &TrackingConfig,
    features: FeatureFlags,
    p: &mut GpuWavefrontParams,
) {
    let Some(m) = rs.vdb.first() else { return };
    let bound = m.sigma_t_bound;
    if bound.is_nan() || bound <= 0.0 {
        return;
    }
    let spectral = features.chromatic && (!m.grey || cfg.force_spectral);
    let weight = cfg.absorption == Absorption::Weight;
    // GreyView: the grey sigma_s per unit density is the channel mean (absorption as an
    // event) or sigma_t (as a weight: the trackers see no absorption).
    let sigma_s = if weight {
        bound
    } else {
        (m.sigma_s.x + m.sigma_s.y + m.sigma_s.z) / 3.0
    };
    // GreyView: sigma_a = max(sigma_t - sigma_s, 0) per unit density when any medium absorbs.
    let albedo = if features.absorption {
        sigma_s / bound
    } else {
        1.0
    };
    let (control_mode, control_value) = GpuControlMode::from_control(cfg.control());
    let estimator = if spectral {
        GpuEstimator::Spectral
    } else {
        match cfg.estimator {
            Estimator::Delta => GpuEstimator::Delta,
            Estimator::WeightedDelta => GpuEstimator::WeightedDelta,
            Estimator::Decomposition => GpuEstimator::Decomposition,
            Estimator::WeightedDecomposition => GpuEstimator::WeightedDecomposition,
        }
    };
    let residual = cfg.residual_shadow();
    let shadow = if spectral {
        GpuEstimator::Spectral
    } else if residual {
        GpuEstimator::ResidualRatio
    } else {
        GpuEstimator::Ratio
    };
    let sigma_t = m.sigma_a + m.sigma_s;
    let per_channel = |num: Vec3, den: Vec3| {
        Vec3::select(den.cmpgt(Vec3::ZERO), num / den, Vec3::ZERO).to_array()
    };
    p.has_medium = 1;
    p.medium_lo = m.world_bounds.min.to_array();
    p.medium_hi = m.world_bounds.max.to_array();
    p.phase_g = m.phase.g;
    p.spectral = spectral as u32;
    // The RGB factor of a scattering event: GreyView::scatter_albedo, or RgbView's
    // scatter_albedo for spectral tracking (the albedo with absorption as a weight, else 1);
    // albedo_rgb splits spectral lookups as RgbView's coefficients do.
    (p.scatter_albedo, p.albedo_rgb) = match (spectral, weight) {
        (true, true) => (per_channel(m.sigma_s, sigma_t), [1.0; 3]),
        (true, false) => ([1.0; 3], per_channel(m.sigma_s, sigma_t)),
        (false, _) if sigma_s > 0.0 => ((m.sigma_s / sigma_s).to_array(), [0.0; 3]),
        (false, _) => ([0.0; 3], [0.0; 3]),
    };
    p.shadow_estimator = shadow as u32;
    p.tracking = GpuTrackingParams {
        estimator: estimator as u32,
        majorant_mode: match cfg.majorant {
            MajorantMode::Leaf => GpuMajorantMode::PerCell,
            MajorantMode::Global => GpuMajorantMode::Global,
            MajorantMode::Adaptive => GpuMajorantMode::Adaptive,
        } as u32,
        control_mode: control_mode as u32,
        spectral_mode: 0,
        b: cfg.b(),
        control_value,
        albedo,
        control_albedo: sigma_s / bound,
        channel_scale: (sigma_t / bound).to_array(),
        seed: 0,
        majorant_channel_scale: 1.0,
        samples_per_ray: 0,
        invocation_count: 0,
        _pad0: 0,
    };
}

/// The scene's surfaces as the GPU reads them: obvhs' CWBVH nodes, the triangles in its
/// primitive order and the area lights' selection CDF (each at least one element: a binding
/// cannot be empty; a zero node has no children, so traversal ends at once).
struct Geometry {
    nodes: Vec<obvhs::cwbvh::node::CwBvhNode>,
    triangles: Vec<GpuTriangle>,
    area_lights: Vec<GpuAreaLight>,
}

impl Geometry {
    fn new(rs: &RenderScene) -> Result<Geometry, String> {
        let scene = rs.scene;
        let mut g = Geometry {
            nodes: vec![bytemuck::Zeroable::zeroed()],
            triangles: vec![GpuTriangle::zeroed()],
            area_lights: vec![GpuAreaLight::zeroed()],
        };
        let Some(bvh) = scene.bvh.cwbvh() else {
            return Ok(g);
        };
        // Selection density of each area light, by scene triangle.
        let mut light_pdf = vec![0.0f32; scene.triangles.len()];
        if let Some(area) = &rs.lights.area {
            for (i, &t) in area.triangles.iter().enumerate() {
                light_pdf[t as usize] = area.selection_pdf(i);
            }
        }
        let mut slot_of = vec![crate::scene::NO_INDEX; scene.triangles.len()];
        let mut triangles = Vec::with_capacity(bvh.primitive_indices.len());
        for (slot, &t) in bvh.primitive_indices.iter().enumerate() {
            let t = t as usize;
            let tri = scene.triangles.get(t).ok_or_else(|| {
                format!("the BVH names triangle {t} of {}", scene.triangles.len())
            })?;
            slot_of[t] = slot as u32;
            let [p0, p1, p2] = scene.triangle_corners(t);
            let n = |k: usize| scene.vertices[tri.vertices[k] as usize].normal;
            let material = scene.instances[tri.instance as usize].material;
            triangles.push(GpuTriangle {
                p0: p0.to_array(),
                triangle: t as u32,
                p1: p1.to_array(),
                material,
                p2: p2.to_array(),
                light_pdf: light_pdf[t],
                n0: n(0),
                kind: match rs.kinds[material as usize] {
                    SurfaceKind::Opaque => SURFACE_OPAQUE,
                    SurfaceKind::Dielectric => SURFACE_DIELECTRIC,
                    SurfaceKind::Null => SURFACE_NULL,
                },
                n1: n(1),
                interior: scene.materials[material as usize].interior_medium,
                n2: n(2),
                _pad0: 0,
            });
        }
        if bvh.nodes.is_empty() || triangles.is_empty() {
            return Ok(g);
        }
        let mut area_lights = Vec::new();
        if let Some(area) = &rs.lights.area {
            for (&t, &cdf) in area.triangles.iter().zip(area.cdf()) {
                let prim = slot_of[t as usize];
                if prim == crate::scene::NO_INDEX {
                    return Err(format!(
                        "emissive triangle {t} is not in the BVH; the GPU cannot sample it"
                    ));
                }
                area_lights.push(GpuAreaLight { cdf, prim });
            }
        }
        g.nodes = bvh.nodes.clone();
        g.triangles = triangles;
        if !area_lights.is_empty() {
            g.area_lights = area_lights;
        }
        Ok(g)
    }
}

/// The grids the emission of `m` reads, in the order [`emission_params`] expects them: the
/// emission grid, then the temperature grid (none when `features` has no emission).
fn emission_fields(m: &VdbMedium, features: FeatureFlags) -> Vec<GridField> {
    let Some(e) = m.emission.as_ref().filter(|_| features.emission) else {
        return Vec::new();
    };
    e.grid
        .iter()
        .cloned()
        .chain(e.blackbody.as_ref().map(|b| b.temperature.clone()))
        .collect()
}

/// `GpuEmissionParams` of `m`'s `Emission`, with the headers of the grids
/// [`emission_fields`] listed.
fn emission_params(
    m: &VdbMedium,
    features: FeatureFlags,
    infos: &[GpuGridInfo],
) -> GpuEmissionParams {
    let mut p = GpuEmissionParams::default();
    let Some(e) = m.emission.as_ref().filter(|_| features.emission) else {
        return p;
    };
    let mut next = infos.iter();
    p.strength_color = e.strength_color.to_array();
    if e.grid.is_some() {
        p.grid = *next.next().expect("emission grid uploaded");
        p.has_grid = 1;
    }
    if let Some(b) = &e.blackbody {
        p.temperature = *next.next().expect("temperature grid uploaded");
        p.has_blackbody = 1;
        p.tint = b.tint.to_array();
        p.temperature_scale = b.scale;
        p.temperature_offset = b.offset;
        p.intensity = b.intensity;
    }
    p
}

/// Renders `rs` on the GPU; see [`render_with_timings`].
pub fn render(
    ctx: &GpuContext,
    rs: &RenderScene,
    settings: &RenderSettings,
    stop: &AtomicBool,
    progress: Progress,
) -> Result<RenderOutput, GpuRenderError> {
    render_with_timings(ctx, rs, settings, stop, progress).map(|(out, _)| out)
}

/// Renders `rs` on the GPU in the CPU backend's passes (1, 1, 2, 4, ... samples per pixel),
/// each pass in batches of whole rows (one [`TileRecord`] per batch, its rectangle the rows,
/// `wall_ns` the batch's host time). Returns per-stage timings alongside.
pub fn render_with_timings(
    ctx: &GpuContext,
    rs: &RenderScene,
    settings: &RenderSettings,
    stop: &AtomicBool,
    progress: Progress,
) -> Result<(RenderOutput, GpuTimings), GpuRenderError> {
    let start = Instant::now();
    supports(rs).map_err(GpuRenderError::Unsupported)?;
    settings.validate().map_err(GpuRenderError::Unsupported)?;
    // As on the CPU: the generic variant has every feature on.
    let features = if settings.generic {
        FeatureFlags::ALL
    } else {
        rs.features
    };
    let cfg = TrackingConfig::from_settings(settings);
    let (w, h) = (settings.width, settings.height);
    let limit = ctx.limits.max_storage_buffer_binding_size;

    // The grid, with the medium's own world -> index map and sigma_t per unit value.
    let mut emission = GpuEmissionParams::default();
    let grid = match rs.vdb.first() {
        Some(m) if features.heterogeneous => {
            let g = &m.density.grid;
            let bounds_bytes = (g.bounds.cells.len() as u64 + 1) * 8;
            if bounds_bytes > limit {
                return Err(GpuRenderError::Limits(format!(
                    "the grid's bounds need {}; the device binds at most {}",
                    byte_size(bounds_bytes),
                    byte_size(limit)
                )));
            }
            // The emission grids follow the density in the same buffers.
            let fields = emission_fields(m, features);
            let extra: Vec<&SparseGrid> = fields.iter().map(|f| &f.grid.grid).collect();
            let (mut gg, mut infos) = GpuGrid::upload_with(
                ctx,
                &g.grid,
                &g.bounds,
                (cfg.majorant == MajorantMode::Adaptive).then_some(&*m.adaptive),
                m.sigma_t_bound,
                &extra,
            )
            .map_err(GpuRenderError::Limits)?;
            gg.info.index_from_world = affine_rows(m.density.index_from_world);
            ctx.queue
                .write_buffer(&gg.info_buffer, 0, bytemuck::bytes_of(&gg.info));
            for (info, f) in infos.iter_mut().zip(&fields) {
                info.index_from_world = affine_rows(f.index_from_world);
            }
            emission = emission_params(m, features, &infos);
            Some(gg)
        }
        _ => None,
    };

    // Batches: whole rows, at most MAX_BATCH_SAMPLES samples and one storage binding.
    let max_batch = MAX_BATCH_SAMPLES.min(limit / 16).max(1);
    let batch_max_samples = |n: u32| -> u64 {
        let rows = (max_batch / (w as u64 * n as u64)).clamp(1, h as u64);
        rows * w as u64 * n as u64
    };
    let target = if settings.spp == 0 {
        u32::MAX
    } else {
        settings.spp
    };
    let largest = pass_sizes(target.min(1 << 16), settings.max_pass_spp)
        .map(|(_, n)| batch_max_samples(n))
        .max()
        .unwrap_or(1);
    if largest * 16 > limit {
        return Err(GpuRenderError::Limits(format!(
            "one row of {w} pixels at {} samples per pass needs {} of sample buffer; the device binds {}",
            settings.max_pass_spp,
            byte_size(largest * 16),
            byte_size(limit)
        )));
    }
    let slots = (WAVEFRONT_SIZE as u64).min(largest) as u32;

    let mut params = GpuWavefrontParams {
        camera: affine_rows(glam::Affine3A::from_mat4(rs.scene.camera.world_from_camera)),
        tan_half: (0.5 * rs.scene.camera.yfov).tan(),
        aspect: w as f32 / h as f32,
        znear: rs.scene.camera.znear,
        seed: settings.seed,
        forward: rs.scene.camera.forward().to_array(),
        width: w,
        height: h,
        path_count: slots,
        light_count: rs.lights.punctual.len() as u32,
        env: rs
            .lights
            .environment
            .as_ref()
            .map_or(Vec3::ZERO, |e| e.radiance)
            .to_array(),
        env_pdf: rs.lights.pdf_environment(Vec3::Z),
        max_depth: settings.max_depth,
        rr_depth: settings.rr_depth,
        rr_throughput: settings.rr_throughput,
        absorption_weight: (settings.absorption == Absorption::Weight) as u32,
        max_collisions: settings.max_collisions_per_path.min(u32::MAX as u64) as u32,
        has_env: rs.lights.environment.is_some() as u32,
        camera_medium: rs.camera_medium.unwrap_or(crate::scene::NO_INDEX),
        ..Default::default()
    };
    let geometry = Geometry::new(rs).map_err(GpuRenderError::Unsupported)?;
    params.area_count = rs
        .lights
        .area
        .as_ref()
        .map_or(0, |a| a.triangles.len() as u32);
    if features.heterogeneous {
        medium_params(rs, &cfg, features, &mut params);
    }

    let timestamps = ctx.timestamp_queries;
    let stages = Stage::for_features(features);
    // The counters, then two timestamps per stage.
    let readback_size = (std::mem::size_of::<GpuWavefrontCounters>() + 16 * Stage::COUNT) as u64;
    let bufs = Buffers {
        params: [
            ctx.uniform_buffer("wavefront params 0", &params),
            ctx.uniform_buffer("wavefront params 1", &params),
        ],
        paths: ctx.storage_buffer_zeroed(
            "paths",
            slots as u64 * std::mem::size_of::<GpuPathState>() as u64,
        ),
        queues: ctx.storage_buffer_zeroed("queues", GpuQueue::COUNT as u64 * slots as u64 * 4),
        counters: ctx.storage_buffer_zeroed(
            "counters",
            std::mem::size_of::<GpuWavefrontCounters>() as u64,
        ),
        shadows: ctx.storage_buffer_zeroed(
            "shadow rays",
            slots as u64 * std::mem::size_of::<GpuShadowRay>() as u64,
        ),
        // A binding holds at least one element: an unused zero light when there are none.
        lights: if rs.lights.punctual.is_empty() {
            ctx.storage_buffer("lights", &[crate::scene::PunctualLight::zeroed()])
        } else {
            ctx.storage_buffer("lights", &rs.lights.punctual)
        },
        samples: ctx.storage_buffer_zeroed("samples", largest * 16),
        emission: ctx.uniform_buffer("emission", &emission),
        bvh_nodes: ctx.storage_buffer("bvh nodes", &geometry.nodes),
        bvh_triangles: ctx.storage_buffer("bvh triangles", &geometry.triangles),
        materials: if rs.scene.materials.is_empty() {
            ctx.storage_buffer("materials", &[crate::scene::Material::zeroed()])
        } else {
            ctx.storage_buffer("materials", &rs.scene.materials)
        },
        area_lights: ctx.storage_buffer("area lights", &geometry.area_lights),
        homogeneous: {
            let mut h: Vec<GpuHomogeneousMedium> = rs
                .homogeneous
                .iter()
                .map(|m| GpuHomogeneousMedium {
                    sigma_a: m.sigma_a.to_array(),
                    g: m.phase.g,
                    sigma_s: m.sigma_s.to_array(),
                    _pad0: 0.0,
                })
                .collect();
            if h.is_empty() {
                h.push(GpuHomogeneousMedium::zeroed());
            }
            ctx.storage_buffer("homogeneous media", &h)
        },
        no_grid: (
            ctx.uniform_buffer("no grid", &GpuGridInfo::default()),
            ctx.storage_buffer_zeroed("no grid data", 16),
        ),
        blackbody: {
            let rows: Vec<[f32; 4]> = blackbody::table()
                .iter()
                .map(|c| [c.x, c.y, c.z, 0.0])
                .collect();
            let b = ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("blackbody table"),
                size: (rows.len() * 16) as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            ctx.queue.write_buffer(&b, 0, bytemuck::cast_slice(&rows));
            b
        },
        args: ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("dispatch args"),
            size: GpuQueue::COUNT as u64 * 12,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::INDIRECT,
            mapped_at_creation: false,
        }),
        readback: ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("counters read-back"),
            size: readback_size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        }),
        timestamps: timestamps.then(|| {
            let n = 2 * Stage::ALL.len() as u32;
            (
                ctx.device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some("stage timestamps"),
                    ty: wgpu::QueryType::Timestamp,
                    count: n,
                }),
                ctx.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("timestamps"),
                    size: n as u64 * 8,
                    usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                }),
            )
        }),
    };
    let sp = specs(features, settings.sampler);
    let g = grid.as_ref();
    let mut kernels = Vec::new();
    for &s in &stages {
        kernels.push((s, kernel(ctx, &s.module(), &sp, &bufs, g)?));
    }
    let reset = kernel(ctx, &shader::QUEUE_RESET_MODULE, &sp, &bufs, g)?;
    let args = kernel(ctx, &shader::QUEUE_ARGS_MODULE, &sp, &bufs, g)?;

    let mut wave = Wavefront {
        ctx,
        bufs: &bufs,
        kernels,
        reset,
        args,
        slots,
        period_ns: ctx.queue.get_timestamp_period() as f64,
    };
    let mut film = Film::new(w, h);
    let mut records = Vec::new();
    let mut batches = Vec::new();
    let mut lookups = vec![0u64; (w * h) as usize];
    let mut spp = 0u32;
    let mut interrupted = false;
    'passes: for (pass, (s0, n)) in pass_sizes(target, settings.max_pass_spp).enumerate() {
        if stop.load(Ordering::Relaxed)
            || settings
                .time_limit
                .is_some_and(|t| start.elapsed().as_secs_f64() >= t)
        {
            interrupted = true;
            break;
        }
        let rows = (batch_max_samples(n) / (w as u64 * n as u64)) as u32;
        let mut pending = Vec::new();
        let mut y0 = 0;
        let mut tile = 0;
        while y0 < h {
            let y1 = (y0 + rows).min(h);
            let batch_start = Instant::now();
            params.pixel0 = y0 * w;
            params.s0 = s0;
            params.spp_batch = n;
            params.total_samples = (y1 - y0) * w * n;
            let Some((counters, iterations, stage_ns, samples)) = wave.run_batch(&params, stop)?
            else {
                interrupted = true;
                break 'passes;
            };
            let rect = TileRect {
                x0: 0,
                y0,
                x1: w,
                y1,
                index: tile,
            };
            let mut r = TileRecord::new(pass as u32, &rect);
            r.samples = params.total_samples as u64;
            r.wall_ns = batch_start.elapsed().as_nanos() as u64;
            r.density_lookups = counters.wide(GpuWideCounter::Lookups);
            r.null_collisions = counters.wide(GpuWideCounter::NullCollisions);
            r.real_collisions = counters.wide(GpuWideCounter::RealCollisions)
                + counters.wide(GpuWideCounter::ControlCollisions);
            r.shadow_lookups = counters.wide(GpuWideCounter::ShadowLookups);
            r.path_length_sum = counters.wide(GpuWideCounter::DepthSum);
            r.emission_lookups = counters.wide(GpuWideCounter::EmissionLookups);
            r.majorant_segments = counters.wide(GpuWideCounter::Segments);
            r.shadow_segments = counters.wide(GpuWideCounter::ShadowSegments);
            r.guard_fired = counters.guard_fired as u64;
            r.majorant_violations = counters.majorant_violations as u64;
            pending.push((r, iterations, stage_ns, samples, y0, y1));
            tile += 1;
            y0 = y1;
        }
        // The pass is complete: merge it (an interrupted pass is dropped, as on the CPU).
        for (r, iterations, stage_ns, samples, y0, y1) in pending {
            let mut k = 0;
            for y in y0..y1 {
                for x in 0..w {
                    for _ in 0..n {
                        let s: [f32; 4] = samples[k];
                        film.add_sample(x, y, [s[0], s[1], s[2]]);
                        lookups[(y * w + x) as usize] += s[3].to_bits() as u64;
                        k += 1;
                    }
                }
            }
            batches.push(BatchTimings {
                record: records.len(),
                iterations,
                stage_ns,
            });
            records.push(r);
        }
        spp += n;
        progress(spp, settings.spp, start.elapsed().as_secs_f64());
    }
    let out = RenderOutput {
        film,
        records,
        lookups,
        spp,
        seconds: start.elapsed().as_secs_f64(),
        features,
        interrupted,
    };
    let timings = GpuTimings {
        source: if timestamps {
            TimingSource::TimestampQueries
        } else {
            TimingSource::WallClock
        },
        batches,
        variant: variant_name(features),
        adapter: ctx.adapter_name().to_string(),
    };
    Ok((out, timings))
}

/// The scheduler: the kernels of one render and the loop over iterations.
struct Wavefront<'a> {
    ctx: &'a GpuContext,
    bufs: &'a Buffers,
    kernels: Vec<(Stage, Kernel)>,
    reset: Kernel,
    args: Kernel,
    slots: u32,
    period_ns: f64,
}

type BatchResult = (
    GpuWavefrontCounters,
    u32,
    [u64; Stage::COUNT],
    Vec<[f32; 4]>,
);

impl Wavefront<'_> {
    fn run_batch(
        &mut self,
        params: &GpuWavefrontParams,
        stop: &AtomicBool,
    ) -> Result<Option<BatchResult>, GpuRenderError> {
        let ctx = self.ctx;
        let dev = |e: String| GpuRenderError::Device(e);
        for parity in 0..2u32 {
            let p = GpuWavefrontParams { parity, ..*params };
            ctx.queue.write_buffer(
                &self.bufs.params[parity as usize],
                0,
                bytemuck::bytes_of(&p),
            );
        }
        // Every slot free: the done queue of parity 0 lists them all.
        let mut counters = GpuWavefrontCounters::default();
        counters.queue_count[GpuQueue::Done0 as usize] = self.slots;
        ctx.queue
            .write_buffer(&self.bufs.counters, 0, bytemuck::bytes_of(&counters));
        let slots: Vec<u32> = (0..self.slots).collect();
        ctx.queue.write_buffer(
            &self.bufs.queues,
            GpuQueue::Done0 as u64 * self.slots as u64 * 4,
            bytemuck::cast_slice(&slots),
        );
        let mut stage_ns = [0u64; Stage::COUNT];
        let mut iteration = 0u32;
        loop {
            if stop.load(Ordering::Relaxed) {
                return Ok(None);
            }
            let parity = iteration & 1;
            let scope = ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
            let c = self.iteration(parity, &mut stage_ns)?;
            if let Some(e) = pollster::block_on(scope.pop()) {
                return Err(dev(e.to_string()));
            }
            iteration += 1;
            if c.live == 0 && c.next_sample >= params.total_samples {
                counters = c;
                break;
            }
            // Every live path waits in the medium queue the next iteration reads; none there
            // means a path was lost between stages: stop instead of spinning.
            let next_medium = if parity == 0 {
                GpuQueue::Medium1
            } else {
                GpuQueue::Medium0
            };
            if c.live > 0 && c.queue_count[next_medium as usize] == 0 {
                return Err(dev(format!(
                    "wavefront stalled after {iteration} iterations: {} live paths in no queue",
                    c.live
                )));
            }
        }
        let mut samples: Vec<[f32; 4]> = ctx.read_buffer(&self.bufs.samples);
        samples.truncate(params.total_samples as usize);
        Ok(Some((counters, iteration, stage_ns, samples)))
    }

    /// One compute pass: `kernel` over `workgroups` (direct) or the indirect arguments of
    /// `queue`, with timestamps at `query` when timing on the GPU.
    fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        kernel: &Kernel,
        parity: u32,
        queue: Option<GpuQueue>,
        query: Option<u32>,
    ) {
        let timestamp_writes = match (&self.bufs.timestamps, query) {
            (Some((set, _)), Some(q)) => Some(wgpu::ComputePassTimestampWrites {
                query_set: set,
                beginning_of_pass_write_index: Some(2 * q),
                end_of_pass_write_index: Some(2 * q + 1),
            }),
            _ => None,
        };
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: None,
            timestamp_writes,
        });
        pass.set_pipeline(&kernel.pipeline);
        for (g, group) in kernel.groups[parity as usize].iter().enumerate() {
            pass.set_bind_group(g as u32, group, &[]);
        }
        match queue {
            Some(q) => pass.dispatch_workgroups_indirect(&self.bufs.args, q as u64 * 12),
            None => pass.dispatch_workgroups(1, 1, 1),
        }
    }

    /// Runs one iteration and returns the counters after it.
    fn iteration(
        &self,
        parity: u32,
        stage_ns: &mut [u64; Stage::COUNT],
    ) -> Result<GpuWavefrontCounters, GpuRenderError> {
        let ctx = self.ctx;
        let gpu_timing = self.bufs.timestamps.is_some();
        let new_encoder = || {
            ctx.device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None })
        };
        let mut encoder = new_encoder();
        self.encode(&mut encoder, &self.reset, parity, None, None);
        for (i, (stage, kernel)) in self.kernels.iter().enumerate() {
            let k = Stage::ALL.iter().position(|s| s == stage).unwrap();
            if stage.needs_args() {
                self.encode(&mut encoder, &self.args, parity, None, None);
            }
            let q = stage.input_queue(parity);
            if gpu_timing {
                self.encode(&mut encoder, kernel, parity, Some(q), Some(i as u32));
            } else {
                // Host timing: submit what came before, then this stage alone.
                ctx.queue
                    .submit([std::mem::replace(&mut encoder, new_encoder()).finish()]);
                wait(ctx)?;
                let t = Instant::now();
                self.encode(&mut encoder, kernel, parity, Some(q), None);
                ctx.queue
                    .submit([std::mem::replace(&mut encoder, new_encoder()).finish()]);
                wait(ctx)?;
                stage_ns[k] += t.elapsed().as_nanos() as u64;
            }
        }
        encoder.copy_buffer_to_buffer(
            &self.bufs.counters,
            0,
            &self.bufs.readback,
            0,
            std::mem::size_of::<GpuWavefrontCounters>() as u64,
        );
        if let Some((set, resolve)) = &self.bufs.timestamps {
            // Only the queries of the dispatched stages were written.
            let n = 2 * self.kernels.len() as u32;
            encoder.resolve_query_set(set, 0..n, resolve, 0);
            encoder.copy_buffer_to_buffer(resolve, 0, &self.bufs.readback, 128, n as u64 * 8);
        }
        ctx.queue.submit([encoder.finish()]);
        let (tx, rx) = std::sync::mpsc::channel();
        self.bufs
            .readback
            .map_async(wgpu::MapMode::Read, .., move |r| {
                let _ = tx.send(r);
            });
        wait(ctx)?;
        rx.recv()
            .map_err(|e| GpuRenderError::Device(e.to_string()))?
            .map_err(|e| GpuRenderError::Device(e.to_string()))?;
        let data = self.bufs.readback.get_mapped_range(..).expect("mapped");
        let counters: GpuWavefrontCounters =
            bytemuck::pod_read_unaligned(&data[..std::mem::size_of::<GpuWavefrontCounters>()]);
        if gpu_timing {
            let ts: &[u64] = bytemuck::cast_slice(&data[128..128 + 2 * 8 * Stage::ALL.len()]);
            for (i, (stage, _)) in self.kernels.iter().enumerate() {
                let k = Stage::ALL.iter().position(|s| s == stage).unwrap();
                let dt = ts[2 * i + 1].saturating_sub(ts[2 * i]);
                stage_ns[k] += (dt as f64 * self.period_ns) as u64;
            }
        }
        drop(data);
        self.bufs.readback.unmap();
        Ok(counters)
    }
}

fn wait(ctx: &GpuContext) -> Result<(), GpuRenderError> {
    ctx.device
        .poll(wgpu::PollType::wait_indefinitely())
        .map(|_| ())
        .map_err(|e| GpuRenderError::Device(e.to_string()))
}
