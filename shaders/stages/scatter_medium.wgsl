// Mirrors scatter_medium (src/integrator/path.rs): Stage::ScatterMedium. Count the event and apply the depth limit, then next-event estimation:
// Lights::sample (or, guided, Lights::sample_selected) at the scattering point with the
// sampler's light-selection and light blocks of this bounce (or the path's next three
// uniforms), the phase
// function's value and the MIS weight (power heuristic unless the light is a delta). The
// unoccluded contribution goes to the shadow stage, which multiplies it by the transmittance
// with the path's own stream, so the random numbers are drawn in the CPU's order. Every path
// then goes on to the phase stage. With the light groups the shadow ray's estimate goes to the
// group of the light sampled (GpuPathState::shadow_group). With the data passes, a medium
// event before any opaque surface records the throughput and the view direction
// (record_albedo).

// Run on every path slot of its queue (the entry point src/backend/gpu/shader.rs adds).
fn scatter_medium(slot: u32) {
    var ps = paths[slot];
    // A zero throughput (absorption as a weight in an albedo-0 medium) ends the path before
    // it counts as a bounce, as an absorption event would.
    let absorbed = all(ps.beta == vec3<f32>(0.0));
    if (!absorbed) {
        ps.depth += 1u;
        ps.flags &= ~PATH_FLAG_FLIGHT_STARTED;
    }
    if (absorbed || ps.depth > wf.max_depth) {
        paths[slot] = ps;
        queue_push(queue_done_out(), slot);
        return;
    }
// #if FEATURE_LIGHT_PASSES
    // PathState::first_in_medium: the light the path gathers from here on goes to the volume
    // passes.
    if (ps.depth == 1u) {
        ps.flags |= PATH_FLAG_FIRST_IN_MEDIUM;
    }
// #endif
// #if FEATURE_DATA_PASSES
    if ((ps.flags & PATH_FLAG_ALBEDO_SEEN) == 0u) {
        // Cycles' volume features: the throughput past the event's albedo, and the view
        // direction as normal; a camera ray that scatters first sees no surface (depth 0).
        record_albedo(slot, &ps, ps.beta, -ps.d);
        ps.flags |= PATH_FLAG_DEPTH_SEEN;
    }
// #endif
    var rng = path_rng(ps);
    let p = ps.o;
    let wo = -ps.d;
    let bounce = ps.depth - 1u;
    let u_select = sampler_1d(ps.sample_id, bounce_dim(bounce, DIM_LIGHT_SELECT), &rng);
    let u_light = sampler_2d(ps.sample_id, bounce_dim(bounce, DIM_LIGHT), &rng);
    let ph = path_phase(ps);
    var ls: LightSample;
    if (lights_guided()) {
        ls = light_sample_selected(phase_selection(p, ph, wo), p, ph, wo, u_select, u_light, &rng);
    } else {
        ls = light_sample(p, u_select, u_light);
    }
    if (ls.valid) {
        let f = phase_p(ph, wo, ls.wi);
        if (f > 0.0 && ls.pdf > 0.0) {
            var w = 1.0;
            if (!ls.is_delta) {
                w = power_heuristic(ls.pdf, lamps_mixture_pdf(p, ls.wi, f));
            }
            // With equiangular sampling, the free-flight side of its MIS weight.
            w *= distance_weight(ps, ls.source);
            push_shadow_ray(slot, p, ls.wi, ls.dist, ps.medium, ps.outer, ps.beta * ls.li * (f * w / ls.pdf));
// #if FEATURE_LIGHT_GROUPS
            ps.shadow_group = light_group_of(ls.source);
// #endif
        }
    }
    ps.rng_state = rng.state;
    ps.rng_inc = rng.inc;
    paths[slot] = ps;
    queue_push(QUEUE_PHASE, slot);
}
