// Mirrors Lights::sample, Lights::pdf_environment, spot_falloff and power_heuristic
// (src/render/lights.rs) for punctual lights, the constant environment and the area
// lights (emissive triangles, chosen by area times luminance), the guided selection at medium
// events (Lights::phase_selection, sample_selected, env_weight), and uniform_sphere
// (src/sampling/warp.rs). Needs wavefront.wgsl (wf), phase.wgsl (PI, INV_4PI), dda.wgsl
// (f32_inf) and surfaces.wgsl (triangles, materials, emitted).

@group(1) @binding(5) var<storage, read> lights: array<PunctualLight>;
@group(1) @binding(11) var<storage, read> area_lights: array<GpuAreaLight>;

// Lights::count and pmf: punctual lights, the environment and the area group, uniformly.
fn light_count() -> u32 {
    return wf.light_count + wf.has_env + select(0u, 1u, wf.area_count > 0u);
}

fn light_pmf() -> f32 {
    return 1.0 / f32(light_count());
}

// LightSample (wi towards the light; dist +inf for directional/environment).
struct LightSample {
    wi: vec3<f32>,
    dist: f32,
    li: vec3<f32>,
    pdf: f32,
    is_delta: bool,
    valid: bool,  // false where the CPU returns None
    // LightSample::source: the light's index among the punctual lights, the environment and
    // the area lights (light_count() order; light_group_of takes it to its group).
    source: u32,
}

// power_heuristic (beta = 2).
fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    let a = pdf_a * pdf_a;
    let b = pdf_b * pdf_b;
    if (a + b > 0.0 && a <= F32_MAX) {
        return a / (a + b);
    }
    if (a > F32_MAX) {
        return 1.0;
    }
    return 0.0;
}

// uniform_sphere (Archimedes).
fn uniform_sphere(u: vec2<f32>) -> vec3<f32> {
    let z = 1.0 - 2.0 * u.x;
    let r = sqrt(max(1.0 - z * z, 0.0));
    let phi = 2.0 * PI * u.y;
    return vec3<f32>(r * cos(phi), r * sin(phi), z);
}

// spot_falloff.
fn spot_falloff(l: PunctualLight, w_from_light: vec3<f32>) -> f32 {
    let cd = dot(l.direction, w_from_light);
    let scale = 1.0 / max(l.cos_inner - l.cos_outer, 1e-3);
    let a = clamp((cd - l.cos_outer) * scale, 0.0, 1.0);
    return a * a;
}

// Lights::sample: one light chosen uniformly among the punctual lights and the environment.
fn light_sample(p: vec3<f32>, u_select: f32, u: vec2<f32>) -> LightSample {
    var ls: LightSample;
    ls.valid = false;
    let n = light_count();
    if (n == 0u) {
        return ls;
    }
    let pmf = 1.0 / f32(n);
    let k = min(u32(u_select * f32(n)), n - 1u);
    if (k < wf.light_count) {
        ls = punctual_incident(k, p);
        ls.pdf = pmf;
        ls.source = k;
        return ls;
    }
    ls.source = k;
    if (wf.has_env != 0u && k == wf.light_count) {
// #if FEATURE_ENV_MAP
        let es = env_sample(u);
        ls.wi = es.wi;
        ls.dist = f32_inf();
        ls.li = es.le;
        ls.pdf = pmf * es.pdf;
        ls.is_delta = false;
        ls.valid = es.valid;
        return ls;
// #endif
// #if !FEATURE_ENV_MAP
        ls.wi = uniform_sphere(u);
        ls.dist = f32_inf();
        ls.li = wf.env;
        ls.pdf = pmf * INV_4PI;
        ls.is_delta = false;
        ls.valid = true;
        return ls;
// #endif
    }
// #if FEATURE_SURFACES
    if (wf.area_count == 0u) {
        return ls;
    }
    // The area group: u.x picks the triangle by the CDF (partition_point: the first entry
    // above u.x) and is remapped for the position; u.y is kept.
    var lo_i = 0u;
    var hi_i = wf.area_count;
    while (lo_i < hi_i) {
        let mid = (lo_i + hi_i) / 2u;
        if (area_lights[mid].cdf <= u.x) {
            lo_i = mid + 1u;
        } else {
            hi_i = mid;
        }
    }
    let i = min(lo_i, wf.area_count - 1u);
    var lo = 0.0;
    if (i > 0u) {
        lo = area_lights[i - 1u].cdf;
    }
    let ux = clamp((u.x - lo) / (area_lights[i].cdf - lo), 0.0, 1.0 - 1.1920929e-7);
    let t = scene_triangle(area_lights[i].prim);
    // Uniform point on the triangle (square-root parameterisation).
    let su = sqrt(ux);
    let b1 = 1.0 - su;
    let b2 = u.y * su;
    let q = t.p0 * (1.0 - b1 - b2) + t.p1 * b1 + t.p2 * b2;
    let c = triangle_cross(t);
    let area_t = 0.5 * length(c);
    let n_l = c / (2.0 * area_t);
    let to = q - p;
    let d2 = dot(to, to);
    let dist = sqrt(d2);
    if (!(dist > 0.0)) {
        return ls;
    }
    ls.wi = to / dist;
    ls.dist = dist;
    let cos_l = dot(n_l, -ls.wi);
    ls.li = emitted(materials[t.material], triangle_uv(area_lights[i].prim, b1, b2), cos_l);
    ls.pdf = pmf * t.light_pdf * d2 / max(abs(cos_l), 1e-8);
    ls.is_delta = false;
    ls.valid = true;
// #endif
    return ls;
}

// Lights::guided (decided on the host: WF_FLAG_GUIDED_LIGHTS).
fn lights_guided() -> bool {
    return (wf.flags & WF_FLAG_GUIDED_LIGHTS) != 0u;
}

// Lights::uniform_env_pmf.
fn uniform_env_pmf() -> f32 {
    return select(0.0, light_pmf(), wf.has_env != 0u);
}

// Whether the environment is constant (EnvLight::map is None): without FEATURE_ENV_MAP, or a
// one-pixel map (the generic variant's stand-in for a constant environment; the loader turns
// any map of equal pixels into a constant environment).
fn env_is_constant() -> bool {
    var c = true;
// #if FEATURE_ENV_MAP
    c = env_map.width == 1u && env_map.height == 1u;
// #endif
    return c;
}

// Lights::env_weight.
fn env_weight() -> f32 {
    if (wf.has_env == 0u) {
        return 0.0;
    }
    var w = luminance(wf.env);
// #if FEATURE_ENV_MAP
    if (!env_is_constant()) {
        w = luminance(env_map.scale) * (0.5 * PI) * env_map.integral;
    }
// #endif
    return w;
}

// Lights::punctual_incident (valid false at the light's own position).
fn punctual_incident(k: u32, p: vec3<f32>) -> LightSample {
    var ls: LightSample;
    ls.valid = false;
    ls.is_delta = true;
    let l = lights[k];
    if (l.kind == LIGHT_DIRECTIONAL) {
        ls.wi = -l.direction;
        ls.dist = f32_inf();
        ls.li = l.intensity;
        ls.valid = true;
        return ls;
    }
    let to = l.position - p;
    let d2 = dot(to, to);
    if (!(d2 > 0.0)) {
        return ls;
    }
    let dist = sqrt(d2);
    ls.wi = to / dist;
    ls.dist = dist;
    ls.li = l.intensity / d2;
    if (l.kind == LIGHT_SPOT) {
        ls.li *= spot_falloff(l, -ls.wi);
    }
    ls.valid = true;
    return ls;
}

// Selection: probabilities of the punctual lights, then the environment, then "no estimate".
struct Selection {
    pmf: array<f32, 6>,
    env: f32,
    env_by_phase: bool,
}

// Lights::phase_selection at a medium event at p with phase function ph and outgoing wo
// (called only when lights_guided()).
fn phase_selection(p: vec3<f32>, ph: GpuPhase, wo: vec3<f32>) -> Selection {
    var sel: Selection;
    let n = light_count();
    let np = min(wf.light_count, GUIDED_MAX_PUNCTUAL);
    var w: array<f32, 5>;
    for (var k = 0u; k < np; k++) {
        let ls = punctual_incident(k, p);
        w[k] = 0.0;
        if (ls.valid) {
            w[k] = luminance(ls.li) * phase_p(ph, wo, ls.wi);
        }
    }
    w[np] = env_weight();
    var sum = 0.0;
    for (var k = 0u; k <= np; k++) {
        sum += w[k];
    }
    let uniform = 1.0 / f32(n);
    let valid = sum > 0.0 && sum <= F32_MAX;
    let scale = (1.0 - GUIDED_UNIFORM_SHARE) / sum;
    let floor = GUIDED_UNIFORM_SHARE * uniform;
    // `sel` is zero-initialised (WGSL function variables are), so the entries past the
    // lights, the "no estimate" slot among them, start at 0.
    for (var k = 0u; k < n; k++) {
        sel.pmf[k] = select(uniform, w[k] * scale + floor, valid);
    }
    let constant_env = wf.has_env != 0u && env_is_constant();
    if (constant_env) {
        // The continuation ray's share of the sky goes to the punctual lights, or to no
        // estimate at all.
        let q_env = sel.pmf[np];
        let moved = wf.continuation_albedo * q_env;
        sel.pmf[np] = q_env - moved;
        var q_punctual = 0.0;
        for (var k = 0u; k < np; k++) {
            q_punctual += sel.pmf[k];
        }
        if (q_punctual > 0.0) {
            let f = 1.0 + moved / q_punctual;
            for (var k = 0u; k < np; k++) {
                sel.pmf[k] *= f;
            }
        } else {
            sel.pmf[n] = moved;
        }
    }
    sel.env = 0.0;
    sel.env_by_phase = false;
    if (wf.has_env != 0u) {
        sel.env = sel.pmf[np];
        sel.env_by_phase = constant_env;
    }
    return sel;
}

// Lights::sample_selected: the light by the selection's CDF, a constant environment's
// direction from the phase function (a rejection's further points from rng, the path's stream).
fn light_sample_selected(sel: Selection, p: vec3<f32>, ph: GpuPhase, wo: vec3<f32>, u_select: f32,
                         u: vec2<f32>, rng: ptr<function, Rng>) -> LightSample {
    let n = light_count();
    let np = wf.light_count;
    // sampling::sample_discrete over the selection and "no estimate" (entry n; u scaled by
    // the sum, zero entries skipped, rounding at the top to the last entry with mass); the
    // probability is the selection's.
    var sum = 0.0;
    for (var j = 0u; j <= n; j++) {
        sum += sel.pmf[j];
    }
    let up = u_select * sum;
    var k = n + 1u;
    var last = n + 1u;
    var acc = 0.0;
    for (var j = 0u; j <= n; j++) {
        if (sel.pmf[j] <= 0.0) {
            continue;
        }
        last = j;
        if (up < acc + sel.pmf[j]) {
            k = j;
            break;
        }
        acc += sel.pmf[j];
    }
    if (k == n + 1u) {
        k = last;
    }
    var ls: LightSample;
    ls.valid = false;
    if (k >= n) {
        return ls;
    }
    let pmf = sel.pmf[k];
    if (k < np) {
        ls = punctual_incident(k, p);
        ls.pdf = pmf;
        ls.source = k;
        return ls;
    }
    ls.source = k;
    if (wf.has_env == 0u) {
        return ls;
    }
    ls.dist = f32_inf();
    ls.is_delta = false;
    if (sel.env_by_phase) {
        let s = phase_sample(ph, wo, u, rng);
        ls.wi = s.wi;
        ls.li = wf.env;
        ls.pdf = pmf * s.pdf;
        ls.valid = true;
        return ls;
    }
// #if FEATURE_ENV_MAP
    let es = env_sample(u);
    ls.wi = es.wi;
    ls.li = es.le;
    ls.pdf = pmf * es.pdf;
    ls.valid = es.valid;
// #endif
    return ls;
}

// The escape's MIS weight against light sampling of the environment (radiance's no-hit
// branch), for a direction not drawn by a delta distribution. With guided selection the
// path's prev_pdf is already divided by the event's environment probability (or is P_env when
// the event drew the environment by its phase function: PATH_FLAG_ENV_BY_PHASE; both
// strategies then have the continuation's density, and P_env may be 0).
fn escape_mis(ps: GpuPathState, env_density: f32) -> f32 {
    if (lights_guided()) {
        if ((ps.flags & PATH_FLAG_ENV_BY_PHASE) != 0u) {
            return power_heuristic(1.0, ps.prev_pdf);
        }
        return power_heuristic(ps.prev_pdf, env_density);
    }
    return power_heuristic(ps.prev_pdf, light_pmf() * env_density);
}

// The path's prev_pdf after an event whose continuation has density `pdf`: as is, or with
// guided selection over the event's environment probability `env_pmf` (see escape_mis).
fn store_prev_pdf(ps: ptr<function, GpuPathState>, pdf: f32, env_pmf: f32, env_by_phase: bool) {
    (*ps).prev_pdf = pdf;
    (*ps).flags &= ~PATH_FLAG_ENV_BY_PHASE;
    if (lights_guided() && env_by_phase) {
        (*ps).prev_pdf = env_pmf;
        (*ps).flags |= PATH_FLAG_ENV_BY_PHASE;
    } else if (lights_guided() && env_pmf > 0.0) {
        (*ps).prev_pdf = pdf / env_pmf;
    }
}
