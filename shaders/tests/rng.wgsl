// Test kernel for Rng::new, Rng::raw, Rng::next_u32 and Rng::uniform_f32 (src/sampling/rng.rs):
// per stream, the raw (state, inc) after construction, DRAWS/2 next_u32 outputs, then DRAWS/2
// uniforms as bits. tests/gpu/rng.rs compares them with the CPU bit for bit.

@group(0) @binding(0) var<storage, read> streams: array<vec4<u32>>; // pixel, sample, seed, -
@group(0) @binding(1) var<storage, read_write> out: array<u32>;

// The items: the generated entry point `rng_streams` runs test_rng on each (`Dispatch::Items`).
fn test_rng_count() -> u32 {
    return arrayLength(&streams);
}

fn test_rng(i: u32) {
    let s = streams[i];
    var rng = rng_new(s.x, s.y, s.z);
    let base = i * (DRAWS + 2u);
    out[base] = rng.state;
    out[base + 1u] = rng.inc;
    for (var j = 0u; j < DRAWS / 2u; j++) {
        out[base + 2u + j] = rng_next_u32(&rng);
    }
    for (var j = DRAWS / 2u; j < DRAWS; j++) {
        out[base + 2u + j] = bitcast<u32>(rng_uniform(&rng));
    }
}
