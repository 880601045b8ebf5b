// Test kernel for ln_f32 (shaders/common/math.wgsl), the mirror of f32::ln: for u = 4 i 2^-24,
// the bits of WGSL's built-in log(1 - u) and of ln_f32(1 - u); tests/gpu/math.rs compares
// both with f32::ln and with the f64 logarithm.

@group(0) @binding(0) var<storage, read_write> out: array<vec2<u32>>;

// The items: the generated entry point `logs` runs test_math on each (`Dispatch::Items`).
fn test_math_count() -> u32 {
    return arrayLength(&out);
}

fn test_math(i: u32) {
    let u = f32(i * 4u) * (1.0 / 16777216.0);
    out[i] = vec2<u32>(bitcast<u32>(log(1.0 - u)), bitcast<u32>(ln_f32(1.0 - u)));
}
