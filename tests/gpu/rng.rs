//! The WGSL RNG (shaders/common/rng.wgsl) against `sampling::Rng`, bit for bit.
use crate::common;

use brume::backend::gpu::shader::{Spec, TEST_RNG_MODULE};
use brume::sampling::rng::pcg_hash;
use brume::sampling::Rng;

const DRAWS: u32 = 16;

#[test]
fn wgsl_streams_equal_cpu_bit_for_bit() {
    let Some(ctx) = common::gpu::gpu_or_skip("gpu_rng") else {
        return;
    };
    // Random triples plus the corners of the u32 range.
    let mut streams: Vec<[u32; 4]> = (0..100_000u32)
        .map(|i| {
            [
                pcg_hash(i),
                pcg_hash(i ^ 0x5555_5555),
                pcg_hash(i.wrapping_mul(3)),
                0,
            ]
        })
        .collect();
    for p in [0, 1, u32::MAX] {
        for s in [0, 1, u32::MAX] {
            for seed in [0, 1, u32::MAX] {
                streams.push([p, s, seed, 0]);
            }
        }
    }
    let input = ctx.storage_buffer("streams", &streams);
    let out = ctx.storage_buffer_zeroed("out", streams.len() as u64 * (DRAWS as u64 + 2) * 4);
    let pipeline = ctx
        .pipeline(&TEST_RNG_MODULE, &[Spec::u32("DRAWS", DRAWS)])
        .unwrap();
    ctx.dispatch(
        &pipeline,
        &[(0, 0, &input), (0, 1, &out)],
        (streams.len() as u32).div_ceil(64),
    )
    .unwrap();
    let gpu: Vec<u32> = ctx.read_buffer(&out);
    let mut mismatches = 0;
    for (i, s) in streams.iter().enumerate() {
        let mut rng = Rng::new(s[0], s[1], s[2]);
        let (state, inc) = rng.raw();
        let mut cpu = vec![state, inc];
        for _ in 0..DRAWS / 2 {
            cpu.push(rng.next_u32());
        }
        for _ in 0..DRAWS / 2 {
            cpu.push(rng.uniform_f32().to_bits());
        }
        let g = &gpu[i * (DRAWS as usize + 2)..][..DRAWS as usize + 2];
        if g != cpu.as_slice() {
            if mismatches < 5 {
                eprintln!("stream {s:?}: gpu {g:?} cpu {cpu:?}");
            }
            mismatches += 1;
        }
    }
    println!(
        "{} streams x ({} raw + {DRAWS} draws): {mismatches} mismatches",
        streams.len(),
        2
    );
    assert_eq!(mismatches, 0);
}
