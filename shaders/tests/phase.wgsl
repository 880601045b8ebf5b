// Test kernel for HenyeyGreenstein::sample and HenyeyGreenstein::p (src/volume/phase.rs);
// tests/gpu/phase.rs compares with the CPU within a few ulps.

// Per sample two rows: (g, u.x, u.y, -) and (wo, -).
@group(0) @binding(0) var<storage, read> inputs: array<vec4<f32>>;
// Per sample two rows: (wi, pdf) and (p(wo, wi), -, -, -).
@group(0) @binding(1) var<storage, read_write> outputs: array<vec4<f32>>;

// The items: the generated entry point `phase_samples` runs test_phase on each (`Dispatch::Items`).
fn test_phase_count() -> u32 {
    return arrayLength(&inputs) / 2u;
}

fn test_phase(i: u32) {
    let a = inputs[2u * i];
    let wo = inputs[2u * i + 1u].xyz;
    let s = hg_sample(a.x, wo, a.yz);
    outputs[2u * i] = vec4<f32>(s.wi, s.pdf);
    outputs[2u * i + 1u] = vec4<f32>(hg_p(a.x, wo, s.wi), 0.0, 0.0, 0.0);
}
