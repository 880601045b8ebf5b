// Mirrors escape (src/integrator/path.rs): Stage::Escape. A ray that
// leaves the scene gathers the environment, MIS-weighted against light sampling
// (Lights::pdf_environment, or the guided selection's: escape_mis) unless its direction came
// from a delta distribution; the path ends, marked PATH_FLAG_ESCAPED (accumulate takes a
// camera ray's coverage from it). A camera ray escaping unscattered on a transparent film
// (WF_FLAG_FILM_TRANSPARENT) gathers nothing.
// With FEATURE_ENV_MAP the radiance and the pdf come from the map (envmap.wgsl). The light
// goes to the background pass as PathState::gather routes it (gather_pass), and to the
// environment's light group (gather_group); with the data
// passes, a camera ray that meets no surface records the background's depth, and the sky is
// the albedo of a path that meets no opaque surface or medium event first (record_albedo).

// Run on every path slot of its queue (the entry point src/backend/gpu/shader.rs adds).
fn escape(slot: u32) {
    var ps = paths[slot];
    ps.flags |= PATH_FLAG_ESCAPED;
    // Seen straight through, the sky is the background, which a transparent film leaves out.
    let unscattered = ps.depth == 0u;
    let gathers = !(unscattered && (wf.flags & WF_FLAG_FILM_TRANSPARENT) != 0u);
// #if FEATURE_DATA_PASSES
    record_depth(slot, &ps, BACKGROUND_DEPTH);
// #endif
    if (wf.has_env != 0u && gathers) {
        var w = 1.0;
// #if FEATURE_ENV_MAP
        // The map: radiance and light-sampling density depend on the direction.
        let le = env_le(ps.d);
        if ((ps.flags & PATH_FLAG_SPECULAR) == 0u) {
            w = escape_mis(ps, env_pdf(ps.d));
        }
// #endif
// #if !FEATURE_ENV_MAP
        let le = wf.env;
        if ((ps.flags & PATH_FLAG_SPECULAR) == 0u) {
            // wf.env_pdf is the uniform selection's pmf over 4 pi.
            if (lights_guided()) {
                w = escape_mis(ps, INV_4PI);
            } else {
                w = power_heuristic(ps.prev_pdf, wf.env_pdf);
            }
        }
// #endif
// #if FEATURE_DATA_PASSES
        // The sky seen (through smooth dielectrics at most) is its own albedo, as Cycles
        // gives it to the denoiser.
        record_albedo(slot, &ps, ps.beta * le, vec3<f32>(0.0));
// #endif
        let x = ps.beta * le * w;
        ps.l += x;
// #if FEATURE_LIGHT_PASSES
        gather_pass(slot, ps, x, PASS_BACKGROUND);
// #endif
// #if FEATURE_LIGHT_GROUPS
        gather_group(slot, wf.environment_group, x);
// #endif
    }
    // One write of the path state: the flag, and the radiance where the sky was gathered.
    paths[slot] = ps;
    queue_push(queue_done_out(), slot);
}
