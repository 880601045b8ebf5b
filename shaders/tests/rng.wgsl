// Test kernel for Rng::new, Rng::raw, Rng::next_u32 and Rng::uniform_f32 (src/sampling/rng.rs):
// per stream, the raw (state, inc) after construction, DRAWS/2 next_u32 outputs, then DRAWS/2
// uniforms as bits. tests/gpu/rng.rs compares them with the CPU bit for bit.

@group(0) @binding(0) var<storage, read> streams: array<vec4<u32>>; // pixel, sample, seed, -
@group(0) @binding(1) var<storage, read_write> out: array<u32>;

@compute @workgroup_size(64)
fn rng_streams(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= arrayLength(&streams)) {
        return;
    }
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
