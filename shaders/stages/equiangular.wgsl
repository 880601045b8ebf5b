// Mirrors path.rs `equiangular`: Stage::Equiangular. Each path waiting in the medium queue,
// after the intersect stage, draws one equiangular estimate over its flight's span in media
// up to the surface hit (equiangular.wgsl), from its own stream before the flight's draws as
// on the CPU, gathered as the next event's with the path's throughput before the flight; it
// records the segment (ray parameters) for the medium stage, which keeps it where the flight
// scatters. A stage of its own so that the medium stage's kernel holds one tracker walk.

// Run on every path slot of its queue (the entry point src/backend/gpu/shader.rs adds).
fn equiangular(slot: u32) {
    var ps = paths[slot];
    ps.flags &= ~PATH_FLAG_SEGMENT;
    if (wf.volume_sampling != VOLUME_SAMPLING_DISTANCE && ps.depth < wf.max_depth) {
        var t_hit = f32_inf();
        if (FEATURE_SURFACES && ps.hit_prim != NO_INDEX) {
            t_hit = ps.hit_t;
        }
        equiangular_flight(slot, &ps, t_hit);
    }
    paths[slot] = ps;
}

// path.rs `equiangular`: the estimate over the flight up to `t_hit`, gathered as the next
// event's, and the flight's segment in media recorded.
fn equiangular_flight(slot: u32, ps: ptr<function, GpuPathState>, t_hit: f32) {
    let seg = media_extent((*ps).o, (*ps).d, (*ps).t0, t_hit, (*ps).medium, (*ps).outer);
    if (!seg.valid) {
        return;
    }
    let est = equiangular_estimate(seg, ps);
    if (est.valid && any(est.l != vec3<f32>(0.0))) {
        let x = (*ps).beta * est.l;
        (*ps).l += x;
// #if FEATURE_LIGHT_PASSES
        gather_next_pass(slot, *ps, x);
// #endif
// #if FEATURE_LIGHT_GROUPS
        gather_group(slot, light_group_of(est.source), x);
// #endif
    }
    (*ps).flags |= PATH_FLAG_SEGMENT;
    (*ps).seg_a = seg.a;
    (*ps).seg_b = seg.b;
    (*ps).seg_sigma_max = seg.sigma_max;
}
