// Mirrors src/gpu_types.rs, the source of truth for every host/WGSL shared struct (same struct
// and member names). tests/gpu_layout.rs parses this file with naga and checks that every size
// and member offset equals the Rust `#[repr(C)]` layout. Rows are 16 bytes: a vec3 plus one
// scalar, so WGSL's vec3 alignment adds no hidden padding.

// GpuGridInfo: the SparseGrid header (src/volume/grid.rs).
struct GpuGridInfo {
    dims: vec3<u32>,             // cell counts of the dense cell index
    brick_count: u32,            // 512-float bricks in `bricks`
    cell_origin: vec3<i32>,      // cell coordinate of cells[0]
    constant_count: u32,         // entries in `constants`
    index_from_world: array<vec4<f32>, 3>, // rows of the world -> index affine map
    background: f32,             // value outside the cell box
    density_scale: f32,          // sigma_t = density_scale * value
    global_bounds_index: u32,    // index of the global CellBounds in `bounds`
    _pad0: u32,
}

// GpuRay: o + t d over [t_min, t_max].
struct GpuRay {
    o: vec3<f32>,
    t_min: f32,
    d: vec3<f32>,
    t_max: f32,
}

// GpuMajorantSegment: MajorantSegment (src/volume/segment.rs).
struct GpuMajorantSegment {
    t_min: f32,
    t_max: f32,
    sigma_maj: f32,
    sigma_min: f32,
}

// CellBounds (src/volume/bounds.rs): bounds of the reconstructed values in or near a cell.
struct CellBounds {
    min: f32,
    max: f32,
}

// GpuTrackingParams: one tracking dispatch.
struct GpuTrackingParams {
    estimator: u32,              // ESTIMATOR_* constant
    majorant_mode: u32,          // MAJORANT_PER_CELL or MAJORANT_GLOBAL
    control_mode: u32,           // CONTROL_* constant
    spectral_mode: u32,          // 0 history-aware max, 1 history-aware average
    b: f32,                      // majorant scale
    control_value: f32,          // constant sigma_c or fraction m
    albedo: f32,                 // sigma_s / sigma_t
    control_albedo: f32,         // split of the control extinction
    channel_scale: vec3<f32>,    // RGB extinction multipliers (spectral)
    seed: u32,                   // Rng::new(pixel, sample, seed)
    majorant_channel_scale: f32, // majorant multiplier (max channel_scale for spectral)
    samples_per_ray: u32,
    invocation_count: u32,
    _pad0: u32,
}

// GpuTrackingStats: TrackingStats counters, accumulated with atomics.
struct GpuTrackingStats {
    lookups: atomic<u32>,
    null_collisions: atomic<u32>,
    real_collisions: atomic<u32>,
    control_collisions: atomic<u32>,
    majorant_violations: atomic<u32>,
    invalid_majorants: atomic<u32>,
    collision_cap_hits: atomic<u32>,
    roulette_kills: atomic<u32>,
    max_abs_weight_bits: atomic<u32>, // bits of a non-negative f32: atomicMax is a float max
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}
