// Mirrors HenyeyGreenstein::p and HenyeyGreenstein::sample (src/volume/phase.rs), Phase::p
// and Phase::sample with Draine and Rayleigh (src/volume/phases.rs), and Frame::from_z /
// Frame::from_local (src/sampling/warp.rs). Convention (pbrt-v4): wo and wi
// both point away from the scattering point; forward scattering (g > 0) puts wi near -wo.
//
// The rearranged, cancellation-free forms of the CPU are kept: with a = |g| and
// x = 1 - sign(g) mu, 1 + g^2 - 2 g mu = (1 - a)^2 + 2 a x, and the sampled x is a product of
// positive terms. sin/cos/sqrt are WGSL's, so results agree with the CPU to a few ulps, not
// bit for bit.

const INV_4PI: f32 = 0.0795774715459476679;
const PI: f32 = 3.14159265358979323846;

struct PhaseSample {
    wi: vec3<f32>, // sampled direction, unit, pointing away from the scattering point
    pdf: f32,      // solid-angle density (equals p(wo, wi))
    weight: f32,   // p / pdf = 1
}

// HenyeyGreenstein::p_from_x.
fn hg_p_from_x(a: f32, x: f32) -> f32 {
    let one_minus_a = 1.0 - a;
    let denom = one_minus_a * one_minus_a + 2.0 * a * x;
    return INV_4PI * one_minus_a * (1.0 + a) / (denom * sqrt(denom));
}

// HenyeyGreenstein::p: the lobe coordinate from a chord, not a dot product.
fn hg_p(g: f32, wo: vec3<f32>, wi: vec3<f32>) -> f32 {
    var x: f32;
    if (g >= 0.0) {
        let s = wo + wi;
        x = 0.5 * dot(s, s);
    } else {
        let s = wo - wi;
        x = 0.5 * dot(s, s);
    }
    return hg_p_from_x(abs(g), min(x, 2.0));
}

// Frame::from_z followed by Frame::from_local (Duff et al. 2017 branchless basis).
fn frame_from_z_to_world(n: vec3<f32>, v: vec3<f32>) -> vec3<f32> {
    let s = select(1.0, -1.0, (bitcast<u32>(n.z) & 0x80000000u) != 0u);
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    let x = vec3<f32>(1.0 + s * n.x * n.x * a, s * b, -s * n.x);
    let y = vec3<f32>(b, s + n.y * n.y * a, -n.y);
    return v.x * x + v.y * y + v.z * n;
}

// HenyeyGreenstein::sample: u.x picks the cosine, u.y the azimuth around -wo.
fn hg_sample(g: f32, wo: vec3<f32>, u: vec2<f32>) -> PhaseSample {
    let a = abs(g);
    let v = 1.0 - 2.0 * u.x;
    let one_minus_a = 1.0 - a;
    let one_plus_av = 1.0 + a * v;
    let s = one_minus_a * (1.0 + a) / one_plus_av;
    let x = clamp(one_minus_a * u.x * (s + one_minus_a) / one_plus_av, 0.0, 2.0);
    let pdf = hg_p_from_x(a, x);
    let sin_theta = sqrt(max(x * (2.0 - x), 0.0));
    let cos_theta = select(x - 1.0, 1.0 - x, g >= 0.0);
    let phi = 2.0 * PI * u.y;
    let local = vec3<f32>(sin_theta * cos(phi), sin_theta * sin(phi), cos_theta);
    let wi = normalize(frame_from_z_to_world(-wo, local));
    return PhaseSample(wi, pdf, 1.0);
}

// f32::EPSILON.
const F32_EPSILON: f32 = 1.1920929e-7;

// A Henyey-Greenstein phase function of asymmetry g.
fn phase_hg(g: f32) -> GpuPhase {
    return GpuPhase(PHASE_HG, g, 0.0, 0.0, 0.0, 0u, 0u, 0u);
}

// Phase::p. Without FEATURE_PHASES every medium is Henyey-Greenstein.
fn phase_p(ph: GpuPhase, wo: vec3<f32>, wi: vec3<f32>) -> f32 {
// #if FEATURE_PHASES
    if (ph.kind != PHASE_HG) {
        return phase_p_general(ph, wo, wi);
    }
// #endif
    return hg_p(ph.g_a, wo, wi);
}

// Phase::mean_cosine: the mean scattering cosine (Draine::mean_cosine for Draine's lobes).
fn phase_mean_cosine(ph: GpuPhase) -> f32 {
// #if FEATURE_PHASES
    switch ph.kind {
        case PHASE_TWO_LOBE: {
            return ph.w * ph.g_a + (1.0 - ph.w) * ph.g_b;
        }
        case PHASE_DRAINE: {
            return draine_mean_cosine(ph.g_a, ph.alpha);
        }
        case PHASE_MIE: {
            return (1.0 - ph.w) * ph.g_a + ph.w * draine_mean_cosine(ph.g_b, ph.alpha);
        }
        case PHASE_RAYLEIGH: {
            return 0.0;
        }
        default: {}
    }
// #endif
    return ph.g_a;
}

// Phase::sample: u decides, rng gives the further points a rejection needs (Draine), drawn
// from the path's own stream as the CPU draws them.
fn phase_sample(ph: GpuPhase, wo: vec3<f32>, u: vec2<f32>, rng: ptr<function, Rng>) -> PhaseSample {
// #if FEATURE_PHASES
    if (ph.kind != PHASE_HG) {
        return phase_sample_general(ph, wo, u, rng);
    }
// #endif
    return hg_sample(ph.g_a, wo, u);
}

// #if FEATURE_PHASES
// Draine::shape: HG reshaped by (1 + alpha mu^2), normalised.
fn draine_shape(g: f32, alpha: f32, mu: f32) -> f32 {
    return (1.0 + alpha * mu * mu) / (1.0 + alpha * (1.0 + 2.0 * g * g) / 3.0);
}

// Draine::mean_cosine.
fn draine_mean_cosine(g: f32, alpha: f32) -> f32 {
    return g * (1.0 + alpha * (3.0 + 2.0 * g * g) / 5.0) / (1.0 + alpha * (1.0 + 2.0 * g * g) / 3.0);
}

// Draine::p.
fn draine_p(g: f32, alpha: f32, wo: vec3<f32>, wi: vec3<f32>) -> f32 {
    return hg_p(g, wo, wi) * draine_shape(g, alpha, -dot(wo, wi));
}

// Draine::sample: HG candidates accepted with (1 + alpha mu^2) / max(1, 1 + alpha); each
// accept test and each new candidate takes the next two uniforms of rng (Rng::uniform_vec2).
fn draine_sample(g: f32, alpha: f32, wo: vec3<f32>, u0: vec2<f32>,
                 rng: ptr<function, Rng>) -> PhaseSample {
    let bound = max(1.0 + alpha, 1.0);
    var u = u0;
    for (var i = 0u; i < 256u; i++) {
        let s = hg_sample(g, wo, u);
        let mu = -dot(wo, s.wi);
        if (rng_uniform_vec2(rng).x * bound < 1.0 + alpha * mu * mu) {
            return PhaseSample(s.wi, draine_p(g, alpha, wo, s.wi), 1.0);
        }
        u = rng_uniform_vec2(rng);
    }
    let s = hg_sample(g, wo, u);
    return PhaseSample(s.wi, draine_p(g, alpha, wo, s.wi), 1.0);
}

// Phase::p for the kinds other than Henyey-Greenstein.
fn phase_p_general(ph: GpuPhase, wo: vec3<f32>, wi: vec3<f32>) -> f32 {
    switch ph.kind {
        case PHASE_TWO_LOBE: {
            return ph.w * hg_p(ph.g_a, wo, wi) + (1.0 - ph.w) * hg_p(ph.g_b, wo, wi);
        }
        case PHASE_DRAINE: {
            return draine_p(ph.g_a, ph.alpha, wo, wi);
        }
        case PHASE_MIE: {
            return (1.0 - ph.w) * hg_p(ph.g_a, wo, wi) + ph.w * draine_p(ph.g_b, ph.alpha, wo, wi);
        }
        case PHASE_RAYLEIGH: {
            let mu = -dot(wo, wi);
            return 3.0 * INV_4PI / 4.0 * (1.0 + mu * mu);
        }
        default: {
            return hg_p(ph.g_a, wo, wi);
        }
    }
}

// Phase::sample's lobe choice: u.x below w picks the first lobe, and the rest of u.x,
// rescaled, stays the lobe's own (u stays stratified).
fn phase_pick(w: f32, u: vec2<f32>) -> vec2<f32> {
    if (u.x < w) {
        return vec2<f32>(u.x / w, u.y);
    }
    return vec2<f32>(min((u.x - w) / (1.0 - w), 1.0 - F32_EPSILON), u.y);
}

// Phase::sample for the kinds other than Henyey-Greenstein.
fn phase_sample_general(ph: GpuPhase, wo: vec3<f32>, u: vec2<f32>,
                        rng: ptr<function, Rng>) -> PhaseSample {
    var wi: vec3<f32>;
    switch ph.kind {
        case PHASE_DRAINE: {
            return draine_sample(ph.g_a, ph.alpha, wo, u, rng);
        }
        case PHASE_TWO_LOBE: {
            wi = hg_sample(select(ph.g_b, ph.g_a, u.x < ph.w), wo, phase_pick(ph.w, u)).wi;
        }
        case PHASE_MIE: {
            if (u.x < ph.w) {
                wi = draine_sample(ph.g_b, ph.alpha, wo, phase_pick(ph.w, u), rng).wi;
            } else {
                wi = hg_sample(ph.g_a, wo, phase_pick(ph.w, u)).wi;
            }
        }
        case PHASE_RAYLEIGH: {
            wi = rayleigh_direction(wo, u);
        }
        default: {
            return hg_sample(ph.g_a, wo, u);
        }
    }
    return PhaseSample(wi, phase_p_general(ph, wo, wi), 1.0);
}

// rayleigh_direction: the root mu = z - 1/z of mu^3 + 3 mu - 4 xi = 0, xi = 2 u.x - 1, with
// z = cbrt(2 xi + sqrt(4 xi^2 + 1)) (Cardano), as the CPU takes it in f64. In f32 it is taken
// for |xi| (the root is odd in xi) and rearranged so nothing cancels:
// z^3 - 1 = 2a + 4a^2 / (s + 1) with s = sqrt(4a^2 + 1), and
// z - 1/z = (z^3 - 1)(z + 1) / (z (z^2 + z + 1)).
fn rayleigh_direction(wo: vec3<f32>, u: vec2<f32>) -> vec3<f32> {
    let xi = 2.0 * u.x - 1.0;
    let a = abs(xi);
    let s = sqrt(4.0 * a * a + 1.0);
    let z3_minus_1 = 2.0 * a + 4.0 * a * a / (s + 1.0);
    let z = pow(1.0 + z3_minus_1, 1.0 / 3.0);
    let m = z3_minus_1 * (z + 1.0) / (z * (z * z + z + 1.0));
    let mu = clamp(select(m, -m, xi < 0.0), -1.0, 1.0);
    let sin_theta = sqrt(max(1.0 - mu * mu, 0.0));
    let phi = 2.0 * PI * u.y;
    let local = vec3<f32>(sin_theta * cos(phi), sin_theta * sin(phi), mu);
    return normalize(frame_from_z_to_world(-wo, local));
}
// #endif
