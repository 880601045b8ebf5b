// Mirrors `tracking::sample_distance` with each distance-sampling estimator of
// src/volume/tracking/ (delta, weighted_delta, decomposition, weighted_decomposition, spectral),
// run over the segments of DdaMajorantIterator::new / ::global with path throughput 1:
//
//   let mut rng = Rng::new(i, 0, seed);
//   let segs = DdaMajorantIterator::new(&bounds, &ray, ray.t_min, ray.t_max, scale);
//   tracking::sample_distance(&estimator, segs, ray.t_max, &medium, &mut rng, &mut stats)
//
// One invocation per (ray, sample): invocation i samples ray i / samples_per_ray.

@group(1) @binding(0) var<uniform> params: GpuTrackingParams;
@group(1) @binding(1) var<storage, read> rays: array<GpuRay>;
// xyz: the event's weight (grey in x); w: its ray parameter (0 on escape).
@group(1) @binding(2) var<storage, read_write> results: array<vec4<f32>>;
@group(1) @binding(3) var<storage, read_write> stats: GpuTrackingStats;
// x: EVENT_ESCAPE / EVENT_ABSORB / EVENT_SCATTER; y: the lookups this sample made.
@group(1) @binding(4) var<storage, read_write> events: array<vec2<u32>>;

@compute @workgroup_size(64)
fn distance_main(@builtin(global_invocation_id) id: vec3<u32>) {
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
    let scale = grid_info.density_scale * params.majorant_channel_scale;
    let dda = dda_new(ray.o, ray.d, ray.t_min, ray.t_max, scale, params.majorant_mode);
    tracking_sample_distance(&tr, dda, ray.t_max, vec3<f32>(1.0));
    results[i] = vec4<f32>(tr.w, tr.t_event);
    events[i] = vec2<u32>(tr.event, tr.stats.lookups);

    let s = tr.stats;
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

// Medium::on_collision's default: the media of the test kernels do not emit.
fn on_collision(tr: ptr<function, Tracker>, t: f32, sigma_maj: f32) {}
