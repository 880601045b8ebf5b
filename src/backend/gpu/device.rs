//! The wgpu device and the few helpers the compute kernels need: storage buffers from slices,
//! one-shot dispatches with bind groups, and read-back.
//!
//! Everything here blocks (`pollster`): Brume is an offline renderer and submits large batches.
//! Errors a kernel can cause (validation of a module or a binding) are caught with error
//! scopes and returned as strings instead of reaching wgpu's default handler, which panics.
use super::shader::{Module, Spec};
use crate::gpu_types::{CellBounds, GpuGridInfo};
use crate::volume::grid::CONSTANT_BIT;
use crate::volume::{AdaptiveMajorants, LeafBounds, SparseGrid};
use bytemuck::Pod;
use std::fmt;

/// Why no GPU could be used: one line for the CPU-fallback message.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GpuUnavailable {
    pub reason: String,
    /// `true` when no adapter exists at all (as opposed to one that could not be used).
    pub no_adapter: bool,
}

impl fmt::Display for GpuUnavailable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.reason)
    }
}

impl std::error::Error for GpuUnavailable {}

/// A wgpu device and queue with what Brume needs to know about the adapter.
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub adapter_info: wgpu::AdapterInfo,
    /// The limits the device was created with (the adapter's storage-buffer sizes).
    pub limits: wgpu::Limits,
    /// `true` when timestamp queries (`Features::TIMESTAMP_QUERY`) were enabled.
    pub timestamp_queries: bool,
    /// WebGPU default limits the adapter does not reach (`"name have < default"`), for logs.
    pub limits_below_default: Vec<String>,
}

impl GpuContext {
    /// A device on the best Vulkan adapter (a real GPU, else a software one such as Mesa's
    /// llvmpipe), with the default WebGPU limits raised to the adapter's storage-buffer sizes.
    pub fn new() -> Result<GpuContext, GpuUnavailable> {
        let unavailable = |reason: String| GpuUnavailable {
            reason,
            no_adapter: false,
        };
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = wgpu::Backends::VULKAN;
        let instance = wgpu::Instance::new(desc);
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: None,
            apply_limit_buckets: false,
        }))
        .map_err(|e| GpuUnavailable {
            reason: format!("no Vulkan adapter found ({e})"),
            no_adapter: true,
        })?;
        let info = adapter.get_info();
        let supported = adapter.limits();
        // WebGPU's defaults, lowered where the adapter offers less (lavapipe, for one, is below
        // a few graphics limits a compute renderer never uses), then the storage sizes raised
        // to the adapter's. What Brume's kernels need is checked explicitly.
        let defaults = wgpu::Limits::default();
        let mut limits_below_default = Vec::new();
        defaults.check_limits_with_fail_fn(&supported, false, |name, want, have| {
            limits_below_default.push(format!("{name} {have} < {want}"));
        });
        // The wavefront stages with surfaces, media and passes bind up to 15 storage buffers;
        // WebGPU's default is 8, Vulkan drivers (lavapipe included) offer far more.
        let limits = wgpu::Limits {
            max_storage_buffer_binding_size: supported.max_storage_buffer_binding_size,
            max_buffer_size: supported.max_buffer_size,
            max_storage_buffers_per_shader_stage: supported
                .max_storage_buffers_per_shader_stage
                .min(16),
            ..defaults.or_worse_values_from(&supported)
        };
        for (name, have, need) in [
            ("max_bind_groups", limits.max_bind_groups, 2),
            (
                "max_storage_buffers_per_shader_stage",
                limits.max_storage_buffers_per_shader_stage,
                8,
            ),
            (
                "max_compute_invocations_per_workgroup",
                limits.max_compute_invocations_per_workgroup,
                64,
            ),
            (
                "max_compute_workgroups_per_dimension",
                limits.max_compute_workgroups_per_dimension,
                65535,
            ),
        ] {
            if have < need {
                return Err(unavailable(format!(
                    "adapter {}: {name} is {have}, Brume needs {need}",
                    info.name
                )));
            }
        }
        let timestamp_queries = adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let features = if timestamp_queries {
            wgpu::Features::TIMESTAMP_QUERY
        } else {
            wgpu::Features::empty()
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("brume"),
            required_features: features,
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| {
            unavailable(format!(
                "adapter {}: device request failed ({e})",
                info.name
            ))
        })?;
        Ok(GpuContext {
            device,
            queue,
            adapter_info: info,
            limits,
            timestamp_queries,
            limits_below_default,
        })
    }

    pub fn adapter_name(&self) -> &str {
        &self.adapter_info.name
    }

    /// One line describing the device, for logs.
    pub fn describe(&self) -> String {
        format!(
            "{} ({:?}, {:?}), {} MiB per storage binding, timestamp queries {}, below WebGPU \
             defaults: [{}]",
            self.adapter_info.name,
            self.adapter_info.device_type,
            self.adapter_info.backend,
            self.limits.max_storage_buffer_binding_size >> 20,
            if self.timestamp_queries { "yes" } else { "no" },
            self.limits_below_default.join(", ")
        )
    }

    /// A storage buffer holding `data` (also a copy source and destination). An empty slice
    /// gets 16 zero bytes, since a binding cannot be empty.
    pub fn storage_buffer<T: Pod>(&self, label: &str, data: &[T]) -> wgpu::Buffer {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let buffer = self.storage_buffer_zeroed(label, bytes.len() as u64);
        if !bytes.is_empty() {
            // Pod types made of u32/f32 are a whole number of 4-byte words, as required.
            self.queue.write_buffer(&buffer, 0, bytes);
        }
        buffer
    }

    /// A uniform buffer holding `value` (the `gpu_types` structs are 16-byte rows, as uniform
    /// layout requires).
    pub fn uniform_buffer<T: Pod>(&self, label: &str, value: &T) -> wgpu::Buffer {
        let bytes: &[u8] = bytemuck::bytes_of(value);
        let buffer = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: (bytes.len() as u64).next_multiple_of(16),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        self.queue.write_buffer(&buffer, 0, bytes);
        buffer
    }

    /// A zero-filled storage buffer of `size` bytes.
    pub fn storage_buffer_zeroed(&self, label: &str, size: u64) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: size.max(16).next_multiple_of(4),
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    /// Compiles `module` with `specs` into a compute pipeline (layout derived from the
    /// bindings the entry point uses). Validation errors are returned, not panicked on.
    pub fn pipeline(
        &self,
        module: &Module,
        specs: &[Spec],
    ) -> Result<wgpu::ComputePipeline, String> {
        // The binding rules every driver needs (`Module::bindings`), before the driver sees it.
        let (source, _) = module.checked_source(specs)?;
        self.pipeline_from(module, source)
    }

    /// [`GpuContext::pipeline`] from the source [`Module::checked_source`] gave.
    pub fn pipeline_from(
        &self,
        module: &Module,
        source: String,
    ) -> Result<wgpu::ComputePipeline, String> {
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let shader = self
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(module.label),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
        let pipeline = self
            .device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(module.label),
                layout: None,
                module: &shader,
                entry_point: Some(module.entry_point),
                compilation_options: Default::default(),
                cache: None,
            });
        match pollster::block_on(scope.pop()) {
            None => Ok(pipeline),
            Some(e) => Err(format!("module {}: {e}", module.label)),
        }
    }

    /// Runs `pipeline` once over `workgroups` workgroups along x and waits for it. Kernels
    /// index work with `global_invocation_id.x` only, so one dispatch covers at most
    /// `max_compute_workgroups_per_dimension` (65,535) workgroups: 4.19 M invocations at 64
    /// per workgroup; larger batches are split by the caller. `bindings` are
    /// `(group, binding, buffer)` and must be exactly those the entry point uses (the layout
    /// is derived from the shader).
    pub fn dispatch(
        &self,
        pipeline: &wgpu::ComputePipeline,
        bindings: &[(u32, u32, &wgpu::Buffer)],
        workgroups: u32,
    ) -> Result<(), String> {
        if workgroups > self.limits.max_compute_workgroups_per_dimension {
            return Err(format!(
                "{workgroups} workgroups exceed the limit of {} per dispatch",
                self.limits.max_compute_workgroups_per_dimension
            ));
        }
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let max_group = bindings.iter().map(|b| b.0).max().map_or(0, |g| g + 1);
        let groups: Vec<wgpu::BindGroup> = (0..max_group)
            .map(|g| {
                let entries: Vec<wgpu::BindGroupEntry> = bindings
                    .iter()
                    .filter(|b| b.0 == g)
                    .map(|&(_, binding, buffer)| wgpu::BindGroupEntry {
                        binding,
                        resource: buffer.as_entire_binding(),
                    })
                    .collect();
                self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: None,
                    layout: &pipeline.get_bind_group_layout(g),
                    entries: &entries,
                })
            })
            .collect();
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor::default());
            pass.set_pipeline(pipeline);
            for (g, group) in groups.iter().enumerate() {
                pass.set_bind_group(g as u32, group, &[]);
            }
            pass.dispatch_workgroups(workgroups, 1, 1);
        }
        self.queue.submit([encoder.finish()]);
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(e.to_string());
        }
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| e.to_string())?;
        Ok(())
    }

    /// Copies `buffer` back to the host as `T`s (the whole buffer, truncated to whole `T`s).
    pub fn read_buffer<T: Pod>(&self, buffer: &wgpu::Buffer) -> Vec<T> {
        let staging = self.read_back_buffer("read-back", buffer.size());
        self.read_buffer_prefix(buffer, &staging, buffer.size())
    }

    /// A host-readable buffer of `size` bytes to copy results into ([`Self::read_buffer_prefix`]).
    pub fn read_back_buffer(&self, label: &str, size: u64) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    /// Copies the first `size` bytes of `buffer` back to the host as `T`s through `staging`
    /// (a [`Self::read_back_buffer`] at least that large, kept across calls: a fresh staging
    /// buffer a batch cost its pages' first touch every time).
    pub fn read_buffer_prefix<T: Pod>(
        &self,
        buffer: &wgpu::Buffer,
        staging: &wgpu::Buffer,
        size: u64,
    ) -> Vec<T> {
        let size = size.min(buffer.size()).min(staging.size()) & !3;
        if size == 0 {
            return Vec::new();
        }
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        encoder.copy_buffer_to_buffer(buffer, 0, staging, 0, size);
        self.queue.submit([encoder.finish()]);
        let (tx, rx) = std::sync::mpsc::channel();
        staging.map_async(wgpu::MapMode::Read, ..size, move |r| {
            let _ = tx.send(r);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .expect("device lost while reading back");
        rx.recv()
            .expect("map callback dropped")
            .expect("buffer mapping failed");
        let data = staging.get_mapped_range(..size).expect("mapped");
        let n = data.len() / std::mem::size_of::<T>();
        let out = bytemuck::pod_collect_to_vec(&data[..n * std::mem::size_of::<T>()]);
        drop(data);
        staging.unmap();
        out
    }
}

/// A [`SparseGrid`] and its [`LeafBounds`] on the device, bound as group 0 of every kernel
/// that includes `grid.wgsl` (bindings 0-3) and `dda.wgsl` (bindings 4 and 7).
pub struct GpuGrid {
    pub info: GpuGridInfo,
    pub info_buffer: wgpu::Buffer,
    pub cells: wgpu::Buffer,
    pub bricks: wgpu::Buffer,
    pub constants: wgpu::Buffer,
    /// Per-cell bounds followed by the global bound (`info.global_bounds_index`) and the walk
    /// box ([`bounds_layout`]).
    pub bounds: wgpu::Buffer,
    /// Per-voxel culling bytes (`LeafBounds::voxel_q`) of the density grids whose walks thin
    /// by them, indexed by the shared bricks buffer's brick index (each grid's table at its
    /// bricks' place), four to a `u32`, byte `k` in bits `8 (k % 4)` of word `k / 4`; one
    /// zero word where there is none.
    pub voxels: wgpu::Buffer,
}

/// The storage buffer of per-voxel bounds `q` ([`pack_voxel_q`]), or why the device cannot
/// bind it.
fn voxel_buffer(ctx: &GpuContext, q: &[u8]) -> Result<wgpu::Buffer, String> {
    let words = pack_voxel_q(q);
    let limit = ctx.limits.max_storage_buffer_binding_size;
    if (words.len() * 4) as u64 > limit {
        return Err(format!(
            "the grid's per-voxel bounds need {}; the device binds at most {}",
            byte_size((words.len() * 4) as u64),
            byte_size(limit)
        ));
    }
    Ok(ctx.storage_buffer("grid voxel bounds", &words))
}

/// `LeafBounds::voxel_q` as the WGSL reads it (`grid_voxels`): four bytes to a word, little
/// end first; one zero word for an empty table (a binding cannot be empty).
pub fn pack_voxel_q(q: &[u8]) -> Vec<u32> {
    if q.is_empty() {
        return vec![0];
    }
    q.chunks(4)
        .map(|c| {
            c.iter()
                .enumerate()
                .fold(0u32, |w, (i, &b)| w | (b as u32) << (8 * i))
        })
        .collect()
}

impl GpuGrid {
    /// Uploads `grid` with `sigma_t = density_scale * value`. Fails when a buffer exceeds the
    /// device's storage-binding limit.
    pub fn upload(
        ctx: &GpuContext,
        grid: &SparseGrid,
        bounds: &LeafBounds,
        density_scale: f32,
    ) -> Result<GpuGrid, String> {
        Self::upload_adaptive(ctx, grid, bounds, None, density_scale)
    }

    /// [`GpuGrid::upload`] with the adaptive majorant hierarchy in the bounds buffer
    /// ([`AdaptiveMajorants::gpu_bounds`]), for `MAJORANT_ADAPTIVE` walks.
    pub fn upload_adaptive(
        ctx: &GpuContext,
        grid: &SparseGrid,
        bounds: &LeafBounds,
        adaptive: Option<&AdaptiveMajorants>,
        density_scale: f32,
    ) -> Result<GpuGrid, String> {
        Self::upload_with(
            ctx,
            grid,
            bounds,
            adaptive,
            density_scale,
            &crate::volume::voxel_bounds::floored_voxel_q(bounds, &grid.cells),
            &[],
        )
        .map(|(g, _)| g)
    }

    /// Uploads `grid` as [`GpuGrid::upload`] does, followed in the same cells, bricks and
    /// constants buffers by `extra` grids (emission and temperature), whose headers are
    /// returned: each has its [`GpuGridInfo::cell_offset`] and its brick and constant indices
    /// shifted past the grids before it, so the shaders read every grid through one set of
    /// bindings. The extra grids' `index_from_world` is their own; callers placing a grid in
    /// the world overwrite it. `voxels` are the per-voxel bounds bound for the density grid
    /// (its `voxel_q`, or none where its walks do not thin by them).
    pub fn upload_with(
        ctx: &GpuContext,
        grid: &SparseGrid,
        bounds: &LeafBounds,
        adaptive: Option<&AdaptiveMajorants>,
        density_scale: f32,
        voxels: &[u8],
        extra: &[&SparseGrid],
    ) -> Result<(GpuGrid, Vec<GpuGridInfo>), String> {
        let mut parts = vec![(grid, density_scale, Some(bounds_layout(bounds, adaptive)?))];
        parts.extend(extra.iter().map(|&g| (g, 1.0, None)));
        let (mut gg, placed) = Self::upload_many(ctx, &parts)?;
        gg.set_voxels(ctx, voxels)?;
        // The extra grids have no bounds.
        let infos = placed[1..]
            .iter()
            .map(|&(info, _)| GpuGridInfo {
                global_bounds_index: 0,
                ..info
            })
            .collect();
        Ok((gg, infos))
    }

    /// Binds `q`, per-voxel bounds (`LeafBounds::voxel_q`) laid out by the shared bricks
    /// buffer's brick index: the density grid's own table, or (the mixture) each thinning
    /// medium's table at its bricks' place. Fails when the table exceeds the device's
    /// storage-binding limit.
    pub fn set_voxels(&mut self, ctx: &GpuContext, q: &[u8]) -> Result<(), String> {
        self.voxels = voxel_buffer(ctx, q)?;
        Ok(())
    }

    /// Several grids in one set of buffers (the mixture variant's media): each of `grids`
    /// with `sigma_t = scale * value` and, when given, its bounds (one medium's layout:
    /// per-cell bounds, the global bound, the adaptive hierarchy) placed after the bounds of
    /// the grids before it. Returns each grid's header (its [`GpuGridInfo::cell_offset`],
    /// brick and constant indices shifted past the grids before it, `global_bounds_index`
    /// relative to its bounds) and the first entry of its bounds; the buffer set's own header
    /// is the first grid's. The headers' `index_from_world` is each grid's own.
    pub fn upload_many(
        ctx: &GpuContext,
        grids: &[(&SparseGrid, f32, Option<Vec<CellBounds>>)],
    ) -> Result<(GpuGrid, Vec<(GpuGridInfo, u32)>), String> {
        let limit = ctx.limits.max_storage_buffer_binding_size;
        let mut cells: Vec<u32> = Vec::new();
        let mut bricks: Vec<f32> = Vec::new();
        let mut constants: Vec<f32> = Vec::new();
        let mut bounds: Vec<CellBounds> = Vec::new();
        let mut out = Vec::with_capacity(grids.len());
        for (g, scale, b) in grids {
            let info = append_grid(g, *scale, &mut cells, &mut bricks, &mut constants)?;
            let base = u32::try_from(bounds.len())
                .map_err(|_| "the grids need more than 2^32 bounds".to_string())?;
            if let Some(b) = b {
                bounds.extend_from_slice(b);
            }
            out.push((info, base));
        }
        for (what, bytes) in [
            ("cells", cells.len() * 4),
            ("bricks", bricks.len() * 4),
            ("constants", constants.len() * 4),
            ("bounds", bounds.len() * 8),
        ] {
            if bytes as u64 > limit {
                return Err(format!(
                    "the grids need {} of {what} in one storage binding; the device binds at \
                     most {} (`--backend auto` renders it on the CPU)",
                    byte_size(bytes as u64),
                    byte_size(limit)
                ));
            }
        }
        // Bindings cannot be empty.
        if cells.is_empty() {
            cells.push(0);
        }
        for v in [&mut bricks, &mut constants] {
            if v.is_empty() {
                v.push(0.0);
            }
        }
        if bounds.is_empty() {
            bounds.push(CellBounds::point(0.0));
        }
        let info = out
            .first()
            .map_or(<GpuGridInfo as bytemuck::Zeroable>::zeroed(), |o| o.0);
        Ok((
            GpuGrid {
                info,
                info_buffer: ctx.uniform_buffer("grid info", &info),
                cells: ctx.storage_buffer("grid cells", &cells),
                bricks: ctx.storage_buffer("grid bricks", &bricks),
                constants: ctx.storage_buffer("grid constants", &constants),
                bounds: ctx.storage_buffer("grid bounds", &bounds),
                voxels: voxel_buffer(ctx, &[])?,
            },
            out,
        ))
    }

    /// The `(group, binding, buffer)` entries of group 0 for a kernel using the lookups
    /// (`with_lookups`) and/or the DDA bounds and per-voxel bounds (`with_bounds`).
    pub fn bindings(
        &self,
        with_lookups: bool,
        with_bounds: bool,
    ) -> Vec<(u32, u32, &wgpu::Buffer)> {
        let mut v = vec![(0, 0, &self.info_buffer)];
        if with_lookups {
            v.extend([
                (0, 1, &self.cells),
                (0, 2, &self.bricks),
                (0, 3, &self.constants),
            ]);
        }
        if with_bounds {
            // The walk's set-up reads the voxel table's length (dda.wgsl `dda_new`).
            v.extend([(0, 4, &self.bounds), (0, 7, &self.voxels)]);
        }
        v
    }
}

/// One medium's bounds as the DDA and the adaptive walk read them: the per-cell bounds, the
/// global bound and the walk box ([`LeafBounds::gpu_walk_box`]) after them, then (for
/// adaptive walks) the hierarchy
/// ([`AdaptiveMajorants::gpu_bounds`]).
pub fn bounds_layout(
    bounds: &LeafBounds,
    adaptive: Option<&AdaptiveMajorants>,
) -> Result<Vec<CellBounds>, String> {
    match adaptive {
        Some(a) => a.gpu_bounds(bounds),
        None => {
            let mut b = bounds.cells.clone();
            b.push(bounds.global);
            b.extend(bounds.gpu_walk_box());
            Ok(b)
        }
    }
}

/// Appends grid `g` to the shared `cells`, `bricks` and `constants` (its brick and constant
/// indices shifted past the grids before it) and returns its header with `cell_offset` set.
fn append_grid(
    g: &SparseGrid,
    density_scale: f32,
    cells: &mut Vec<u32>,
    bricks: &mut Vec<f32>,
    constants: &mut Vec<f32>,
) -> Result<GpuGridInfo, String> {
    let mut info = GpuGridInfo::new(g, density_scale);
    info.cell_offset = u32::try_from(cells.len())
        .map_err(|_| "the grids need more than 2^32 cells".to_string())?;
    let brick0 = (bricks.len() / 512) as u32;
    let const0 = constants.len() as u32;
    if (brick0 as u64 + g.brick_count() as u64) >= CONSTANT_BIT as u64
        || (const0 as u64 + g.constants.len() as u64) >= CONSTANT_BIT as u64
    {
        return Err("the grids need more than 2^31 bricks or constants".into());
    }
    cells.extend(g.cells.iter().map(|&e| {
        if e & CONSTANT_BIT != 0 {
            CONSTANT_BIT | ((e & !CONSTANT_BIT) + const0)
        } else {
            e + brick0
        }
    }));
    bricks.extend_from_slice(&g.bricks);
    constants.extend_from_slice(&g.constants);
    Ok(info)
}

/// `bytes` in the largest binary unit that keeps a digit before the point ("3.2 MiB").
pub fn byte_size(bytes: u64) -> String {
    let units = ["bytes", "KiB", "MiB", "GiB", "TiB"];
    let mut v = bytes as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < units.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{bytes} bytes")
    } else {
        format!("{v:.1} {}", units[u])
    }
}
