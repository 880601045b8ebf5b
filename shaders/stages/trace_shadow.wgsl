// Mirrors trace_shadow (src/integrator/next_event.rs): Stage::TraceShadow. The pending shadow
// ray's transmittance (shadow.wgsl); the path's radiance gains the NEE contribution times it
// (and, with the light passes, so does the pass PathState::gather routes it to; with the light
// groups, the group of the light sampled).

// Run on every path slot of its queue (the entry point src/backend/gpu/shader.rs adds).
fn trace_shadow(slot: u32) {
    var ps = paths[slot];
    let sh = shadows[slot];
    let t = shadow_transmittance(sh.o, sh.wi, sh.dist, sh.medium, sh.outer, &ps);
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
