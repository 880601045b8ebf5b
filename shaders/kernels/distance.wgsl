// Mirrors `tracking::sample_distance` with each distance-sampling estimator of
// src/volume/tracking/ (delta, weighted_delta, decomposition, weighted_decomposition, spectral),
// run over the segments of DdaMajorantIterator::new / ::global with path throughput 1:
//
//   let mut rng = Rng::new(i, 0, seed);
//   let segs = DdaMajorantIterator::new(&bounds, &ray, ray.t_min, ray.t_max, scale);
//   tracking::sample_distance(&estimator, segs, ray.t_max, &medium, &mut rng, &mut stats)
//
// One invocation per (ray, sample): invocation i samples ray i / samples_per_ray.

// results (tracking_kernel.wgsl): xyz the event's weight (grey in x), w its ray parameter (0
// on escape). events: x EVENT_ESCAPE / EVENT_ABSORB / EVENT_SCATTER, y the lookups it made.
@group(1) @binding(4) var<storage, read_write> events: array<vec2<u32>>;

@compute @workgroup_size(64)
fn distance_main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= params.invocation_count) {
        return;
    }
    let ray = rays[i / params.samples_per_ray];
    var tr = kernel_tracker(i, ray);
    tracking_sample_distance(&tr, kernel_dda(ray), ray.t_max, vec3<f32>(1.0));
    results[i] = vec4<f32>(tr.w, tr.t_event);
    events[i] = vec2<u32>(tr.event, tr.stats.lookups);
    merge_stats(tr.stats);
}
