// Test kernel for Phase::sample, Phase::p and Phase::mean_cosine (src/volume/phases.rs), every kind;
// tests/gpu/phase.rs compares with the CPU within a few ulps.

// Per sample three rows: (kind bits, g_a, g_b, w), (alpha, u.x, u.y, seed bits) and
// (wo, -). A rejection's further points come from the stream Rng::new(i, 0, seed).
@group(0) @binding(0) var<storage, read> inputs: array<vec4<f32>>;
// Per sample two rows: (wi, pdf) and (p(wo, wi), mean cosine, -, -).
@group(0) @binding(1) var<storage, read_write> outputs: array<vec4<f32>>;

// The items: the generated entry point `phase_samples` runs test_phase on each (`Dispatch::Items`).
fn test_phase_count() -> u32 {
    return arrayLength(&inputs) / 3u;
}

fn test_phase(i: u32) {
    let a = inputs[3u * i];
    let b = inputs[3u * i + 1u];
    let wo = inputs[3u * i + 2u].xyz;
    let ph = GpuPhase(bitcast<u32>(a.x), a.y, a.z, a.w, b.x, 0u, 0u, 0u);
    var rng = rng_new(i, 0u, bitcast<u32>(b.w));
    let s = phase_sample(ph, wo, b.yz, &rng);
    outputs[2u * i] = vec4<f32>(s.wi, s.pdf);
    outputs[2u * i + 1u] = vec4<f32>(phase_p(ph, wo, s.wi), phase_mean_cosine(ph), 0.0, 0.0);
}
