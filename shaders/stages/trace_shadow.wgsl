// Mirrors transmittance (src/integrator/path.rs) and transmittance_vdb
// (src/integrator/media.rs): Stage::TraceShadow. The transmittance along a shadow ray through
// the VDB medium with ratio or residual ratio tracking (Novak et al. 2014) for a grey medium,
// spectral tracking's estimator for a chromatic one, drawn from the path's stream; the
// path's radiance gains the NEE contribution times it.

@group(1) @binding(4) var<storage, read_write> shadows: array<GpuShadowRay>;

@compute @workgroup_size(64)
fn trace_shadow(@builtin(global_invocation_id) id: vec3<u32>) {
    var slot = 0u;
    if (!queue_item(QUEUE_SHADOW, id.x, &slot)) {
        return;
    }
    var ps = paths[slot];
    let sh = shadows[slot];
    var t = vec3<f32>(1.0);
    var te = vec2<f32>(0.0);
    if (FEATURE_HETEROGENEOUS && medium_interval(sh.o, sh.wi, 0.0, sh.dist, &te)) {
        var tr = medium_tracker(sh.o, sh.wi, path_rng(ps), wf.shadow_estimator);
        let dda = medium_dda(tr, te.x, te.y);
        let est = tracking_transmittance(&tr, dda, te.y);
        if (wf.shadow_estimator == ESTIMATOR_SPECTRAL) {
            t = est;
        } else {
            t = vec3<f32>(est.x);
        }
        ps.rng_state = tr.rng.state;
        ps.rng_inc = tr.rng.inc;
        add_tracking_stats(tr.stats, true, &ps);
    }
    ps.l += sh.contribution * t;
    paths[slot] = ps;
}
