// Mirrors TrackingStats::merge (src/volume/tracking/mod.rs) for the two tracking kernels
// (transmittance.wgsl, distance.wgsl): their shared bindings, the tracker one invocation
// starts from (Rng::new(i, 0, seed) on ray i / samples_per_ray), and the fold of its counters
// into the kernel's totals with atomics.

@group(1) @binding(0) var<uniform> params: GpuTrackingParams;
@group(1) @binding(1) var<storage, read> rays: array<GpuRay>;
// xyz: the estimate or event weight (grey in x); w: as each kernel says.
@group(1) @binding(2) var<storage, read_write> results: array<vec4<f32>>;
@group(1) @binding(3) var<storage, read_write> stats: GpuTrackingStats;

// The tracker of invocation i with its ray's origin and direction.
fn kernel_tracker(i: u32, ray: GpuRay) -> Tracker {
    var tr: Tracker;
    tr.params = params;
    tr.albedo_rgb = vec3<f32>(params.albedo);
    tr.rng = rng_new(i, 0u, params.seed);
    tr.o = ray.o;
    tr.d = ray.d;
    return tr;
}

// The segments of DdaMajorantIterator::new / ::global along `ray` for the kernel's grid.
fn kernel_dda(ray: GpuRay) -> Dda {
    let scale = grid_info.density_scale * params.majorant_channel_scale;
    return dda_new(ray.o, ray.d, ray.t_min, ray.t_max, scale, params.majorant_mode);
}

// TrackingStats::merge into the kernel's totals.
fn merge_stats(s: Stats) {
    atomicAdd(&stats.lookups, s.lookups);
    atomicAdd(&stats.null_collisions, s.null_collisions);
    atomicAdd(&stats.real_collisions, s.real_collisions);
    atomicAdd(&stats.control_collisions, s.control_collisions);
    atomicAdd(&stats.majorant_violations, s.majorant_violations);
    atomicAdd(&stats.invalid_majorants, s.invalid_majorants);
    atomicAdd(&stats.collision_cap_hits, s.collision_cap_hits);
    atomicAdd(&stats.roulette_kills, s.roulette_kills);
    atomicAdd(&stats.segments, s.segments);
    atomicMax(&stats.max_abs_weight_bits, bitcast<u32>(s.max_abs_weight));
}

// Medium::on_collision's default: the media of the tracking kernels do not emit.
fn on_collision(tr: ptr<function, Tracker>, t: f32, sigma_maj: f32) {}
