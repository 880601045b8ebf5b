// Mirrors sample_media (src/integrator/path.rs) and sample_vdb (src/integrator/media.rs):
// Stage::SampleMedium. The free flight along the path's ray through the VDB medium it crosses,
// with the configured estimator (tracking_sample_distance, tracking.wgsl: the same loop and
// callbacks as the CPU) gathering the medium's emission (emission.wgsl), then the collision
// guard. Scatter -> scatter stage; escape -> the
// throughput takes the flight's weight and the path goes to the escape stage (no surfaces);
// absorption or the guard -> done.

@compute @workgroup_size(64)
fn sample_medium(@builtin(global_invocation_id) id: vec3<u32>) {
    var slot = 0u;
    if (!queue_item(queue_medium_in(), id.x, &slot)) {
        return;
    }
    var ps = paths[slot];
    var te = vec2<f32>(0.0);
    if (!medium_interval(ps.o, ps.d, ps.t0, f32_inf(), &te)) {
        queue_push(QUEUE_ESCAPE, slot);
        return;
    }
    var tr = medium_tracker(ps.o, ps.d, path_rng(ps), wf.tracking.estimator);
    let dda = medium_dda(tr, te.x, te.y);
    tracking_sample_distance(&tr, dda, te.y, ps.beta);
    ps.rng_state = tr.rng.state;
    ps.rng_inc = tr.rng.inc;
    add_tracking_stats(tr.stats, false, &ps);
    if (FEATURE_EMISSION) {
        // sample_vdb: the emission met on the way, already weighted by beta.
        ps.l += tr.emitted;
        ps.lookups += tr.emission_lookups;
        add_wide(WIDE_EMISSION_LOOKUPS, tr.emission_lookups);
    }
    // radiance's guard: tentative collisions of the whole path so far.
    if (ps.collisions > wf.max_collisions) {
        atomicAdd(&counters.guard_fired, 1u);
        paths[slot] = ps;
        queue_push(queue_done_out(), slot);
        return;
    }
    // from_grey: grey weights are splat, RGB ones (spectral tracking) used as they are.
    var weight = vec3<f32>(tr.w.x);
    if (FEATURE_CHROMATIC && wf.spectral != 0u) {
        weight = tr.w;
    }
    switch tr.event {
        case EVENT_SCATTER: {
            if (!(FEATURE_CHROMATIC && wf.spectral != 0u)) {
                weight = wf.scatter_albedo * tr.w.x;
            }
            ps.beta *= weight;
            ps.o = ps.o + tr.t_event * ps.d;
            paths[slot] = ps;
            queue_push(QUEUE_SCATTER, slot);
        }
        case EVENT_ABSORB: {
            paths[slot] = ps;
            queue_push(queue_done_out(), slot);
        }
        default: {
            ps.beta *= weight;
            paths[slot] = ps;
            queue_push(QUEUE_ESCAPE, slot);
        }
    }
}
