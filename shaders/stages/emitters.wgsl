// Mirrors emitters (src/integrator/path.rs) and emitter_event (src/integrator/emitters.rs):
// Stage::Emitters, next-event estimation towards the emitting media at every scattering event
// the phase stage is about to continue (a medium event, or an opaque surface's with
// PATH_FLAG_SURFACE). It runs after the shadow stage has tracked the event's own shadow ray
// and before the phase stage samples the next direction, so its five uniforms and its shadow
// ray's come from the path's stream where the CPU draws them. A point of the emitting media
// (MediaLights::sample), kept with probability min(1, Le / e_c); its contribution
// w_L f T Le / (p_V r^2 P_keep), f the phase function or the BSDF times the cosine and w_L the
// power heuristic against the flights' emission, goes to the path's radiance and, with the
// passes, to the event's pass and the medium's light group.

// The scattering factor f(wi) at the path's event and its direction density (emitters'
// `scatter` closures): the phase function in a medium; at an opaque surface the BSDF times
// the cosine from the offset point `p` (none below the surface). `.w` is the density.
fn emitter_scatter(ps: GpuPathState, wi: vec3<f32>) -> vec4<f32> {
    let wo = -ps.d;
// #if FEATURE_SURFACES
    if ((ps.flags & PATH_FLAG_SURFACE) != 0u) {
        let tri = scene_triangle(ps.hit_prim);
        let mat = materials[tri.material];
        let ng = normalize_or_zero(triangle_cross(tri));
        let n_side = select(-ng, ng, dot(ng, wo) >= 0.0);
        if (dot(n_side, wi) <= 0.0) {
            return vec4<f32>(0.0);
        }
        let frame = frame_from_z(shading_normal(tri, ps.hit_b1, ps.hit_b2, n_side));
        let bsdf = principled_new(ps.surface_color, mat.metallic, mat.roughness);
        let wo_l = frame_to_local(frame, wo);
        let wi_l = frame_to_local(frame, wi);
        let f = principled_eval(bsdf, wo_l, wi_l) * abs(wi_l.z);
        return vec4<f32>(f, surface_mixture_pdf(emitter_origin(ps), wi,
                                                principled_pdf(bsdf, wo_l, wi_l)));
    }
// #endif
    let f = phase_p(path_phase(ps), wo, wi);
    return vec4<f32>(vec3<f32>(f), lamps_mixture_pdf(emitter_origin(ps), wi, f));
}

// The point the path's event shades from: the medium event's, or just above the surface
// (shade_surface's p_off).
fn emitter_origin(ps: GpuPathState) -> vec3<f32> {
// #if FEATURE_SURFACES
    if ((ps.flags & PATH_FLAG_SURFACE) != 0u) {
        let tri = scene_triangle(ps.hit_prim);
        let ng = normalize_or_zero(triangle_cross(tri));
        let n_side = select(-ng, ng, dot(ng, -ps.d) >= 0.0);
        return offset_origin(ps.o + ps.hit_t * ps.d, n_side, n_side);
    }
// #endif
    return ps.o;
}

// Run on every path slot of its queue (the entry point src/backend/gpu/shader.rs adds).
fn emitters(slot: u32) {
// #if FEATURE_EMISSION
    if (wf.media_light_cells == 0u) {
        return;
    }
    var ps = paths[slot];
    var rng = path_rng(ps);
    let u_select = rng_uniform(&rng);
    let ux = rng_uniform(&rng);
    let uy = rng_uniform(&rng);
    let uz = rng_uniform(&rng);
    let u_keep = rng_uniform(&rng);
    ps.rng_state = rng.state;
    ps.rng_inc = rng.inc;
    let p = emitter_origin(ps);
    let s = media_light_sample(p, u_select, vec3<f32>(ux, uy, uz));
    if (!(s.pdf_volume > 0.0)) {
        paths[slot] = ps;
        return;
    }
    var e = emission;
// #if FEATURE_MIXTURE
    e = vdb_media[s.vdb].emission;
// #endif
    var tr: Tracker;
    let le = emission_radiance_of(&tr, e, s.y);
    ps.lookups += tr.emission_lookups;
    add_wide(WIDE_EMISSION_LOOKUPS, tr.emission_lookups);
    let keep = min(max(le.x, max(le.y, le.z)) / s.weight, 1.0);
    let to = s.y - p;
    let d2 = dot(to, to);
    let dist = sqrt(d2);
    if (u_keep < keep && dist > 0.0) {
        let wi = to / dist;
        let sc = emitter_scatter(ps, wi);
        let f = sc.xyz;
        let p_l = s.pdf_volume * d2;
        if (any(f != vec3<f32>(0.0)) && p_l > 0.0) {
            let w = power_heuristic(p_l, sc.w * s.sigma_maj);
            let t = shadow_transmittance(p, wi, dist, ps.medium, ps.outer, &ps);
            let x = ps.beta * (t * f * le * (w / (p_l * keep)));
            ps.l += x;
// #if FEATURE_LIGHT_PASSES
            gather_pass(slot, ps, x, PASS_EMISSION);
// #endif
// #if FEATURE_LIGHT_GROUPS
            gather_group(slot, e.light_group, x);
// #endif
        }
    }
    paths[slot] = ps;
// #endif
}
