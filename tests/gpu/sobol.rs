//! The WGSL Sobol points (shaders/common/sobol.wgsl) against `sampling::sobol`, bit for bit.
use crate::common;

use brume::backend::gpu::shader::TEST_SOBOL_MODULE;
use brume::sampling::rng::pcg_hash;
use brume::sampling::sobol::{sobol_point, sobol_point_u32};

#[test]
fn wgsl_sobol_points_equal_cpu_bit_for_bit() {
    let Some(ctx) = common::gpu::gpu_or_skip("gpu_sobol") else {
        return;
    };
    // Hashed (pixel, sample, block, seed), a dense run of samples and blocks of one pixel (the
    // access pattern of a render), and the corners of the u32 range.
    let mut queries: Vec<[u32; 4]> = (0..100_000u32)
        .map(|i| {
            [
                pcg_hash(i),
                pcg_hash(i ^ 0x5555_5555),
                pcg_hash(i.wrapping_mul(3)) % 2048,
                pcg_hash(i.wrapping_mul(7)),
            ]
        })
        .collect();
    for s in 0..1024u32 {
        for b in 0..8u32 {
            queries.push([77, s, b, 0]);
        }
    }
    for p in [0, 1, u32::MAX] {
        for s in [0, 1, u32::MAX] {
            for b in [0, 1, u32::MAX] {
                for seed in [0, u32::MAX] {
                    queries.push([p, s, b, seed]);
                }
            }
        }
    }
    let input = ctx.storage_buffer("queries", &queries);
    let out = ctx.storage_buffer_zeroed("out", queries.len() as u64 * 16);
    let pipeline = ctx.pipeline(&TEST_SOBOL_MODULE, &[]).unwrap();
    ctx.dispatch(
        &pipeline,
        &[(0, 0, &input), (0, 1, &out)],
        (queries.len() as u32).div_ceil(64),
    )
    .unwrap();
    let gpu: Vec<u32> = ctx.read_buffer(&out);
    let mut mismatches = 0;
    for (i, q) in queries.iter().enumerate() {
        let (x, y) = sobol_point_u32(q[0], q[1], q[2], q[3]);
        let f = sobol_point(q[0], q[1], q[2], q[3]);
        let cpu = [x, y, f.x.to_bits(), f.y.to_bits()];
        let g = &gpu[4 * i..][..4];
        if g != cpu.as_slice() {
            if mismatches < 5 {
                eprintln!("query {q:?}: gpu {g:?} cpu {cpu:?}");
            }
            mismatches += 1;
        }
    }
    println!("{} points: {mismatches} mismatches", queries.len());
    assert_eq!(mismatches, 0);
}
