//! `ln_f32` (shaders/common/math.wgsl), the WGSL mirror of `f32::ln` used for exponential
//! steps, against the CPU: within 1 ulp of the true logarithm everywhere tracking calls it, and
//! reported against WGSL's built-in `log`, which Vulkan lets be off by 2^-21 absolutely.
use crate::common;

use brume::backend::gpu::shader::TEST_MATH_MODULE;

#[test]
fn ln_f32_is_accurate_where_builtin_log_is_not() {
    let Some(ctx) = common::gpu::gpu_or_skip("gpu_math") else {
        return;
    };
    let pipeline = ctx.pipeline(&TEST_MATH_MODULE, &[]).unwrap();
    // u = 4 i 2^-24 over all of [0, 1): every fourth uniform the RNG can return.
    let n = 65_535u32 * 64;
    let out = ctx.storage_buffer_zeroed("logs", n as u64 * 8);
    ctx.dispatch(&pipeline, &[(0, 0, &out)], n / 64).unwrap();
    let gpu: Vec<[u32; 2]> = ctx.read_buffer(&out);
    let (mut same_builtin, mut same_ours) = (0u32, 0u32);
    let (mut rel_builtin, mut rel_ours) = (0.0f64, 0.0f64);
    for (i, g) in gpu.iter().enumerate() {
        let u = (i as u32 * 4) as f32 * (1.0 / 16_777_216.0);
        let cpu = (1.0 - u).ln();
        let exact = (1.0 - u as f64).ln();
        let (builtin, ours) = (f32::from_bits(g[0]), f32::from_bits(g[1]));
        same_builtin += (builtin.to_bits() == cpu.to_bits()) as u32;
        same_ours += (ours.to_bits() == cpu.to_bits()) as u32;
        if exact != 0.0 {
            rel_builtin = rel_builtin.max(((builtin as f64 - exact) / exact).abs());
            rel_ours = rel_ours.max(((ours as f64 - exact) / exact).abs());
        } else {
            assert_eq!(ours, 0.0, "ln_f32(1) must be 0");
        }
    }
    let pct = |k: u32| 100.0 * k as f64 / n as f64;
    println!(
        "{n} values of ln(1 - u): built-in log equals f32::ln {:.3} %, max rel err {rel_builtin:.2e}; \
         ln_f32 equals f32::ln {:.3} %, max rel err {rel_ours:.2e}",
        pct(same_builtin),
        pct(same_ours)
    );
    // One ulp of f32 is at most 2^-23 relative.
    assert!(rel_ours <= 1.2e-7, "ln_f32 off by {rel_ours:.2e} relative");
}
