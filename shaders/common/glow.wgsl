// Mirrors src/integrator/glow.rs: pixel jitter drawn towards the film points of lamps inside
// media (Glows::jitter), and the weight 1 / p(q) each camera sample then carries.

const GLOW_RADIUS: f32 = 0.5;
const GLOW_SHARE: f32 = 0.5;
const GLOW_TAU: f32 = 6.28318530717958647692;

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
        let r = GLOW_RADIUS * (s - f32(pick));
        let phi = GLOW_TAU * u.y;
        q = glow_centre(near[pick]) + r * vec2<f32>(cos(phi), sin(phi)) - corner;
    } else {
        q = vec2<f32>((u.x - GLOW_SHARE) / (1.0 - GLOW_SHARE), u.y);
    }
    if (!(q.x >= 0.0 && q.x < 1.0 && q.y >= 0.0 && q.y < 1.0)) {
        return vec3<f32>(q, 0.0);
    }
    var glow = 0.0;
    for (var i = 0u; i < n; i++) {
        let r = length(corner + q - glow_centre(near[i]));
        if (r < GLOW_RADIUS) {
            glow += 1.0 / (GLOW_TAU * GLOW_RADIUS * max(r, 1e-12));
        }
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
