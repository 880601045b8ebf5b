// Mirrors the no-hit branch of radiance (src/integrator/path.rs): Stage::Escape. A ray that
// leaves the scene gathers the environment, MIS-weighted against light sampling
// (Lights::pdf_environment) unless its direction came from a delta distribution; the path ends.

@compute @workgroup_size(64)
fn escape(@builtin(global_invocation_id) id: vec3<u32>) {
    var slot = 0u;
    if (!queue_item(QUEUE_ESCAPE, id.x, &slot)) {
        return;
    }
    if (wf.has_env != 0u) {
        var ps = paths[slot];
        var w = 1.0;
        if ((ps.flags & PATH_FLAG_SPECULAR) == 0u) {
            w = power_heuristic(ps.prev_pdf, wf.env_pdf);
        }
        ps.l += ps.beta * wf.env * w;
        paths[slot] = ps;
    }
    queue_push(queue_done_out(), slot);
}
