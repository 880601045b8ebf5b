// Mirrors trace_shadow (src/integrator/next_event.rs), transmittance_vdb
// (src/integrator/media.rs) and transmittance_homogeneous (src/integrator/homogeneous.rs):
// Stage::TraceShadow. The shadow ray
// walks from surface to surface (bvh_closest_hit): each stretch is attenuated by the
// homogeneous medium it lies in (exactly), or by the VDB medium it crosses with ratio or
// residual ratio tracking (Novak et al. 2014) for a grey medium and spectral tracking's
// estimator for a chromatic one, drawn from the path's stream; a null interface changes the
// medium and the walk goes on, any other surface blocks the ray (tested before the media up
// to it are tracked, as on the CPU). The path's radiance gains
// the NEE contribution times the transmittance (and, with the light passes, so does the pass
// PathState::gather routes it to; with the light groups, the group of the light sampled).

// Surfaces a shadow ray crosses at most: a bound for malformed geometry only (the CPU walk
// ends because t0 grows; so does this one, long before the bound for any real scene).
const MAX_SHADOW_CROSSINGS: u32 = 4096u;

// Run on every path slot of its queue (the entry point src/backend/gpu/shader.rs adds).
fn trace_shadow(slot: u32) {
    var ps = paths[slot];
    let sh = shadows[slot];
    var t = vec3<f32>(1.0);
    var medium = sh.medium;
    var outer = sh.outer;
    var t0 = 0.0;
    for (var crossing = 0u; crossing < MAX_SHADOW_CROSSINGS; crossing++) {
        let h = bvh_closest_hit(sh.o, sh.wi, t0, sh.dist);
        var t1 = sh.dist;
        if (h.prim != NO_INDEX) {
            t1 = h.t;
            // A surface that scatters blocks the ray before the media up to it are tracked.
            if (bvh_triangles[h.prim].kind != SURFACE_NULL) {
                t = vec3<f32>(0.0);
                break;
            }
        }
// #if FEATURE_HOMOGENEOUS
        if (medium != NO_INDEX) {
            t *= transmittance_homogeneous(homogeneous[medium], t1 - t0);
        }
// #endif
// #if FEATURE_MIXTURE
// #if FEATURE_HETEROGENEOUS
        // Every VDB medium along the stretch, inside a homogeneous medium or not (MIX).
        t *= mix_transmittance(sh.o, sh.wi, t0, t1, &ps);
        if (all(t == vec3<f32>(0.0))) {
            break;
        }
// #endif
// #endif
// #if !FEATURE_MIXTURE
// #if FEATURE_HETEROGENEOUS
        var te = vec2<f32>(0.0);
        if (medium == NO_INDEX
            && medium_interval(sh.o, sh.wi, t0, t1, &te)) {
            var tr = medium_tracker(sh.o, sh.wi, path_rng(ps), wf.shadow_estimator);
            // The shadow ray sees its path's instant.
            tr.time = ps.time;
            // WalkPlan::shadow: shadow rays may walk otherwise than free flights.
            tr.params.majorant_mode = wf.shadow_majorant_mode;
            let dda = medium_dda(tr, te.x, te.y);
            let est = tracking_transmittance(&tr, dda, te.y);
            if (wf.shadow_estimator == ESTIMATOR_SPECTRAL) {
                t *= est;
            } else {
                t *= vec3<f32>(est.x);
            }
            ps.rng_state = tr.rng.state;
            ps.rng_inc = tr.rng.inc;
            add_tracking_stats(tr.stats, true, &ps);
            if (all(t == vec3<f32>(0.0))) {
                break;
            }
        }
// #endif
// #endif
        if (h.prim == NO_INDEX) {
            break;
        }
        let tri = bvh_triangles[h.prim];
// #if FEATURE_HOMOGENEOUS
        let entering = dot(triangle_cross(tri), sh.wi) < 0.0;
        let m = stack_cross(medium, outer, tri.interior, entering);
        medium = m.x;
        outer = m.y;
// #endif
        t0 = h.t + 1e-4 * (1.0 + h.t);
        if (t0 >= sh.dist) {
            break;
        }
    }
    let x = sh.contribution * t;
    ps.l += x;
// #if FEATURE_LIGHT_PASSES
    // The estimate of the event that queued the ray (the path's depth is still that event's).
    gather_pass(slot, ps, x, PASS_EMISSION);
// #endif
// #if FEATURE_LIGHT_GROUPS
    gather_group(slot, ps.shadow_group, x);
// #endif
    paths[slot] = ps;
}
