// Test kernel for SparseGrid::sample_nearest, SparseGrid::sample_trilinear and
// SparseGrid::voxel (src/volume/grid.rs) at given index points; tests/gpu/grid.rs compares.

@group(1) @binding(0) var<storage, read> points: array<vec4<f32>>;
// x: nearest, y: trilinear, z: voxel(floor(p)).
@group(1) @binding(1) var<storage, read_write> values: array<vec4<f32>>;

// The items: the generated entry point `grid_lookups` runs test_grid on each (`Dispatch::Items`).
fn test_grid_count() -> u32 {
    return arrayLength(&points);
}

fn test_grid(i: u32) {
    let p = points[i].xyz;
    values[i] = vec4<f32>(grid_sample_nearest(p), grid_sample_trilinear(p),
                          grid_voxel(vec3<i32>(floor(p))), 0.0);
}
