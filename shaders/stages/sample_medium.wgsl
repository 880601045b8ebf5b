// Mirrors sample_medium (src/integrator/path.rs), media_flight (src/integrator/flight.rs) and
// sample_vdb (src/integrator/media.rs): Stage::SampleMedium. (The mixture variant: sample_media_mix,
// mixture.wgsl.) The free flight along the path's ray up to
// the surface it hits (or to infinity): through the homogeneous medium the path is in
// (closed form, media.wgsl), else through the VDB medium it crosses with the configured
// estimator (tracking_sample_distance, tracking.wgsl: the same loop and callbacks as the CPU)
// gathering the medium's emission (emission.wgsl); then the collision guard. Scatter ->
// scatter stage; escape -> the throughput takes the flight's weight and the path goes to the
// surface stage when its ray hits one, else to the escape stage; absorption or the guard ->
// done. With the light passes, the flight's emission goes to the pass PathState::pass_of
// names; with the light groups, each medium's to its group (Emitted::add). After a
// scattering event, where emitting media are sampled as lights, the emission is weighed
// against them (EmissionMis, media_lights.wgsl). The equiangular stage, before this one, has
// drawn its estimate over the flight's span; a flight that scatters keeps its segment.

// Run on every path slot of its queue (the entry point src/backend/gpu/shader.rs adds).
fn sample_medium(slot: u32) {
    var ps = paths[slot];
    let hit = FEATURE_SURFACES && ps.hit_prim != NO_INDEX;
    var t_hit = f32_inf();
    if (hit) {
        t_hit = ps.hit_t;
    }
    var event = EVENT_ESCAPE;
    var t_event = 0.0;
    var weight = vec3<f32>(1.0);
    var in_homogeneous = false;
    // radiance's flight_started: the first flight after each scattering event starts from
    // the sampler's point DIM_DISTANCE; one continued past a null interface does not.
    var rng0 = path_rng(ps);
    if ((ps.flags & PATH_FLAG_FLIGHT_STARTED) == 0u) {
        sampler_queue_on_stream(ps.sample_id, bounce_dim(ps.depth, DIM_DISTANCE), &rng0);
        ps.flags |= PATH_FLAG_FLIGHT_STARTED;
    }
// #if FEATURE_LIGHT_PASSES
    let l_before = ps.l;
// #endif
// #if FEATURE_EMISSION
    // After a scattering event, emission is weighed against the media lights (EmissionMis).
    emission_mis_on = wf.media_light_cells > 0u && (ps.flags & PATH_FLAG_SPECULAR) == 0u;
    emission_mis_pdf = ps.dir_pdf;
    emission_mis_origin = ps.o;
// #endif
// #if FEATURE_MIXTURE
// #if FEATURE_HETEROGENEOUS
    // Several VDB media (mixture.wgsl): the homogeneous medium, each VDB medium in turn, or
    // their sum where they overlap. (graph.rs never builds the mixture without media; the
    // other paths below are then cut.)
    let f = sample_media_mix(&ps, rng0, t_hit);
    event = f.event;
    t_event = f.t;
    weight = f.weight;
    ps.phase_g = f.g;
    ps.phase_medium = f.phase_medium;
// #endif
// #endif
// #if !FEATURE_MIXTURE
// #if FEATURE_HOMOGENEOUS
    in_homogeneous = ps.medium != NO_INDEX;
    if (in_homogeneous) {
        var rng = rng0;
        let ev = sample_homogeneous(homogeneous[ps.medium], t_hit - ps.t0, wf.absorption_weight != 0u, &rng);
        ps.rng_state = rng.state;
        ps.rng_inc = rng.inc;
        event = ev.event;
        t_event = ps.t0 + ev.t;
        weight = ev.weight;
    }
// #endif
// #if FEATURE_HETEROGENEOUS
    if (!in_homogeneous) {
        var te = vec2<f32>(0.0);
        if (medium_interval(ps.o, ps.d, ps.t0, t_hit, &te)) {
            var tr = medium_tracker(ps.o, ps.d, rng0, wf.tracking.estimator);
            tr.time = ps.time;
            let dda = medium_dda(tr, te.x, te.y);
            tracking_sample_distance(&tr, dda, te.y, ps.beta);
            ps.rng_state = tr.rng.state;
            ps.rng_inc = tr.rng.inc;
            add_tracking_stats(tr.stats, false, &ps);
// #if FEATURE_EMISSION
            // sample_vdb: the emission met on the way, already weighted by beta.
            ps.l += tr.emitted;
            ps.lookups += tr.emission_lookups;
            add_wide(WIDE_EMISSION_LOOKUPS, tr.emission_lookups);
// #endif
            event = tr.event;
            t_event = tr.t_event;
            // from_grey: grey weights are splat and a scattering event takes the RGB albedo;
            // RGB weights (spectral tracking) take RgbView's scatter_albedo at a scattering
            // event (the albedo with absorption as a weight, else 1).
            weight = vec3<f32>(tr.w.x);
            if (FEATURE_CHROMATIC && wf.spectral != 0u) {
                weight = tr.w;
                if (event == EVENT_SCATTER) {
                    weight = tr.w * wf.scatter_albedo;
                }
            } else if (event == EVENT_SCATTER) {
                weight = wf.scatter_albedo * tr.w.x;
            }
        }
    }
// #endif
// #endif
// #if FEATURE_LIGHT_PASSES
    // The flight's emission, as the radiance took it (sample_medium's `ps.l - before`).
    gather_pass(slot, ps, ps.l - l_before, PASS_EMISSION);
// #endif
// #if FEATURE_LIGHT_GROUPS
// #if FEATURE_EMISSION
    gather_flight_groups(slot);
// #endif
// #endif
// #if FEATURE_EQUIANGULAR
    // The segment the equiangular stage recorded, for the scattering stage's weight.
    if ((ps.flags & PATH_FLAG_SEGMENT) != 0u) {
        keep_segment(&ps, event == EVENT_SCATTER, t_event);
    }
// #endif
    end_flight_stage(slot, ps, hit, event, t_event, weight);
}

// The guard, then where the path goes after its flight (sample_medium's match on the event):
// the scattering stage, done, or the surface or escape stage with the flight's weight.
fn end_flight_stage(slot: u32, ps_in: GpuPathState, hit: bool, event: u32, t_event: f32,
                    weight: vec3<f32>) {
    var ps = ps_in;
    // radiance's guard: tentative collisions of the whole path so far.
    if (ps.collisions > wf.max_collisions) {
        atomicAdd(&counters.guard_fired, 1u);
        paths[slot] = ps;
        queue_push(queue_done_out(), slot);
        return;
    }
    switch event {
        case EVENT_SCATTER: {
            ps.beta *= weight;
            ps.o = ps.o + t_event * ps.d;
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
            if (hit) {
                queue_push(QUEUE_SURFACE, slot);
            } else {
                queue_push(QUEUE_ESCAPE, slot);
            }
        }
    }
}

// #if FEATURE_EQUIANGULAR
// A flight that scatters at `t_event` keeps the segment the equiangular stage recorded,
// relative to the event, with the extinction there (distance_weight); any other drops it.
fn keep_segment(ps: ptr<function, GpuPathState>, scatters: bool, t_event: f32) {
    if (!scatters) {
        (*ps).flags &= ~PATH_FLAG_SEGMENT;
        return;
    }
    var seg: Segment;
    seg.o = (*ps).o;
    seg.dir = (*ps).d;
    seg.medium = (*ps).medium;
    (*ps).seg_a -= t_event;
    (*ps).seg_b -= t_event;
    (*ps).seg_sigma_t = media_at(seg, t_event, -seg.dir, -seg.dir, (*ps).time).sigma_t;
}
// #endif
