// Mirrors Lights::sample, Lights::pdf_environment, spot_falloff and power_heuristic
// (src/integrator/lights.rs) for punctual lights, the constant environment and the area
// lights (emissive triangles, chosen by area times luminance), and uniform_sphere
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
        let l = lights[k];
        ls.is_delta = true;
        ls.pdf = pmf;
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
    let t = bvh_triangles[area_lights[i].prim];
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
