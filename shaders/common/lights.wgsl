// Mirrors Lights::sample, Lights::pdf_environment, spot_falloff and power_heuristic
// (src/integrator/lights.rs) for punctual lights and the constant environment, and
// uniform_sphere (src/sampling/warp.rs). Area lights (emissive triangles) are not mirrored:
// the GPU backend refuses scenes with surfaces other than inert null interfaces.
// Needs wavefront.wgsl (wf), phase.wgsl (PI, INV_4PI) and dda.wgsl (f32_inf).

@group(1) @binding(5) var<storage, read> lights: array<PunctualLight>;

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
    let n = wf.light_count + wf.has_env;
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
    // The environment (area lights are refused before this runs).
    ls.wi = uniform_sphere(u);
    ls.dist = f32_inf();
    ls.li = wf.env;
    ls.pdf = pmf * INV_4PI;
    ls.is_delta = false;
    ls.valid = true;
    return ls;
}
