// Mirrors the medium-scattering arm of radiance (src/integrator/path.rs), its second half, and
// russian_roulette: Stage::SamplePhase. HenyeyGreenstein::sample for the next direction (after
// the shadow stage has drawn its numbers from the same stream), then Russian roulette on the
// throughput after rr_depth events. Survivors go back to the medium stage next iteration.

@compute @workgroup_size(64)
fn sample_phase(@builtin(global_invocation_id) id: vec3<u32>) {
    var slot = 0u;
    if (!queue_item(QUEUE_PHASE, id.x, &slot)) {
        return;
    }
    var ps = paths[slot];
    var rng = path_rng(ps);
    let u0 = rng_uniform(&rng);
    let u1 = rng_uniform(&rng);
    let s = hg_sample(wf.phase_g, -ps.d, vec2<f32>(u0, u1));
    ps.beta *= s.weight;
    ps.d = s.wi;
    ps.t0 = 0.0;
    ps.prev_pdf = s.pdf;
    ps.flags = ps.flags & ~PATH_FLAG_SPECULAR;
    // russian_roulette: survive with probability min(max(beta), 0.95).
    var alive = true;
    if (ps.depth >= wf.rr_depth) {
        let a = abs(ps.beta);
        let q = min(max(a.x, max(a.y, a.z)), 0.95);
        if (!(q > 0.0) || rng_uniform(&rng) >= q) {
            alive = false;
        } else {
            ps.beta /= q;
        }
    }
    ps.rng_state = rng.state;
    ps.rng_inc = rng.inc;
    paths[slot] = ps;
    if (alive) {
        queue_push(queue_medium_out(), slot);
    } else {
        queue_push(queue_done_out(), slot);
    }
}
