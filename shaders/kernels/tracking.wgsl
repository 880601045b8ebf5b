// Mirrors `tracking::transmittance` and `tracking::sample_distance` (src/volume/tracking/mod.rs)
// with each estimator of src/volume/tracking/, run over the segments of
// DdaMajorantIterator::new / ::global as a caller on the CPU would, with path throughput 1,
// and TrackingStats::merge for the counters:
//
//   let mut rng = Rng::new(i, 0, seed);
//   let segs = DdaMajorantIterator::new(&bounds, &ray, ray.t_min, ray.t_max, scale);
//   tracking::transmittance(&estimator, segs, ray.t_max, &medium, &mut rng, &mut stats)
//   tracking::sample_distance(&estimator, segs, ray.t_max, &medium, &mut rng, &mut stats)
//
// One invocation per (ray, sample): invocation i tracks ray i / samples_per_ray. The
// specialisation KERNEL_DISTANCE picks the distance kernel, else transmittance.

@group(1) @binding(0) var<uniform> params: GpuTrackingParams;
@group(1) @binding(1) var<storage, read> rays: array<GpuRay>;
// Transmittance: xyz the estimate (grey in x), w the lookups the sample made.
// Distance: xyz the event's weight (grey in x), w its ray parameter (0 on escape).
@group(1) @binding(2) var<storage, read_write> results: array<vec4<f32>>;
@group(1) @binding(3) var<storage, read_write> stats: GpuTrackingStats;

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

// #if KERNEL_DISTANCE
// x: EVENT_ESCAPE / EVENT_ABSORB / EVENT_SCATTER; y: the lookups the sample made.
@group(1) @binding(4) var<storage, read_write> events: array<vec2<u32>>;
// #endif

@compute @workgroup_size(64)
fn tracking_main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= params.invocation_count) {
        return;
    }
    let ray = rays[i / params.samples_per_ray];
    var tr: Tracker;
    tr.params = params;
    tr.albedo_rgb = vec3<f32>(params.albedo);
    tr.rng = rng_new(i, 0u, params.seed);
    tr.o = ray.o;
    tr.d = ray.d;
// #if KERNEL_DISTANCE
    tracking_sample_distance(&tr, kernel_dda(ray), ray.t_max, vec3<f32>(1.0));
    results[i] = vec4<f32>(tr.w, tr.t_event);
    events[i] = vec2<u32>(tr.event, tr.stats.lookups);
// #endif
// #if !KERNEL_DISTANCE
    tr.w = vec3<f32>(1.0);
    let t = tracking_transmittance(&tr, kernel_dda(ray), ray.t_max);
    results[i] = vec4<f32>(t, f32(tr.stats.lookups));
// #endif
    merge_stats(tr.stats);
}
