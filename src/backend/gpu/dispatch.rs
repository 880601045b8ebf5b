//! The scheduler: one batch of camera samples run to completion as wavefront iterations,
//! each iteration the stage kernels over their queues' indirect arguments (timed by GPU
//! timestamps or, without them, by the host clock around each stage submitted alone).
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use super::buffers::{Buffers, Kernel, ITERATIONS_PER_SYNC};
use super::device::GpuContext;
use super::error::GpuRenderError;
use super::graph::{Passes, Stage};
use crate::gpu_types::{
    GpuDataPasses, GpuQueue, GpuSample, GpuWavefrontCounters, GpuWavefrontParams,
    GPU_DATA_PASS_BYTES,
};

/// The scheduler: the kernels of one render and the loop over iterations.
pub(super) struct Wavefront<'a> {
    pub(super) ctx: &'a GpuContext,
    pub(super) bufs: &'a Buffers,
    pub(super) kernels: Vec<(Stage, Kernel)>,
    pub(super) reset: Kernel,
    pub(super) args: Kernel,
    pub(super) slots: u32,
    pub(super) period_ns: f64,
    /// The passes the kernels keep (`FEATURE_LIGHT_PASSES`, `FEATURE_DATA_PASSES`,
    /// `FEATURE_LIGHT_GROUPS`): a batch then reads its samples' passes back too.
    pub(super) passes: Passes,
}

/// A finished batch's camera samples, in batch entry order; where the light passes or the
/// light groups are kept their `Passes::light_entries` RGB values each (w unused: the light
/// passes, then the groups), entry by entry, and where the data passes are, one
/// `GpuDataPasses` each; empty without.
pub(super) struct BatchSamples {
    pub(super) samples: Vec<GpuSample>,
    pub(super) passes: Vec<[f32; 4]>,
    pub(super) data: Vec<GpuDataPasses>,
}

/// The counters after the batch, its iterations, the stages' times, its samples, and the host
/// wall time of the iteration loop and of the samples' readback (ns).
pub(super) type BatchResult = (
    GpuWavefrontCounters,
    u32,
    [u64; Stage::COUNT],
    BatchSamples,
    (u64, u64),
);

impl Wavefront<'_> {
    pub(super) fn run_batch(
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
        let loop_start = Instant::now();
        loop {
            if stop.load(Ordering::Relaxed) {
                return Ok(None);
            }
            let scope = ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
            let c = self.iterations(iteration, ITERATIONS_PER_SYNC, &mut stage_ns)?;
            if let Some(e) = pollster::block_on(scope.pop()) {
                return Err(dev(e.to_string()));
            }
            iteration += ITERATIONS_PER_SYNC;
            if c.queue_overflows != 0 {
                return Err(dev(format!(
                    "wavefront queue overflow after {iteration} iterations: {} pushes past a \
                     queue's {} slots were refused",
                    c.queue_overflows, self.slots
                )));
            }
            if c.live == 0 && c.next_sample >= params.total_samples {
                counters = c;
                break;
            }
            // Every live path waits in the medium queue the next iteration reads; none there
            // means a path was lost between stages: stop instead of spinning.
            let next_medium = if iteration & 1 == 1 {
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
        let loop_ns = loop_start.elapsed().as_nanos() as u64;
        let readback_start = Instant::now();
        // Only the batch's own entries: the buffer is sized for the largest batch.
        let samples: Vec<GpuSample> = ctx.read_buffer_prefix(
            &self.bufs.samples,
            &self.bufs.samples_readback,
            params.total_samples as u64 * size_of::<GpuSample>() as u64,
        );
        let entries = self.passes.light_entries() as u64;
        let passes: Vec<[f32; 4]> = if entries > 0 {
            ctx.read_buffer_prefix(
                &self.bufs.sample_passes,
                &self.bufs.sample_passes_readback,
                params.total_samples as u64 * entries * 16,
            )
        } else {
            Vec::new()
        };
        let data: Vec<GpuDataPasses> = if self.passes.data {
            ctx.read_buffer_prefix(
                &self.bufs.sample_data,
                &self.bufs.sample_data_readback,
                params.total_samples as u64 * GPU_DATA_PASS_BYTES,
            )
        } else {
            Vec::new()
        };
        let readback_ns = readback_start.elapsed().as_nanos() as u64;
        Ok(Some((
            counters,
            iteration,
            stage_ns,
            BatchSamples {
                samples,
                passes,
                data,
            },
            (loop_ns, readback_ns),
        )))
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

    /// Runs iterations `first .. first + k` in one submission and returns the counters after
    /// the last: the host waits once per `k` iterations, not once per iteration. Iterations
    /// past a batch's end cost only their empty dispatches (every stage's workgroup count
    /// comes from its queue, then empty).
    fn iterations(
        &self,
        first: u32,
        k: u32,
        stage_ns: &mut [u64; Stage::COUNT],
    ) -> Result<GpuWavefrontCounters, GpuRenderError> {
        let ctx = self.ctx;
        let gpu_timing = self.bufs.timestamps.is_some();
        let new_encoder = || {
            ctx.device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None })
        };
        let mut encoder = new_encoder();
        let stages = self.kernels.len() as u32;
        for j in 0..k {
            let parity = (first + j) & 1;
            self.encode(&mut encoder, &self.reset, parity, None, None);
            for (i, (stage, kernel)) in self.kernels.iter().enumerate() {
                let s = Stage::ALL.iter().position(|s| s == stage).unwrap();
                if stage.needs_args() {
                    self.encode(&mut encoder, &self.args, parity, None, None);
                }
                let q = stage.input_queue(parity);
                if gpu_timing {
                    let query = j * stages + i as u32;
                    self.encode(&mut encoder, kernel, parity, Some(q), Some(query));
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
                    stage_ns[s] += t.elapsed().as_nanos() as u64;
                }
            }
        }
        encoder.copy_buffer_to_buffer(
            &self.bufs.counters,
            0,
            &self.bufs.readback,
            0,
            std::mem::size_of::<GpuWavefrontCounters>() as u64,
        );
        // Only the queries of the dispatched stages were written.
        let n = 2 * stages * k;
        if let Some((set, resolve)) = &self.bufs.timestamps {
            encoder.resolve_query_set(set, 0..n, resolve, 0);
            // After the counters (the timestamps once overwrote the last wide counter).
            encoder.copy_buffer_to_buffer(resolve, 0, &self.bufs.readback, TS_OFFSET, n as u64 * 8);
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
            let at = TS_OFFSET as usize;
            let ts: &[u64] = bytemuck::cast_slice(&data[at..at + n as usize * 8]);
            for j in 0..k as usize {
                for (i, (stage, _)) in self.kernels.iter().enumerate() {
                    let s = Stage::ALL.iter().position(|s| s == stage).unwrap();
                    let q = j * stages as usize + i;
                    let dt = ts[2 * q + 1].saturating_sub(ts[2 * q]);
                    stage_ns[s] += (dt as f64 * self.period_ns) as u64;
                }
            }
        }
        drop(data);
        self.bufs.readback.unmap();
        Ok(counters)
    }
}

/// Where the stage timestamps start in the read-back buffer: after the counters.
const TS_OFFSET: u64 = std::mem::size_of::<GpuWavefrontCounters>() as u64;
const _: () = assert!(TS_OFFSET % 8 == 0);

fn wait(ctx: &GpuContext) -> Result<(), GpuRenderError> {
    ctx.device
        .poll(wgpu::PollType::wait_indefinitely())
        .map(|_| ())
        .map_err(|e| GpuRenderError::Device(e.to_string()))
}
