// Mirrors src/integrator/bsdf.rs (Principled: a Lambertian base plus a GGX reflection lobe
// with Schlick's Fresnel and Smith's height-correlated masking; fresnel_dielectric, refract)
// and Frame, concentric_disk and cosine_hemisphere (src/sampling/warp.rs). Everything works
// in the local frame whose z is the shading normal on wo's side. Needs phase.wgsl (PI).

// Frame::from_z (Duff et al. 2017, "Building an Orthonormal Basis, Revisited"): x and y of
// the frame whose z is the unit vector n.
struct Frame {
    x: vec3<f32>,
    y: vec3<f32>,
    z: vec3<f32>,
}

fn frame_from_z(n: vec3<f32>) -> Frame {
    // f32::copysign(1, n.z): the sign bit decides, so -0.0 counts as negative.
    let s = select(1.0, -1.0, (bitcast<u32>(n.z) & 0x80000000u) != 0u);
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    return Frame(vec3<f32>(1.0 + s * n.x * n.x * a, s * b, -s * n.x),
                 vec3<f32>(b, s + n.y * n.y * a, -n.y), n);
}

fn frame_to_local(f: Frame, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(v, f.x), dot(v, f.y), dot(v, f.z));
}

fn frame_from_local(f: Frame, v: vec3<f32>) -> vec3<f32> {
    return v.x * f.x + v.y * f.y + v.z * f.z;
}

// concentric_disk (Shirley & Chiu 1997).
fn concentric_disk(u: vec2<f32>) -> vec2<f32> {
    let o = 2.0 * u - vec2<f32>(1.0);
    if (o.x == 0.0 && o.y == 0.0) {
        return vec2<f32>(0.0);
    }
    var r = o.y;
    var theta = 0.5 * PI - 0.25 * PI * (o.x / o.y);
    if (abs(o.x) > abs(o.y)) {
        r = o.x;
        theta = 0.25 * PI * (o.y / o.x);
    }
    return r * vec2<f32>(cos(theta), sin(theta));
}

// cosine_hemisphere (Malley's method: lift the concentric disk).
fn cosine_hemisphere(u: vec2<f32>) -> vec3<f32> {
    let d = concentric_disk(u);
    return vec3<f32>(d.x, d.y, sqrt(max(1.0 - dot(d, d), 0.0)));
}

fn luminance(c: vec3<f32>) -> f32 {
    return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
}

// Principled: the lobes of one opaque surface point.
struct Principled {
    diffuse: vec3<f32>,
    f0: vec3<f32>,
    alpha: f32,   // GGX alpha = roughness^2, kept away from 0
    p_spec: f32,  // probability of sampling the specular lobe
}

// Principled::new: F0 = mix(0.04, base, metallic); the specular lobe is sampled in
// proportion to its luminance against the diffuse one's, within [0.1, 0.9].
fn principled_new(base: vec3<f32>, metallic: f32, roughness: f32) -> Principled {
    let diffuse = base * (1.0 - metallic);
    let f0 = vec3<f32>(0.04) + (base - vec3<f32>(0.04)) * metallic;
    let ls = luminance(f0);
    let ld = luminance(diffuse);
    var p_spec = 0.0;
    if (ld <= 0.0) {
        p_spec = 1.0;
    } else if (ls > 0.0) {
        p_spec = clamp(ls / (ls + ld), 0.1, 0.9);
    }
    return Principled(diffuse, f0, max(roughness * roughness, 2e-3), p_spec);
}

// GGX (Trowbridge-Reitz) normal distribution D(h).
fn ggx_d(b: Principled, cos_h: f32) -> f32 {
    let a2 = b.alpha * b.alpha;
    let c2 = cos_h * cos_h;
    let t = c2 * (a2 - 1.0) + 1.0;
    return a2 / (PI * t * t);
}

// Smith's Lambda for GGX.
fn ggx_lambda(b: Principled, cos: f32) -> f32 {
    let c2 = max(cos * cos, 1e-12);
    let tan2 = (1.0 - c2) / c2;
    return 0.5 * (sqrt(1.0 + b.alpha * b.alpha * tan2) - 1.0);
}

// Schlick's Fresnel.
fn schlick(b: Principled, cos: f32) -> vec3<f32> {
    let x = 1.0 - clamp(cos, 0.0, 1.0);
    let m = x * x * x * x * x;
    return b.f0 + (vec3<f32>(1.0) - b.f0) * m;
}

// Principled::eval: f(wo, wi), both above the surface, else 0.
fn principled_eval(b: Principled, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
    if (wo.z <= 0.0 || wi.z <= 0.0) {
        return vec3<f32>(0.0);
    }
    var f = b.diffuse / PI;
    if (b.p_spec > 0.0) {
        let h = normalize(wo + wi);
        let g = 1.0 / (1.0 + ggx_lambda(b, wo.z) + ggx_lambda(b, wi.z));
        f += schlick(b, dot(wo, h)) * (ggx_d(b, h.z) * g / (4.0 * wo.z * wi.z));
    }
    return f;
}

// Principled::pdf: the lobe mixture's solid-angle density of wi.
fn principled_pdf(b: Principled, wo: vec3<f32>, wi: vec3<f32>) -> f32 {
    if (wo.z <= 0.0 || wi.z <= 0.0) {
        return 0.0;
    }
    let h = normalize(wo + wi);
    let pdf_spec = ggx_d(b, h.z) * h.z / (4.0 * max(dot(wo, h), 1e-8));
    return b.p_spec * pdf_spec + (1.0 - b.p_spec) * max(wi.z, 0.0) * (1.0 / PI);
}

// BsdfSample; `valid` false where the CPU returns None.
struct BsdfSample {
    wi: vec3<f32>,
    weight: vec3<f32>,  // f |cos| / pdf
    pdf: f32,
    valid: bool,
}

// Principled::sample: u_lobe picks the lobe, u the direction.
fn principled_sample(b: Principled, wo: vec3<f32>, u_lobe: f32, u: vec2<f32>) -> BsdfSample {
    var s: BsdfSample;
    s.valid = false;
    if (wo.z <= 0.0) {
        return s;
    }
    var wi: vec3<f32>;
    if (u_lobe < b.p_spec) {
        // Distribution of normals D(h) cos(h): cos^2 = (1 - u) / (1 + (a^2 - 1) u).
        let a2 = b.alpha * b.alpha;
        let cos2 = (1.0 - u.x) / (1.0 + (a2 - 1.0) * u.x);
        let cos_h = sqrt(cos2);
        let sin_h = sqrt(max(1.0 - cos2, 0.0));
        let phi = 2.0 * PI * u.y;
        let h = vec3<f32>(sin_h * cos(phi), sin_h * sin(phi), cos_h);
        wi = 2.0 * dot(wo, h) * h - wo;
    } else {
        wi = cosine_hemisphere(u);
    }
    if (wi.z <= 0.0) {
        return s;
    }
    let pdf = principled_pdf(b, wo, wi);
    if (!(pdf > 0.0)) {
        return s;
    }
    s.wi = wi;
    s.weight = principled_eval(b, wo, wi) * wi.z / pdf;
    s.pdf = pdf;
    s.valid = true;
    return s;
}

// fresnel_dielectric: reflectance of a smooth dielectric for cos_i (incident side) and
// relative index eta = n_t / n_i; 1 under total internal reflection.
fn fresnel_dielectric(cos_i_in: f32, eta: f32) -> f32 {
    let cos_i = clamp(cos_i_in, 0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if (sin2_t >= 1.0) {
        return 1.0;
    }
    let cos_t = sqrt(1.0 - sin2_t);
    let r_par = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    return 0.5 * (r_par * r_par + r_perp * r_perp);
}

// refract: wo (pointing away, on n's side) through relative index eta; false under total
// internal reflection.
fn refract(wo: vec3<f32>, n: vec3<f32>, eta: f32, wt: ptr<function, vec3<f32>>) -> bool {
    let cos_i = dot(n, wo);
    let sin2_t = max(1.0 - cos_i * cos_i, 0.0) / (eta * eta);
    if (sin2_t >= 1.0) {
        return false;
    }
    let cos_t = sqrt(1.0 - sin2_t);
    *wt = -wo / eta + (cos_i / eta - cos_t) * n;
    return true;
}
