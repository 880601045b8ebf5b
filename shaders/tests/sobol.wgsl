// Test kernel for sobol_point_u32 and sobol_point (src/sampling/sobol.rs): per query
// (pixel, sample, block, seed), the point's two u32 coordinates, then its two f32 coordinates
// as bits. tests/gpu/sobol.rs compares them with the CPU bit for bit.

@group(0) @binding(0) var<storage, read> queries: array<vec4<u32>>; // pixel, sample, block, seed
@group(0) @binding(1) var<storage, read_write> out: array<u32>;

// The items: the generated entry point `sobol_points` runs test_sobol on each (`Dispatch::Items`).
fn test_sobol_count() -> u32 {
    return arrayLength(&queries);
}

fn test_sobol(i: u32) {
    let q = queries[i];
    let p = sobol_point_u32(q.x, q.y, q.z, q.w);
    let f = sobol_point(q.x, q.y, q.z, q.w);
    out[4u * i] = p.x;
    out[4u * i + 1u] = p.y;
    out[4u * i + 2u] = bitcast<u32>(f.x);
    out[4u * i + 3u] = bitcast<u32>(f.y);
}
