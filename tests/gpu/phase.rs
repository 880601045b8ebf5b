//! The WGSL Henyey-Greenstein mirror (shaders/common/phase.wgsl) against `HenyeyGreenstein`:
//! sampled directions, pdfs and evaluations agree to rounding (WGSL's sin/cos/sqrt are not
//! the CPU's libm, so not bit for bit; on a GPU, to the precision of its built-ins).
use crate::common;

use brume::backend::gpu::shader::TEST_PHASE_MODULE;
use brume::volume::check::SplitMix64;
use brume::volume::phase::HenyeyGreenstein;
use glam::{Vec2, Vec3};

#[test]
fn wgsl_hg_matches_cpu() {
    let Some(ctx) = common::gpu::gpu_or_skip("gpu_phase") else {
        return;
    };
    let pipeline = ctx.pipeline(&TEST_PHASE_MODULE, &[]).unwrap();
    let mut rng = SplitMix64(0x9A5E);
    let gs = [
        -0.99f32, -0.9, -0.5, -0.1, 0.0, 0.1, 0.3, 0.5, 0.8, 0.9, 0.99,
    ];
    let n = 50_000;
    let mut inputs: Vec<[f32; 4]> = Vec::with_capacity(2 * n);
    let mut cases = Vec::with_capacity(n);
    for i in 0..n {
        let g = gs[i % gs.len()];
        let u = Vec2::new(rng.uniform() as f32, rng.uniform() as f32);
        let z = rng.range(-1.0, 1.0) as f32;
        let phi = rng.range(0.0, std::f64::consts::TAU) as f32;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let wo = Vec3::new(r * phi.cos(), r * phi.sin(), z).normalize();
        inputs.push([g, u.x, u.y, 0.0]);
        inputs.push([wo.x, wo.y, wo.z, 0.0]);
        cases.push((g, u, wo));
    }
    let input = ctx.storage_buffer("inputs", &inputs);
    let out = ctx.storage_buffer_zeroed("outputs", inputs.len() as u64 * 16);
    ctx.dispatch(
        &pipeline,
        &[(0, 0, &input), (0, 1, &out)],
        (n as u32).div_ceil(64),
    )
    .unwrap();
    let gpu: Vec<[f32; 4]> = ctx.read_buffer(&out);
    let (mut max_dir, mut max_pdf_rel, mut max_p_rel) = (0.0f32, 0.0f32, 0.0f32);
    for (i, &(g, u, wo)) in cases.iter().enumerate() {
        let hg = HenyeyGreenstein::new(g);
        let s = hg.sample(wo, u);
        let (wi_gpu, pdf_gpu) = (Vec3::from_slice(&gpu[2 * i][..3]), gpu[2 * i][3]);
        let p_gpu = gpu[2 * i + 1][0];
        max_dir = max_dir.max((wi_gpu - s.wi).length());
        max_pdf_rel = max_pdf_rel.max((pdf_gpu - s.pdf).abs() / s.pdf);
        // Evaluate both at the GPU's direction so only p's own arithmetic is compared.
        let p_cpu = hg.p(wo, wi_gpu);
        max_p_rel = max_p_rel.max((p_gpu - p_cpu).abs() / p_cpu);
    }
    println!(
        "{n} HG samples, g in {gs:?}: max |wi_gpu - wi_cpu| {max_dir:.2e}, max pdf rel diff \
         {max_pdf_rel:.2e}, max p(wo, wi) rel diff {max_p_rel:.2e}"
    );
    // A CPU adapter (llvmpipe) computes sin, cos, sqrt and pow to about an ulp, as libm does.
    // WGSL lets a GPU's built-ins be far coarser (sin and cos to 2^-11 absolute on [-pi, pi]);
    // NVIDIA's land within 2e-5 in direction and 1e-5 in pdf. The bounds for a GPU sit below
    // WGSL's own, and far below what a wrong formula gives (errors of order 1).
    let cpu_adapter = ctx.adapter_info.device_type == wgpu::DeviceType::Cpu;
    let (dir_tol, pdf_tol) = if cpu_adapter {
        (2e-6, 1e-6)
    } else {
        (1e-4, 1e-4)
    };
    assert!(max_dir < dir_tol, "directions differ by {max_dir}");
    assert!(
        max_pdf_rel < pdf_tol,
        "pdfs differ by {max_pdf_rel} relative"
    );
    assert!(
        max_p_rel < 1e-5,
        "p(wo, wi) differs by {max_p_rel} relative"
    );
}
