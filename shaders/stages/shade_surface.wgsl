// Mirrors shade_surface (src/integrator/path.rs): Stage::ShadeSurface.
// At the surface its ray hit (GpuPathState::hit_*): the surface's emission, MIS-weighted
// against light sampling (Lights::pdf_area) unless the direction came from a delta
// distribution; then by the material's kind
// - null interface: enter or leave its interior medium and continue the same ray past it;
// - smooth dielectric: count the event, reflect or refract by Fresnel (one uniform), the
//   throughput compressed by eta^2 when refracting, medium change, Russian roulette;
// - opaque: count the event, next-event estimation with the BSDF (the light sample's three
//   uniforms here, its transmittance in the shadow stage) and hand the path to the
//   direction stage, which samples the BSDF after the shadow ray has drawn its numbers (the
//   CPU's order).
// With the light passes, the emission goes to its pass as PathState::gather routes it
// (gather_pass), and with the light groups to the surfaces' group; the next-event estimate
// does in the shadow stage, to the group of the light sampled (GpuPathState::shadow_group). With the data passes, the
// camera ray's first surface that is not a null interface records its depth, and the first
// opaque one the albedo and shading normal (record_depth, record_albedo).

// Run on every path slot of its queue (the entry point src/backend/gpu/shader.rs adds).
fn shade_surface(slot: u32) {
    var ps = paths[slot];
    let tri = scene_triangle(ps.hit_prim);
    let mat = materials[tri.material];
    let p = ps.o + ps.hit_t * ps.d;
    let wo = -ps.d;
    let ng = normalize_or_zero(triangle_cross(tri));
    let cos_o = dot(ng, wo);
    let uv = triangle_uv(ps.hit_prim, ps.hit_b1, ps.hit_b2);
    if (any(mat.emission != vec3<f32>(0.0))) {
        let le = emitted(mat, uv, cos_o);
        if (any(le != vec3<f32>(0.0))) {
            var w = 1.0;
            if ((ps.flags & PATH_FLAG_SPECULAR) == 0u) {
                w = power_heuristic(ps.prev_pdf, pdf_area(tri, ps.hit_t, cos_o));
            }
            let x = ps.beta * le * w;
            ps.l += x;
// #if FEATURE_LIGHT_PASSES
            gather_pass(slot, ps, x, PASS_EMISSION);
// #endif
// #if FEATURE_LIGHT_GROUPS
            gather_group(slot, wf.surfaces_group, x);
// #endif
        }
    }
    if (tri.kind == SURFACE_NULL) {
        // An index-matched boundary: only the medium changes; no event, no roulette.
        if (FEATURE_HOMOGENEOUS) {
            let m = stack_cross(ps.medium, ps.outer, tri.interior, cos_o > 0.0);
            ps.medium = m.x;
            ps.outer = m.y;
        }
        ps.t0 = ps.hit_t + 1e-4 * (1.0 + ps.hit_t);
        paths[slot] = ps;
        queue_push(queue_medium_out(), slot);
        return;
    }
// #if FEATURE_DATA_PASSES
    // The camera ray's first surface: its camera-space Z (Cycles' Z pass).
    let eye = vec3<f32>(wf.camera[0].w, wf.camera[1].w, wf.camera[2].w);
    record_depth(slot, &ps, dot(p - eye, wf.forward));
// #endif
    ps.depth += 1u;
    ps.flags &= ~PATH_FLAG_FLIGHT_STARTED;
    if (ps.depth > wf.max_depth) {
        paths[slot] = ps;
        queue_push(queue_done_out(), slot);
        return;
    }
    var rng = path_rng(ps);
    if (tri.kind == SURFACE_DIELECTRIC) {
        let entering = cos_o > 0.0;
        let n = select(-ng, ng, entering);
        let eta = select(1.0 / mat.ior, mat.ior, entering);
        let f = fresnel_dielectric(dot(n, wo), eta);
        let reflected = 2.0 * dot(n, wo) * n - wo;
        var wi = reflected;
        if (sampler_1d(ps.sample_id, bounce_dim(ps.depth - 1u, DIM_LOBE), &rng) >= f) {
            var wt = vec3<f32>(0.0);
            if (refract(wo, n, eta, &wt)) {
                // Radiance is compressed by eta^2 entering a denser medium.
                ps.beta *= base_color_at(mat, uv) / (eta * eta);
                if (FEATURE_HOMOGENEOUS) {
                    let m = stack_cross(ps.medium, ps.outer, tri.interior, entering);
                    ps.medium = m.x;
                    ps.outer = m.y;
                }
                wi = wt;
            }
        }
        ps.o = offset_origin(p, ng, wi);
        ps.d = wi;
        ps.t0 = 0.0;
        ps.flags |= PATH_FLAG_SPECULAR;
        continue_or_finish(ps, slot, rng, 1.0);
        return;
    }
    // Opaque: next-event estimation with the BSDF from just above the surface.
    let n_side = select(-ng, ng, cos_o >= 0.0);
    let ns = shading_normal(tri, ps.hit_b1, ps.hit_b2, n_side);
    let frame = frame_from_z(ns);
    let base_color = base_color_at(mat, uv);
// #if FEATURE_DATA_PASSES
    record_albedo(slot, &ps, ps.beta * base_color, ns);
// #endif
    let bsdf = principled_new(base_color, mat.metallic, mat.roughness);
    let wo_l = frame_to_local(frame, wo);
    let p_off = offset_origin(p, n_side, n_side);
    let bounce = ps.depth - 1u;
    let u_select = sampler_1d(ps.sample_id, bounce_dim(bounce, DIM_LIGHT_SELECT), &rng);
    let u_light = sampler_2d(ps.sample_id, bounce_dim(bounce, DIM_LIGHT), &rng);
    let ls = light_sample(p_off, u_select, u_light);
    if (ls.valid && dot(n_side, ls.wi) > 0.0) {
        let wi_l = frame_to_local(frame, ls.wi);
        let f = principled_eval(bsdf, wo_l, wi_l) * abs(wi_l.z);
        let pdf_bsdf = principled_pdf(bsdf, wo_l, wi_l);
        if (any(f != vec3<f32>(0.0)) && ls.pdf > 0.0) {
            var w = 1.0;
            if (!ls.is_delta) {
                w = power_heuristic(ls.pdf, surface_mixture_pdf(p_off, ls.wi, pdf_bsdf));
            }
            push_shadow_ray(slot, p_off, ls.wi, ls.dist, ps.medium, ps.outer, ps.beta * ls.li * f * (w / ls.pdf));
// #if FEATURE_LIGHT_GROUPS
            ps.shadow_group = light_group_of(ls.source);
// #endif
        }
    }
    ps.rng_state = rng.state;
    ps.rng_inc = rng.inc;
    ps.flags |= PATH_FLAG_SURFACE;
    ps.surface_color = base_color;
    paths[slot] = ps;
    queue_push(QUEUE_PHASE, slot);
}
