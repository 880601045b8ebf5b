// Mirrors trace_shadow and media_transmittance (src/integrator/next_event.rs), with
// transmittance_vdb (src/integrator/media.rs) and transmittance_homogeneous
// (src/integrator/homogeneous.rs): the transmittance of a shadow ray, used by the shadow stage
// and by the equiangular estimate (equiangular.wgsl). The ray walks from surface to surface
// (bvh_closest_hit): each stretch is attenuated by the homogeneous medium it lies in
// (exactly), or by the VDB media it crosses with ratio or residual ratio tracking (Novak et
// al. 2014) for a grey medium and spectral tracking's estimator for a chromatic one, drawn
// from the path's stream; a null interface changes the medium and the walk goes on, any other
// surface blocks the ray (tested before the media up to it are tracked, as on the CPU).

// Surfaces a shadow ray crosses at most: a bound for malformed geometry only (the CPU walk
// ends because t0 grows; so does this one, long before the bound for any real scene).
const MAX_SHADOW_CROSSINGS: u32 = 4096u;

// media_transmittance: the transmittance along (o, d) over [t0, t1] through the media there
// and no surface: the homogeneous medium `medium` the ray is in and the VDB media it crosses
// (those inside the homogeneous one in the mixture variant), each estimated on its own.
fn media_transmittance(o: vec3<f32>, d: vec3<f32>, t0: f32, t1: f32, medium: u32,
                       ps: ptr<function, GpuPathState>) -> vec3<f32> {
    var t = vec3<f32>(1.0);
// #if FEATURE_HOMOGENEOUS
    if (medium != NO_INDEX) {
        t *= transmittance_homogeneous(homogeneous[medium], t1 - t0);
    }
// #endif
// #if FEATURE_MIXTURE
// #if FEATURE_HETEROGENEOUS
    // Every VDB medium along the stretch, inside a homogeneous medium or not (MIX).
    t *= mix_transmittance(o, d, t0, t1, ps);
// #endif
// #endif
// #if !FEATURE_MIXTURE
// #if FEATURE_HETEROGENEOUS
    var te = vec2<f32>(0.0);
    if (medium == NO_INDEX && medium_interval(o, d, t0, t1, &te)) {
        var tr = medium_tracker(o, d, path_rng(*ps), wf.shadow_estimator);
        // The shadow ray sees its path's instant.
        tr.time = (*ps).time;
        // WalkPlan::shadow: shadow rays may walk otherwise than free flights.
        tr.params.majorant_mode = wf.shadow_majorant_mode;
        let dda = medium_dda(tr, te.x, te.y);
        let est = tracking_transmittance(&tr, dda, te.y);
        if (wf.shadow_estimator == ESTIMATOR_SPECTRAL) {
            t *= est;
        } else {
            t *= vec3<f32>(est.x);
        }
        (*ps).rng_state = tr.rng.state;
        (*ps).rng_inc = tr.rng.inc;
        add_tracking_stats(tr.stats, true, ps);
    }
// #endif
// #endif
    return t;
}

// trace_shadow: the transmittance along the shadow ray from `o` in direction `wi` over `dist`,
// starting in the homogeneous medium `medium` with `outer` below it; 0 when a surface that
// scatters blocks it.
fn shadow_transmittance(o: vec3<f32>, wi: vec3<f32>, dist: f32, medium_in: u32, outer_in: u32,
                        ps: ptr<function, GpuPathState>) -> vec3<f32> {
    return walk_transmittance(FreeLeg(o, wi, 0.0, false), o, wi, dist, medium_in, outer_in, ps);
}

// FreeLeg: a stretch (o, d) over [0, t1] through the medium a walk starts in that no surface
// crosses (the part of a flight before an equiangular sample), tracked before the shadow ray.
struct FreeLeg {
    o: vec3<f32>,
    d: vec3<f32>,
    t1: f32,
    on: bool,
}

// walk_transmittance: the free leg's transmittance (where `free.on`), then the shadow ray's,
// in that order on the path's stream. One loop walks both so that a kernel holds a single copy
// of the trackers and of the BVH traversal.
fn walk_transmittance(free: FreeLeg, o: vec3<f32>, wi: vec3<f32>, dist: f32, medium_in: u32,
                      outer_in: u32, ps: ptr<function, GpuPathState>) -> vec3<f32> {
    var t = vec3<f32>(1.0);
    var medium = medium_in;
    var outer = outer_in;
    var in_free = free.on;
    var ro = select(o, free.o, in_free);
    var rd = select(wi, free.d, in_free);
    var end = select(dist, free.t1, in_free);
    var t0 = 0.0;
    for (var crossing = 0u; crossing < MAX_SHADOW_CROSSINGS; crossing++) {
        var h = Hit(NO_INDEX, 0.0, 0.0, 0.0);
        if (!in_free) {
            h = bvh_closest_hit(ro, rd, t0, end);
        }
        var t1 = end;
        if (h.prim != NO_INDEX) {
            t1 = h.t;
            // A surface that scatters blocks the ray before the media up to it are tracked.
            if (bvh_triangles[placed_slot(h.prim).x].kind != SURFACE_NULL) {
                return vec3<f32>(0.0);
            }
        }
        t *= media_transmittance(ro, rd, t0, t1, medium, ps);
        if (all(t == vec3<f32>(0.0))) {
            break;
        }
        if (in_free) {
            // On to the shadow ray, from the same medium.
            in_free = false;
            ro = o;
            rd = wi;
            end = dist;
            continue;
        }
        if (h.prim == NO_INDEX) {
            break;
        }
// #if FEATURE_HOMOGENEOUS
        let tri = scene_triangle(h.prim);
        let entering = dot(triangle_cross(tri), rd) < 0.0;
        let m = stack_cross(medium, outer, tri.interior, entering);
        medium = m.x;
        outer = m.y;
// #endif
        t0 = h.t + 1e-4 * (1.0 + h.t);
        if (t0 >= end) {
            break;
        }
    }
    return t;
}
