// Test kernel for HenyeyGreenstein::sample and HenyeyGreenstein::p (src/volume/phase.rs);
// tests/gpu/phase.rs compares with the CPU within a few ulps.

// Per sample two rows: (g, u.x, u.y, -) and (wo, -).
@group(0) @binding(0) var<storage, read> inputs: array<vec4<f32>>;
// Per sample two rows: (wi, pdf) and (p(wo, wi), -, -, -).
@group(0) @binding(1) var<storage, read_write> outputs: array<vec4<f32>>;

@compute @workgroup_size(64)
fn phase_samples(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (2u * i >= arrayLength(&inputs)) {
        return;
    }
    let a = inputs[2u * i];
    let wo = inputs[2u * i + 1u].xyz;
    let s = hg_sample(a.x, wo, a.yz);
    outputs[2u * i] = vec4<f32>(s.wi, s.pdf);
    outputs[2u * i + 1u] = vec4<f32>(hg_p(a.x, wo, s.wi), 0.0, 0.0, 0.0);
}
