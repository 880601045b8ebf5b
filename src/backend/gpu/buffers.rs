//! Every buffer of a render ([`Buffers`]) and the kernels bound to them ([`Kernel`]): the
//! bindings each entry point uses come from naga's analysis, so a kernel binds only what it
//! reads and the storage-buffer limit is checked per stage.

use super::device::{GpuContext, GpuGrid};
use super::error::GpuRenderError;
use super::geometry::Geometry;
use super::graph::{Passes, Stage};
use super::media_lights::media_light_words;
use super::shader::{Module, Spec};
use super::upload::Textures;
use crate::gpu_types::{
    GpuEmissionParams, GpuEnvMap, GpuGridInfo, GpuHomogeneousMedium, GpuPathState, GpuPhase,
    GpuQueue, GpuShadowRay, GpuVdbMedium, GpuWavefrontCounters, GpuWavefrontParams,
    GPU_DATA_PASS_BYTES,
};
use crate::render::{blackbody, RenderScene};

/// Bytes of one sample buffer entry.
const SAMPLE_BYTES: u64 = std::mem::size_of::<crate::gpu_types::GpuSample>() as u64;

/// Wavefront iterations submitted together between two reads of the counters. Each read is
/// a host round trip (submit, map, wait: on a large GPU longer than an iteration's
/// kernels at 2^16 slots); a batch overshoots its end by fewer than this many empty
/// iterations. The timestamp query set holds two queries per stage for each of them.
pub(super) const ITERATIONS_PER_SYNC: u32 = 8;

/// A pipeline and its bind groups for both parities.
pub(super) struct Kernel {
    pub(super) pipeline: wgpu::ComputePipeline,
    pub(super) groups: [Vec<wgpu::BindGroup>; 2],
}

/// Every buffer of a render.
pub(super) struct Buffers {
    pub(super) params: [wgpu::Buffer; 2],
    pub(super) paths: wgpu::Buffer,
    pub(super) queues: wgpu::Buffer,
    pub(super) counters: wgpu::Buffer,
    pub(super) shadows: wgpu::Buffer,
    pub(super) lights: wgpu::Buffer,
    pub(super) samples: wgpu::Buffer,
    /// Where each batch's samples are copied for the host, kept for the whole render.
    pub(super) samples_readback: wgpu::Buffer,
    /// The light passes (`FEATURE_LIGHT_PASSES`) and the light groups (`FEATURE_LIGHT_GROUPS`)
    /// in one buffer: each path slot's accumulators and each camera sample's
    /// (`Passes::light_entries` each), with the latter's read-back; 16-byte stand-ins, never
    /// bound, without.
    pub(super) path_passes: wgpu::Buffer,
    pub(super) sample_passes: wgpu::Buffer,
    pub(super) sample_passes_readback: wgpu::Buffer,
    /// The data passes (`FEATURE_DATA_PASSES`): each path slot's `GpuDataPasses` and each
    /// camera sample's, with the latter's read-back; 16-byte stand-ins, never bound, without.
    pub(super) path_data: wgpu::Buffer,
    pub(super) sample_data: wgpu::Buffer,
    pub(super) sample_data_readback: wgpu::Buffer,
    pub(super) args: wgpu::Buffer,
    /// `GpuEmissionParams` (zero when the medium does not emit).
    pub(super) emission: wgpu::Buffer,
    /// `blackbody::table()` as vec4 rows, then the media lights' table ([`emission_tables`]).
    pub(super) emission_tables: wgpu::Buffer,
    /// obvhs' CWBVH nodes (one zero node when the scene has no triangles).
    pub(super) bvh_nodes: wgpu::Buffer,
    /// `GpuTriangle`s in the BVH's primitive order.
    pub(super) bvh_triangles: wgpu::Buffer,
    /// `GpuPlacement`s where the GPU keeps instancing (one zero entry otherwise).
    pub(super) bvh_placements: wgpu::Buffer,
    /// The scene's materials, as loaded.
    pub(super) materials: wgpu::Buffer,
    /// `GpuAreaLight`s: the area lights' selection CDF.
    pub(super) area_lights: wgpu::Buffer,
    /// `GpuTriangleUv`s, like `bvh_triangles`.
    pub(super) triangle_uvs: wgpu::Buffer,
    /// `GpuTexture`s, indexed like `Scene::textures`.
    pub(super) textures: wgpu::Buffer,
    /// The texel pool (linear RGBA).
    pub(super) texels: wgpu::Buffer,
    /// `GpuEnvMap` (uniform) and the map's pixels and distribution (`f32`s).
    pub(super) env_map: wgpu::Buffer,
    pub(super) env_data: wgpu::Buffer,
    /// `GpuHomogeneousMedium`s, indexed like `RenderScene::homogeneous`.
    pub(super) homogeneous: wgpu::Buffer,
    /// `GpuVdbMedium`s, indexed like `RenderScene::vdb` (the mixture variant; one zero entry
    /// otherwise).
    pub(super) vdb_media: wgpu::Buffer,
    /// Bound in place of the grid's buffers when the scene has no VDB medium (the kernels
    /// specialised without one never read them).
    pub(super) no_grid: (wgpu::Buffer, wgpu::Buffer),
    pub(super) readback: wgpu::Buffer,
    pub(super) timestamps: Option<(wgpu::QuerySet, wgpu::Buffer)>,
}

/// A storage buffer of `data`, or of one zeroed element where `data` is empty (a binding
/// holds at least one element; the kernels never read it then).
fn storage_at_least_one<T: bytemuck::Pod>(
    ctx: &GpuContext,
    label: &str,
    data: &[T],
) -> wgpu::Buffer {
    if data.is_empty() {
        ctx.storage_buffer(label, &[T::zeroed()])
    } else {
        ctx.storage_buffer(label, data)
    }
}

/// The emission's tables as words, four a row: the unit-luminance blackbody colours of
/// `blackbody::table()` (xyz; w unused), then the media lights' table of `rs`
/// (`super::media_lights`). One binding for both, so that no stage reaching the emission binds
/// one more storage buffer for the media lights. A storage buffer, not a uniform: with the
/// colours as a fifth uniform block, Mesa 22.3's lavapipe (Debian 12) reads and writes freed
/// memory compiling the generic variant's sample_medium stage. See
/// shaders/common/emission.wgsl.
fn emission_tables(ctx: &GpuContext, rs: &RenderScene) -> wgpu::Buffer {
    let mut words: Vec<u32> = blackbody::table()
        .iter()
        .flat_map(|c| [c.x.to_bits(), c.y.to_bits(), c.z.to_bits(), 0])
        .collect();
    words.extend(media_light_words(rs.media_lights.as_ref()));
    words.resize(words.len().next_multiple_of(4), 0);
    let b = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("emission tables"),
        size: (words.len() * 4) as u64,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    ctx.queue.write_buffer(&b, 0, bytemuck::cast_slice(&words));
    b
}

/// The query set of `n` stage timestamps and the buffer they resolve into.
fn stage_timestamps(ctx: &GpuContext, n: u32) -> (wgpu::QuerySet, wgpu::Buffer) {
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
}

impl Buffers {
    /// Allocates every buffer of a render of `rs` with `slots` path slots and a sample buffer
    /// of `samples` entries (and their `passes`' beside them), uploading what is known before
    /// the first batch.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn new(
        ctx: &GpuContext,
        rs: &RenderScene,
        params: &GpuWavefrontParams,
        slots: u32,
        samples: u64,
        passes: Passes,
        emission: &GpuEmissionParams,
        geometry: &Geometry,
        textures: &Textures,
        env_map: &(GpuEnvMap, Vec<f32>),
        vdb_media: &[GpuVdbMedium],
    ) -> Buffers {
        let timestamps = ctx.timestamp_queries;
        // The counters, then two timestamps per stage and iteration of one submission.
        let queries = 2 * Stage::COUNT as u32 * ITERATIONS_PER_SYNC;
        let readback_size = std::mem::size_of::<GpuWavefrontCounters>() as u64 + 8 * queries as u64;
        let pass_bytes = passes.light_entries() as u64 * 16;
        let data_bytes = if passes.data { GPU_DATA_PASS_BYTES } else { 0 };
        Buffers {
            params: [
                ctx.uniform_buffer("wavefront params 0", params),
                ctx.uniform_buffer("wavefront params 1", params),
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
            lights: storage_at_least_one(ctx, "lights", &rs.lights.punctual),
            samples: ctx.storage_buffer_zeroed("samples", samples * SAMPLE_BYTES),
            samples_readback: ctx.read_back_buffer("samples read-back", samples * SAMPLE_BYTES),
            path_passes: ctx.storage_buffer_zeroed("path light passes", slots as u64 * pass_bytes),
            sample_passes: ctx.storage_buffer_zeroed("sample light passes", samples * pass_bytes),
            sample_passes_readback: ctx.read_back_buffer(
                "sample light passes read-back",
                (samples * pass_bytes).max(16),
            ),
            path_data: ctx.storage_buffer_zeroed("path data passes", slots as u64 * data_bytes),
            sample_data: ctx.storage_buffer_zeroed("sample data passes", samples * data_bytes),
            sample_data_readback: ctx.read_back_buffer(
                "sample data passes read-back",
                (samples * data_bytes).max(16),
            ),
            emission: ctx.uniform_buffer("emission", emission),
            bvh_nodes: ctx.storage_buffer("bvh nodes", &geometry.nodes),
            bvh_triangles: ctx.storage_buffer("bvh triangles", &geometry.triangles),
            bvh_placements: ctx.storage_buffer("bvh placements", &geometry.placements),
            materials: storage_at_least_one(ctx, "materials", &rs.scene.materials),
            area_lights: ctx.storage_buffer("area lights", &geometry.area_lights),
            triangle_uvs: ctx.storage_buffer("triangle uvs", &geometry.triangle_uvs),
            textures: ctx.storage_buffer("textures", &textures.records),
            texels: ctx.storage_buffer("texels", &textures.texels),
            env_map: ctx.uniform_buffer("environment map", &env_map.0),
            env_data: ctx.storage_buffer("environment map data", &env_map.1),
            homogeneous: {
                let h: Vec<GpuHomogeneousMedium> = rs
                    .homogeneous
                    .iter()
                    .map(|m| GpuHomogeneousMedium {
                        sigma_a: m.sigma_a.to_array(),
                        g: m.phase.henyey_greenstein_g().unwrap_or(0.0),
                        sigma_s: m.sigma_s.to_array(),
                        _pad0: 0.0,
                        phase: GpuPhase::of(&m.phase),
                    })
                    .collect();
                storage_at_least_one(ctx, "homogeneous media", &h)
            },
            vdb_media: storage_at_least_one(ctx, "vdb media", vdb_media),
            no_grid: (
                ctx.uniform_buffer("no grid", &GpuGridInfo::default()),
                ctx.storage_buffer_zeroed("no grid data", 16),
            ),
            emission_tables: emission_tables(ctx, rs),
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
            timestamps: timestamps.then(|| stage_timestamps(ctx, queries)),
        }
    }

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
            (0, 6) => &self.emission_tables,
            (0, 7) => grid.map_or(no_data, |g| &g.voxels),
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
            (1, 13) => &self.triangle_uvs,
            (1, 14) => &self.textures,
            (1, 15) => &self.texels,
            (1, 16) => &self.env_map,
            (1, 17) => &self.env_data,
            (1, 18) => &self.vdb_media,
            (1, 19) => &self.path_passes,
            (1, 20) => &self.sample_passes,
            (1, 21) => &self.path_data,
            (1, 22) => &self.sample_data,
            (1, 23) => &self.bvh_placements,
            _ => return None,
        })
    }
}

pub(super) fn kernel(
    ctx: &GpuContext,
    module: &Module,
    specs: &[Spec],
    bufs: &Buffers,
    grid: Option<&GpuGrid>,
) -> Result<Kernel, GpuRenderError> {
    let dev = |e: String| GpuRenderError::Device(format!("{}: {e}", module.label));
    let (source, used) = module.checked_source(specs).map_err(dev)?;
    let storage = used.iter().filter(|b| !b.uniform).count() as u32;
    if storage > ctx.limits.max_storage_buffers_per_shader_stage {
        return Err(GpuRenderError::Limits(format!(
            "{} binds {storage} storage buffers; the device allows {} per stage",
            module.label, ctx.limits.max_storage_buffers_per_shader_stage
        )));
    }
    let pipeline = ctx.pipeline_from(module, source).map_err(dev)?;
    let max_group = used.iter().map(|b| b.group + 1).max().unwrap_or(0);
    let scope = ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
    let mut groups: [Vec<wgpu::BindGroup>; 2] = [Vec::new(), Vec::new()];
    for (parity, out) in groups.iter_mut().enumerate() {
        for g in 0..max_group {
            let mut entries = Vec::new();
            for b in used.iter().filter(|b| b.group == g) {
                let buffer = bufs.get(grid, parity, b.group, b.binding).ok_or_else(|| {
                    dev(format!(
                        "binding ({}, {}) has no buffer (no grid uploaded?)",
                        b.group, b.binding
                    ))
                })?;
                entries.push(wgpu::BindGroupEntry {
                    binding: b.binding,
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
