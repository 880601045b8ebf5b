// Mirrors SparseGrid::voxel, SparseGrid::sample_nearest and SparseGrid::sample_trilinear
// (src/volume/grid.rs): the same flat buffers (cells, bricks, constants) and OpenVDB's
// conventions (voxel (i, j, k) centred at index point (i, j, k); nearest rounds halves away
// from zero; trilinear blends z, then y, then x).
//
// Precision: the CPU scales each blend's difference in f64 (as OpenVDB does). Here it is f32.
// The product of two f32 values is exact in f64, so rounding it once to f32 gives the same bits
// as an f32 multiply: with IEEE f32 arithmetic the two agree bit for bit. A driver may still
// rewrite `a + (b - a) w` (Mesa's NIR applies inexact algebraic rewrites unless SPIR-V marks
// an operation NoContraction, which naga does not), so any difference is rounding only:
// nearly every lookup is bit-exact and the rest agree to a few ulps (tests/gpu/grid.rs).
//
// Limits: `bricks` is one storage binding, so at most maxStorageBufferBindingSize / 2048 bricks
// (65,536 bricks under lavapipe's 128 MiB).

const CONSTANT_BIT: u32 = 0x80000000u;

// A uniform: small, read by every invocation, and not counted against the 8 storage buffers
// per stage that WebGPU guarantees.
@group(0) @binding(0) var<uniform> grid_info: GpuGridInfo;
@group(0) @binding(1) var<storage, read> grid_cells: array<u32>;
@group(0) @binding(2) var<storage, read> grid_bricks: array<f32>;
@group(0) @binding(3) var<storage, read> grid_constants: array<f32>;

// Every lookup takes the grid's header `g` (by value): the density grid's is the uniform
// `grid_info`; the emission grids of a wavefront render live in the same buffers after it
// (GpuGridInfo::cell_offset), so one set of bindings serves them all.

// SparseGrid::entry_at: the cell entry of voxel `v`, false outside the cell box.
fn grid_entry_at_in(g: GpuGridInfo, v: vec3<i32>, entry: ptr<function, u32>) -> bool {
    // `>>` on i32 is arithmetic: it floors negative coordinates like the floored cell_origin.
    // The u32 reinterpretation makes negative cell coordinates huge, so one unsigned compare
    // per axis rejects both sides.
    let c = vec3<u32>((v >> vec3<u32>(3u)) - g.cell_origin);
    if (any(c >= g.dims)) {
        return false;
    }
    *entry = grid_cells[g.cell_offset + c.x + g.dims.x * (c.y + g.dims.y * c.z)];
    return true;
}

// SparseGrid::entry_value: a constant, or a brick value at local offset x + 8y + 64z.
fn grid_entry_value(entry: u32, local: u32) -> f32 {
    if ((entry & CONSTANT_BIT) != 0u) {
        return grid_constants[entry & ~CONSTANT_BIT];
    }
    return grid_bricks[entry * 512u + local];
}

// SparseGrid::voxel.
fn grid_voxel_in(g: GpuGridInfo, v: vec3<i32>) -> f32 {
    var entry = 0u;
    if (!grid_entry_at_in(g, v, &entry)) {
        return g.background;
    }
    let l = vec3<u32>(v & vec3<i32>(7));
    return grid_entry_value(entry, l.x + 8u * l.y + 64u * l.z);
}

fn grid_voxel(v: vec3<i32>) -> f32 {
    return grid_voxel_in(grid_info, v);
}

// SparseGrid::all_background_near: p is outside [lo - 1, hi) on some axis (or NaN).
// lo and hi are integers well inside f32's exact range for any grid the buffers can hold.
fn grid_all_background_near(g: GpuGridInfo, p: vec3<f32>) -> bool {
    let lo = vec3<f32>(g.cell_origin * 8);
    let hi = lo + vec3<f32>(g.dims * 8u);
    return !(all(p >= lo - 1.0) && all(p < hi));
}

// Rust's f64::round: halves away from zero (WGSL's round() rounds halves to even).
// x - trunc(x) is exact, so the comparison with 0.5 is too.
fn round_half_away(x: vec3<f32>) -> vec3<f32> {
    let t = trunc(x);
    return select(t, t + sign(x), abs(x - t) >= vec3<f32>(0.5));
}

// SparseGrid::sample_nearest (OpenVDB's PointSampler).
fn grid_sample_nearest(p: vec3<f32>) -> f32 {
    if (grid_all_background_near(grid_info, p)) {
        return grid_info.background;
    }
    return grid_voxel(vec3<i32>(round_half_away(p)));
}

// lerp_vdb: a + (b - a) w, see the precision note at the top.
fn lerp_vdb(a: f32, b: f32, w: f32) -> f32 {
    return a + (b - a) * w;
}

// trilinear_vdb: v[x][y][z] at floor(p) + (x, y, z); z first, then y, then x.
fn trilinear_vdb(v: array<f32, 8>, f: vec3<f32>) -> f32 {
    // v index = 4x + 2y + z.
    let a = lerp_vdb(lerp_vdb(v[0], v[1], f.z), lerp_vdb(v[2], v[3], f.z), f.y);
    let b = lerp_vdb(lerp_vdb(v[4], v[5], f.z), lerp_vdb(v[6], v[7], f.z), f.y);
    return lerp_vdb(a, b, f.x);
}

// SparseGrid::sample_trilinear (OpenVDB's BoxSampler) of grid `g`.
fn grid_sample_trilinear_in(g: GpuGridInfo, p: vec3<f32>) -> f32 {
    if (grid_all_background_near(g, p)) {
        return g.background;
    }
    let fl = floor(p);
    let i = vec3<i32>(fl);
    // Exact: p and floor(p) are close.
    let f = p - fl;
    var v: array<f32, 8>;
    var entry = 0u;
    // Fast path: all eight voxels in one cell.
    if (all((i & vec3<i32>(7)) != vec3<i32>(7)) && grid_entry_at_in(g, i, &entry)) {
        if ((entry & CONSTANT_BIT) != 0u) {
            // A blend of equal values is that value exactly.
            return grid_constants[entry & ~CONSTANT_BIT];
        }
        let l = vec3<u32>(i & vec3<i32>(7));
        let base = entry * 512u + l.x + 8u * l.y + 64u * l.z;
        for (var c = 0u; c < 8u; c++) {
            v[c] = grid_bricks[base + (c >> 2u) + 8u * ((c >> 1u) & 1u) + 64u * (c & 1u)];
        }
    } else {
        for (var c = 0u; c < 8u; c++) {
            let o = vec3<i32>(i32(c >> 2u), i32((c >> 1u) & 1u), i32(c & 1u));
            v[c] = grid_voxel_in(g, i + o);
        }
    }
    return trilinear_vdb(v, f);
}

// The density grid's trilinear lookup.
fn grid_sample_trilinear(p: vec3<f32>) -> f32 {
    return grid_sample_trilinear_in(grid_info, p);
}

// A world point in grid `g`'s index space (rows of g.index_from_world).
fn grid_index_point(g: GpuGridInfo, p: vec3<f32>) -> vec3<f32> {
    let m = g.index_from_world;
    let q = vec4<f32>(p, 1.0);
    return vec3<f32>(dot(m[0], q), dot(m[1], q), dot(m[2], q));
}
