// Mirrors src/integrator/glow.rs: pixel jitter drawn towards the film points of lamps inside
// media (Glows::jitter), the weight 1 / p(q) each camera sample then carries, and the
// directions medium and surface events draw towards those lamps (Lamps).

const GLOW_TAU: f32 = 6.28318530717958647692;
const GLOW_PI: f32 = 3.14159265358979323846;

// Glows::centres[k]: two film points to a row of wf.glows.
fn glow_centre(k: u32) -> vec2<f32> {
    let row = wf.glows[k / 2u];
    if ((k & 1u) == 0u) {
        return row.xy;
    }
    return row.zw;
}

// reaches (glow.rs): the distance from the glow's centre c to the pixel's square is below
// GLOW_RADIUS.
fn glow_reaches(c: vec2<f32>, corner: vec2<f32>) -> bool {
    let d = max(max(corner - c, c - (corner + vec2<f32>(1.0))), vec2<f32>(0.0));
    return dot(d, d) < GLOW_RADIUS * GLOW_RADIUS;
}

// fan (glow.rs): the directions from c that meet the pixel, as the first one's angle in .x
// and the fan's angle in .y (2 pi where c is inside the pixel).
fn glow_fan(c: vec2<f32>, corner: vec2<f32>) -> vec2<f32> {
    if (all(c > corner) && all(c < corner + vec2<f32>(1.0))) {
        return vec2<f32>(0.0, GLOW_TAU);
    }
    let mid = corner + vec2<f32>(0.5) - c;
    let base = atan2(mid.y, mid.x);
    var lo = 0.0;
    var hi = 0.0;
    for (var k = 0u; k < 4u; k++) {
        let v = corner + vec2<f32>(f32(k & 1u), f32(k >> 1u)) - c;
        if (any(v != vec2<f32>(0.0))) {
            var rel = atan2(v.y, v.x) - base;
            if (rel > GLOW_PI) {
                rel -= GLOW_TAU;
            } else if (rel < -GLOW_PI) {
                rel += GLOW_TAU;
            }
            lo = min(lo, rel);
            hi = max(hi, rel);
        }
    }
    return vec2<f32>(base + lo, hi - lo);
}

// chord (glow.rs): the part [t_in, t_out] of the ray from c along unit e inside the pixel.
fn glow_chord(c: vec2<f32>, e: vec2<f32>, corner: vec2<f32>) -> vec2<f32> {
    var t_in = 0.0;
    var t_out = 3.0e38;
    for (var i = 0u; i < 2u; i++) {
        let lo = corner[i] - c[i];
        let hi = corner[i] + 1.0 - c[i];
        if (e[i] == 0.0) {
            if (!(lo <= 0.0 && hi >= 0.0)) {
                return vec2<f32>(0.0);
            }
        } else {
            let t1 = lo / e[i];
            let t2 = hi / e[i];
            t_in = max(t_in, min(t1, t2));
            t_out = min(t_out, max(t1, t2));
        }
    }
    return vec2<f32>(t_in, t_out);
}

// density (glow.rs): the glow centred at c's density at the point q of the pixel.
fn glow_density(c: vec2<f32>, corner: vec2<f32>, q: vec2<f32>) -> f32 {
    let v = corner + q - c;
    let r = length(v);
    if (!(r > 0.0)) {
        return 0.0;
    }
    let chord = glow_chord(c, v / r, corner);
    let fan = glow_fan(c, corner).y;
    let len = chord.y - chord.x;
    if (len > 0.0 && fan > 0.0) {
        return 1.0 / (fan * r * len);
    }
    return 0.0;
}

// Glows::jitter: pixel (x, y)'s jitter for the uniform numbers u in .xy, its weight in .z.
fn glow_jitter(x: u32, y: u32, u: vec2<f32>) -> vec3<f32> {
    if (wf.glow_count == 0u) {
        return vec3<f32>(u, 1.0);
    }
    let corner = vec2<f32>(f32(x), f32(y));
    var near: array<u32, 4>;
    var n = 0u;
    for (var k = 0u; k < wf.glow_count; k++) {
        if (glow_reaches(glow_centre(k), corner)) {
            near[n] = k;
            n++;
        }
    }
    if (n == 0u) {
        return vec3<f32>(u, 1.0);
    }
    var q: vec2<f32>;
    if (u.x < GLOW_SHARE) {
        let s = u.x / GLOW_SHARE * f32(n);
        let pick = min(u32(s), n - 1u);
        let c = glow_centre(near[pick]);
        let fan = glow_fan(c, corner);
        let phi = fan.x + fan.y * (s - f32(pick));
        let e = vec2<f32>(cos(phi), sin(phi));
        let chord = glow_chord(c, e, corner);
        q = c + (chord.x + u.y * (chord.y - chord.x)) * e - corner;
    } else {
        q = vec2<f32>((u.x - GLOW_SHARE) / (1.0 - GLOW_SHARE), u.y);
    }
    if (!(q.x >= 0.0 && q.x < 1.0 && q.y >= 0.0 && q.y < 1.0)) {
        return vec3<f32>(q, 0.0);
    }
    var glow = 0.0;
    for (var i = 0u; i < n; i++) {
        glow += glow_density(glow_centre(near[i]), corner, q);
    }
    return vec3<f32>(q, 1.0 / ((1.0 - GLOW_SHARE) + GLOW_SHARE / f32(n) * glow));
}

// The weight generate's jitter gave camera sample `sample_id` (render_tile's `weight`), from
// its stream opened afresh: the accumulate stage scales the sample by it. Pixels no glow
// reaches weigh 1 without drawing the sampler's point again.
fn glow_weight(sample_id: u32) -> f32 {
    let pixel = path_pixel(sample_id);
    let corner = vec2<f32>(f32(pixel % wf.width), f32(pixel / wf.width));
    var reached = false;
    for (var k = 0u; k < wf.glow_count; k++) {
        reached = reached || glow_reaches(glow_centre(k), corner);
    }
    if (!reached) {
        return 1.0;
    }
    var rng = rng_new(pixel, path_sample_index(sample_id), wf.seed);
    let u = sampler_2d(sample_id, DIM_JITTER, &rng);
    return glow_jitter(pixel % wf.width, pixel / wf.width, u).z;
}

// Lamps::mixture_pdf: the density of a scattering direction whose phase function or BSDF
// density is `pdf`, mixed with the cones where some lamp is inside media.
fn lamps_mixture_pdf(x: vec3<f32>, wi: vec3<f32>, pdf: f32) -> f32 {
    if (wf.lamp_count == 0u) {
        return pdf;
    }
    return (1.0 - CONE_SHARE) * pdf + CONE_SHARE * lamps_pdf(x, wi);
}

// Lamps::guides_surfaces: whether surface events draw some of their directions from the
// lamps or the lit media.
fn lamps_guide_surfaces() -> bool {
    return wf.lamp_count > 0u || wf.lit_count > 0u;
}

// Lamps::surface_mixture_pdf: lamps_mixture_pdf at a surface, mixed with the lit media's
// boxes too.
fn surface_mixture_pdf(x: vec3<f32>, wi: vec3<f32>, pdf: f32) -> f32 {
    if (wf.lit_count == 0u) {
        return lamps_mixture_pdf(x, wi, pdf);
    }
    let cones = select(0.0, CONE_SHARE, wf.lamp_count > 0u);
    var p = (1.0 - cones - LIT_SHARE) * pdf + LIT_SHARE * lit_pdf(x, wi);
    if (wf.lamp_count > 0u) {
        p += cones * lamps_pdf(x, wi);
    }
    return p;
}

// LitMedia::pdf (src/integrator/lit_media.rs): the boxes' mixture density at x, each box's
// (t_1^3 - t_0^3) / (3 V) along the chord wi cuts from it.
fn lit_pdf(x: vec3<f32>, wi: vec3<f32>) -> f32 {
    var sum = 0.0;
    for (var k = 0u; k < wf.lit_count; k++) {
        let lo = wf.lit_boxes[2u * k].xyz;
        let hi = wf.lit_boxes[2u * k + 1u].xyz;
        var t = vec2<f32>(0.0);
        if (aabb_intersect(lo, hi, x, wi, 0.0, f32_inf(), &t)) {
            let e = max(hi - lo, vec3<f32>(0.0));
            sum += (t.y * t.y * t.y - t.x * t.x * t.x) / (3.0 * (e.x * e.y * e.z));
        }
    }
    return sum / f32(wf.lit_count);
}

// LitMedia::sample: a direction from x towards the point u of box `pick`.
fn lit_sample(x: vec3<f32>, pick: u32, u: vec3<f32>) -> vec3<f32> {
    let lo = wf.lit_boxes[2u * pick].xyz;
    let hi = wf.lit_boxes[2u * pick + 1u].xyz;
    return normalize_or_zero(lo + u * (hi - lo) - x);
}

// Lamps::pdf: the cones' mixture density at x.
fn lamps_pdf(x: vec3<f32>, wi: vec3<f32>) -> f32 {
    var sum = 0.0;
    for (var k = 0u; k < wf.lamp_count; k++) {
        let axis = normalize_or_zero(wf.lamps[k].xyz - x);
        let c = clamp(dot(axis, wi), -1.0, 1.0);
        if (c > COS_CONE_ANGLE) {
            // From the cross product: near the axis 1 - c^2 loses every digit.
            let s = length(cross(axis, wi));
            sum += 1.0 / (GLOW_TAU * CONE_ANGLE * max(s, 1e-7));
        }
    }
    return sum / f32(wf.lamp_count);
}

// Lamps::sample: a direction at x in lamp `pick`'s cone.
fn lamps_sample(x: vec3<f32>, pick: u32, u: vec2<f32>) -> vec3<f32> {
    let axis = normalize_or_zero(wf.lamps[pick].xyz - x);
    let theta = CONE_ANGLE * u.x;
    let phi = GLOW_TAU * u.y;
    let local = vec3<f32>(sin(theta) * cos(phi), sin(theta) * sin(phi), cos(theta));
    return normalize(frame_from_z_to_world(axis, local));
}

// sample_phase's medium event with lamps (wf.lamp_count > 0): a share CONE_SHARE of the
// directions from the lamps' cones, the rest from the phase function, weighed by the mixture.
fn lamps_phase_sample(ph: GpuPhase, x: vec3<f32>, wo: vec3<f32>, u: vec2<f32>,
                      rng: ptr<function, Rng>) -> PhaseSample {
    let u_c = rng_uniform(rng);
    var wi: vec3<f32>;
    if (u_c < CONE_SHARE) {
        let pick = min(u32(u_c / CONE_SHARE * f32(wf.lamp_count)), wf.lamp_count - 1u);
        wi = lamps_sample(x, pick, u);
    } else {
        wi = phase_sample(ph, wo, u, rng).wi;
    }
    let f = phase_p(ph, wo, wi);
    let pdf = lamps_mixture_pdf(x, wi, f);
    var w = 0.0;
    if (pdf > 0.0) {
        w = f / pdf;
    }
    return PhaseSample(wi, pdf, w);
}

// Lamps::sample_bsdf: a surface's next direction (in the shading frame) with lamps or lit
// media (lamps_guide_surfaces): a share CONE_SHARE from the lamps' cones, a share LIT_SHARE
// from the lit media's boxes, the rest from the BSDF, weighed by the mixture; not valid below
// the surface or where the BSDF's sampling fails.
fn lamps_bsdf_sample(b: Principled, frame: Frame, wo: vec3<f32>, x: vec3<f32>, u_lobe: f32,
                     u: vec2<f32>, rng: ptr<function, Rng>) -> BsdfSample {
    let u_c = rng_uniform(rng);
    var s: BsdfSample;
    s.valid = false;
    var wi: vec3<f32>;
    let cones = select(0.0, CONE_SHARE, wf.lamp_count > 0u);
    let boxes = select(0.0, LIT_SHARE, wf.lit_count > 0u);
    if (u_c < cones) {
        let pick = min(u32(u_c / cones * f32(wf.lamp_count)), wf.lamp_count - 1u);
        wi = frame_to_local(frame, lamps_sample(x, pick, u));
    } else if (u_c < cones + boxes) {
        // The box and the point's third coordinate from what is left of u_c.
        let sb = (u_c - cones) / boxes * f32(wf.lit_count);
        let pick = min(u32(sb), wf.lit_count - 1u);
        let w = clamp(sb - f32(pick), 0.0, ONE_MINUS_EPSILON);
        wi = frame_to_local(frame, lit_sample(x, pick, vec3<f32>(u, w)));
    } else {
        let t = principled_sample(b, wo, u_lobe, u);
        if (!t.valid) {
            return s;
        }
        wi = t.wi;
    }
    let pdf_bsdf = principled_pdf(b, wo, wi);
    if (!(wi.z > 0.0 && pdf_bsdf > 0.0)) {
        return s;
    }
    let pdf = surface_mixture_pdf(x, frame_from_local(frame, wi), pdf_bsdf);
    s.wi = wi;
    s.weight = principled_eval(b, wo, wi) * wi.z / pdf;
    s.pdf = pdf;
    s.valid = true;
    return s;
}
