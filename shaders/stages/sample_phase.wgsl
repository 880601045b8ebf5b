// Mirrors sample_phase (src/integrator/path.rs) and russian_roulette: Stage::SamplePhase, the
// next direction once the shadow stage has drawn its numbers from the same stream. In a medium:
// Phase::sample with the phase function of the medium that scattered, mixed with the lamps'
// cones where some lamp is inside media (glow::Lamps). At an opaque surface (PATH_FLAG_SURFACE):
// Principled::sample in the shading frame of the hit, mixed with the same cones, the path
// ending when it fails or points below the surface. Then
// Russian roulette on the throughput after rr_depth events; survivors go back to the
// intersect and medium stages next iteration.

// Run on every path slot of its queue (the entry point src/backend/gpu/shader.rs adds).
fn sample_phase(slot: u32) {
    var ps = paths[slot];
    var rng = path_rng(ps);
    var at_surface = false;
    var rr_scale = 1.0;
// #if FEATURE_SURFACES
    at_surface = (ps.flags & PATH_FLAG_SURFACE) != 0u;
    if (at_surface) {
        ps.flags &= ~PATH_FLAG_SURFACE;
        // The shading frame and BSDF of the hit, as the surface stage built them.
        let tri = scene_triangle(ps.hit_prim);
        let mat = materials[tri.material];
        let p = ps.o + ps.hit_t * ps.d;
        let wo = -ps.d;
        let ng = normalize_or_zero(triangle_cross(tri));
        let n_side = select(-ng, ng, dot(ng, wo) >= 0.0);
        let frame = frame_from_z(shading_normal(tri, ps.hit_b1, ps.hit_b2, n_side));
        let uv = triangle_uv(ps.hit_prim, ps.hit_b1, ps.hit_b2);
        let bsdf = principled_new(base_color_at(mat, uv), mat.metallic, mat.roughness);
        let u_lobe = sampler_1d(ps.sample_id, bounce_dim(ps.depth - 1u, DIM_LOBE), &rng);
        let u_dir = sampler_2d(ps.sample_id, bounce_dim(ps.depth - 1u, DIM_SCATTER), &rng);
        let p_off = offset_origin(p, n_side, n_side);
        var s: BsdfSample;
        if (!lamps_guide_surfaces()) {
            s = principled_sample(bsdf, frame_to_local(frame, wo), u_lobe, u_dir);
        } else {
            let wo_l = frame_to_local(frame, wo);
            s = lamps_bsdf_sample(bsdf, frame, wo_l, p_off, u_lobe, u_dir, &rng);
            if (s.valid) {
                rr_scale = cone_scale(s.pdf, principled_pdf(bsdf, wo_l, s.wi));
            }
        }
        var wi = vec3<f32>(0.0);
        if (s.valid) {
            wi = frame_from_local(frame, s.wi);
        }
        if (!s.valid || dot(n_side, wi) <= 0.0) {
            ps.rng_state = rng.state;
            ps.rng_inc = rng.inc;
            paths[slot] = ps;
            queue_push(queue_done_out(), slot);
            return;
        }
        ps.beta *= s.weight;
        ps.o = p_off;
        ps.d = wi;
        // Surface events select lights uniformly.
        store_prev_pdf(&ps, s.pdf, uniform_env_pmf(), false);
        ps.dir_pdf = s.pdf;
    }
// #endif
    if (!at_surface) {
        let u_dir = sampler_2d(ps.sample_id, bounce_dim(ps.depth - 1u, DIM_SCATTER), &rng);
        let ph = path_phase(ps);
        let wo = -ps.d;
        var s: PhaseSample;
        if (wf.lamp_count == 0u) {
            s = phase_sample(ph, wo, u_dir, &rng);
        } else {
            s = lamps_phase_sample(ph, ps.o, wo, u_dir, &rng);
            rr_scale = cone_scale(s.pdf, phase_p(ph, wo, s.wi));
        }
        ps.beta *= s.weight;
        ps.d = s.wi;
        // The scatter stage's selection, recomputed (a function of the event alone).
        var env_pmf = 0.0;
        var by_phase = false;
        if (lights_guided() && wf.has_env != 0u) {
            let sel = phase_selection(ps.o, ph, wo);
            env_pmf = sel.env;
            by_phase = sel.env_by_phase;
        }
        store_prev_pdf(&ps, s.pdf, env_pmf, by_phase);
        ps.dir_pdf = s.pdf;
    }
    ps.t0 = 0.0;
    ps.flags = ps.flags & ~PATH_FLAG_SPECULAR;
    continue_or_finish(ps, slot, rng, rr_scale);
}
