//! `brume bench gpu`: camera samples per second of the wavefront GPU integrator against the CPU
//! backend on one scene (default: the cloud example at 512x512, 4 spp), with the adapter's
//! name and the GPU time per stage. Prints; never asserts.
use std::path::Path;
use std::sync::atomic::AtomicBool;

use crate::backend::cpu;
use crate::backend::gpu::render::{render_with_timings, Stage};
use crate::backend::gpu::GpuContext;
use crate::render::{RenderScene, RenderSettings};
use anyhow::{anyhow, Result};

/// Renders `scene` at `width` x `height` with `spp` samples per pixel on the GPU, then on the
/// CPU, and prints samples per second for both.
pub fn run(scene: &Path, width: u32, height: u32, spp: u32) -> Result<()> {
    let scene = crate::scene::load(scene).map_err(|e| anyhow!("{e}"))?;
    let settings = RenderSettings {
        width,
        height,
        spp,
        ..RenderSettings::default()
    };
    let rs = RenderScene::new(&scene, false).map_err(|e| anyhow!(e))?;
    let samples = width as f64 * height as f64 * spp as f64;
    let stop = AtomicBool::new(false);
    match GpuContext::new() {
        Err(e) => println!("gpu: unavailable: {e}"),
        Ok(ctx) => {
            println!("gpu: {}", ctx.describe());
            let (out, t) = render_with_timings(&ctx, &rs, &settings, &stop, &|_, _, _| {})?;
            let stage_s: f64 = t.stage_totals().iter().sum::<u64>() as f64 * 1e-9;
            println!(
                "gpu: {width}x{height} {spp} spp in {:.2} s (kernels {:.2} s, {:?}): {:.3} M samples/s, variant {}",
                out.seconds,
                stage_s,
                t.source,
                samples / out.seconds * 1e-6,
                t.variant
            );
            for (s, ns) in Stage::ALL.iter().zip(t.stage_totals()) {
                println!("gpu:   {:<15} {:>9.1} ms", s.name(), ns as f64 * 1e-6);
            }
            // Where the rest goes: the iteration loop (kernels plus a host round trip per
            // iteration), the samples' readback and their merge into the film.
            let sum = |f: fn(&crate::backend::gpu::render::BatchTimings) -> u64| {
                t.batches.iter().map(f).sum::<u64>() as f64 * 1e-6
            };
            println!(
                "gpu: host: {} batches, {} iterations; iteration loop {:.1} ms, sample readback {:.1} ms, merge {:.1} ms",
                t.batches.len(),
                t.batches.iter().map(|b| b.iterations as u64).sum::<u64>(),
                sum(|b| b.loop_ns),
                sum(|b| b.readback_ns),
                sum(|b| b.merge_ns)
            );
        }
    }
    let out = cpu::render(&rs, &settings, &stop, &|_, _, _| {});
    println!(
        "cpu: {width}x{height} {spp} spp in {:.2} s on {} threads: {:.3} M samples/s",
        out.seconds,
        rayon::current_num_threads(),
        samples / out.seconds * 1e-6
    );
    Ok(())
}
