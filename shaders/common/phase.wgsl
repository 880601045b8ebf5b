// Mirrors HenyeyGreenstein::p and HenyeyGreenstein::sample (src/volume/phase.rs) and
// Frame::from_z / Frame::from_local (src/sampling/warp.rs). Convention (pbrt-v4): wo and wi
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
