// Mirrors `tracking::transmittance` with each estimator of src/volume/tracking/ (delta,
// weighted_delta, decomposition, weighted_decomposition, ratio, residual_ratio, spectral), run
// over the segments of DdaMajorantIterator::new / ::global, as a caller on the CPU would:
//
//   let mut rng = Rng::new(i, 0, seed);
//   let segs = DdaMajorantIterator::new(&bounds, &ray, ray.t_min, ray.t_max, scale);
//   tracking::transmittance(&estimator, segs, ray.t_max, &medium, &mut rng, &mut stats)
//
// One invocation per (ray, sample): invocation i estimates ray i / samples_per_ray.

// results (tracking_kernel.wgsl): xyz the estimate (grey in x), w the lookups this sample made.

@compute @workgroup_size(64)
fn transmittance_main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= params.invocation_count) {
        return;
    }
    let ray = rays[i / params.samples_per_ray];
    var tr = kernel_tracker(i, ray);
    tr.w = vec3<f32>(1.0);
    let t = tracking_transmittance(&tr, kernel_dda(ray), ray.t_max);
    results[i] = vec4<f32>(t, f32(tr.stats.lookups));
    merge_stats(tr.stats);
}
