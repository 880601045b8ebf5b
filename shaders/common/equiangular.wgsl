// Mirrors src/integrator/equiangular.rs: equiangular sampling of scattering distances towards
// point and spot lights (Kulla and Fajardo 2012), weighed against free flight by MIS with the
// deterministic free-flight density sigma_t(x) exp(-sigma_t(x) (t - a)) (the module doc writes
// the estimator). The equiangular stage (stages/equiangular.wgsl) draws one estimate per
// flight segment in media, before the flight, from the path's stream (so in the CPU's order)
// and records the segment for the scattering stage's weight of its next-event estimate
// (distance_weight). Needs shadow.wgsl,
// lights.wgsl, media.wgsl, mixture.wgsl (vdb_spans, vdb_media), phase.wgsl and wavefront.wgsl.

// Equiangular: the density of one segment [a, b] of a ray towards a light, its angle shaped
// by the lobe h (0: uniform in theta).
struct Equiangular {
    t_c: f32,
    d: f32,
    theta_a: f32,
    theta_b: f32,
    h: f32,
    rho: f32,     // (1 - h) / (1 + h)
    g_b: f32,     // atan(rho tan(alpha / 2)) at alpha = pi / 2 - theta_b
    g_a: f32,     // the same at theta_a
    valid: bool,  // false where the CPU's Equiangular::new gives None
}

// lobe_of: the lobe of the angle's density for a phase function of mean cosine g.
fn lobe_of(g: f32) -> f32 {
    let g_abs = min(abs(g), 0.99);
    let r = pow((1.0 + g_abs) / (1.0 - g_abs), 1.5);
    let h = min((r - 1.0) / (r + 1.0), 0.9);
    return select(h, -h, g < 0.0);
}

// The lobe of a segment in `medium` (Segment::h): the homogeneous medium's phase function
// where it is in one, else the first VDB medium's.
fn segment_lobe(medium: u32) -> f32 {
    var ph = phase_hg(wf.phase_g);
// #if FEATURE_PHASES
    ph = wf.phases[0];
// #endif
// #if FEATURE_HOMOGENEOUS
    if (medium != NO_INDEX) {
        ph = phase_hg(homogeneous[medium].g);
// #if FEATURE_PHASES
        ph = homogeneous[medium].phase;
// #endif
    }
// #endif
    return lobe_of(phase_mean_cosine(ph));
}

// The angle's cumulative function G(alpha) at alpha = pi / 2 - theta.
fn equiangular_g(rho: f32, theta: f32) -> f32 {
    return atan(rho * tan(0.5 * (0.5 * PI - theta)));
}

// atan2(t - t_c, d) for d > 0, with the infinite ends the CPU's atan2 gives.
fn equiangular_angle(s: f32, d: f32) -> f32 {
    if (s > F32_MAX) {
        return 0.5 * PI;
    }
    if (s < -F32_MAX) {
        return -0.5 * PI;
    }
    return atan2(s, d);
}

// Equiangular::new: the density along the ray (o, dir) over [a, b] towards `light`.
fn equiangular_new(o: vec3<f32>, dir: vec3<f32>, light: vec3<f32>, a: f32, b: f32, h: f32)
    -> Equiangular {
    var eq: Equiangular;
    eq.valid = false;
    let t_c = dot(light - o, dir);
    let d = length(o + dir * t_c - light);
    let l = abs(light);
    let scale = 1.0 + max(l.x, max(l.y, l.z));
    if (!(d > 1e-6 * scale) || !(b > a)) {
        return eq;
    }
    eq.t_c = t_c;
    eq.d = d;
    eq.theta_a = equiangular_angle(a - t_c, d);
    eq.theta_b = equiangular_angle(b - t_c, d);
    eq.h = h;
    eq.rho = (1.0 - h) / (1.0 + h);
    eq.g_b = equiangular_g(eq.rho, eq.theta_b);
    eq.g_a = equiangular_g(eq.rho, eq.theta_a);
    eq.valid = eq.theta_b > eq.theta_a;
    return eq;
}

// Equiangular::sample.
fn equiangular_sample(eq: Equiangular, u: f32) -> f32 {
    if (eq.h == 0.0) {
        let theta = eq.theta_a + u * (eq.theta_b - eq.theta_a);
        return eq.t_c + eq.d * tan(theta);
    }
    let g = eq.g_b + u * (eq.g_a - eq.g_b);
    let alpha = 2.0 * atan(tan(g) / eq.rho);
    return eq.t_c + eq.d / tan(alpha);
}

// Equiangular::pdf.
fn equiangular_pdf(eq: Equiangular, t: f32) -> f32 {
    let s = t - eq.t_c;
    let r2 = eq.d * eq.d + s * s;
    if (eq.h == 0.0) {
        return eq.d / ((eq.theta_b - eq.theta_a) * r2);
    }
    let h = eq.h;
    let sin_theta = s / sqrt(r2);
    let angle = (1.0 - h * h) / ((1.0 + h * h + 2.0 * h * sin_theta) * 2.0 * (eq.g_a - eq.g_b));
    return angle * eq.d / r2;
}

// Segment: the part [a, b] of a flight where its media are, the media the ray is in, and
// their largest extinction.
struct Segment {
    o: vec3<f32>,
    dir: vec3<f32>,
    a: f32,
    b: f32,
    medium: u32,
    outer: u32,
    sigma_max: f32,
    h: f32,       // the lobe of the angle's density (segment_lobe)
    valid: bool,
}

// media_extent: all of the flight [t0, t1] inside a homogeneous medium, else the VDB
// medium's part of it.
fn media_extent(o: vec3<f32>, dir: vec3<f32>, t0: f32, t1: f32, medium: u32, outer: u32) -> Segment {
    var seg: Segment;
    seg.o = o;
    seg.dir = dir;
    seg.medium = medium;
    seg.outer = outer;
    seg.valid = false;
    seg.sigma_max = 0.0;
    seg.h = segment_lobe(medium);
    var hom = false;
// #if FEATURE_HOMOGENEOUS
    hom = medium != NO_INDEX;
    if (hom) {
        let h = homogeneous[medium];
        let st = h.sigma_a + h.sigma_s;
        seg.sigma_max = max(st.x, max(st.y, st.z));
        seg.a = t0;
        seg.b = t1;
        seg.valid = true;
    }
// #endif
// #if FEATURE_MIXTURE
// #if FEATURE_HETEROGENEOUS
    // Every VDB medium along the flight, inside the homogeneous medium or not.
    let spans = vdb_spans(o, dir, t0, t1);
    var sigma_vdb = 0.0;
    for (var i = 0u; i < spans.n; i++) {
        sigma_vdb = max(sigma_vdb, vdb_media[spans.k[i]].sigma_max);
    }
    seg.sigma_max += sigma_vdb;
    if (!hom && spans.n > 0u) {
        seg.a = spans.a[0];
        seg.b = seg.a;
        for (var i = 0u; i < spans.n; i++) {
            seg.b = max(seg.b, spans.b[i]);
        }
        seg.valid = true;
    }
// #endif
// #endif
// #if !FEATURE_MIXTURE
// #if FEATURE_HETEROGENEOUS
    var te = vec2<f32>(0.0);
    if (!hom && medium_interval(o, dir, t0, t1, &te)) {
        seg.sigma_max = wf.medium_sigma_max;
        seg.a = te.x;
        seg.b = te.y;
        seg.valid = true;
    }
// #endif
// #endif
    return seg;
}

// density_towards: light c's density over the segment where the strategy is used (its peak
// density reaches EQUIANGULAR_REACH times the media's largest extinction).
const EQUIANGULAR_REACH: f32 = 0.3;

fn density_towards(seg: Segment, c: vec3<f32>, q: f32) -> Equiangular {
    var eq = equiangular_new(seg.o, seg.dir, c, seg.a, seg.b, seg.h);
    if (eq.valid) {
        let peak = q / ((eq.theta_b - eq.theta_a) * eq.d);
        eq.valid = peak >= EQUIANGULAR_REACH * seg.sigma_max;
    }
    return eq;
}

// media_at's two sums at ray parameter t: sigma_s p(wo, wi) and the mean extinction.
struct MediaAt {
    s: vec3<f32>,
    sigma_t: f32,
}

// media_at: the homogeneous medium the segment is in, else the VDB medium where its bounds
// hold the point, with the coefficients the trackers read there (blur at the path's time).
fn media_at(seg: Segment, t: f32, wo: vec3<f32>, wi: vec3<f32>, time: f32) -> MediaAt {
    var m = MediaAt(vec3<f32>(0.0), 0.0);
// #if FEATURE_HOMOGENEOUS
    if (seg.medium != NO_INDEX) {
        let h = homogeneous[seg.medium];
        var ph = phase_hg(h.g);
// #if FEATURE_PHASES
        ph = h.phase;
// #endif
        m.s = h.sigma_s * phase_p(ph, wo, wi);
        let st = h.sigma_a + h.sigma_s;
        m.sigma_t = (st.x + st.y + st.z) / 3.0;
// #if !FEATURE_MIXTURE
        return m;
// #endif
    }
// #endif
    let x = seg.o + seg.dir * t;
// #if FEATURE_MIXTURE
// #if FEATURE_HETEROGENEOUS
    for (var k = 0u; k < min(wf.vdb_count, MAX_MIX); k++) {
        if (all(x >= vdb_media[k].lo) && all(x <= vdb_media[k].hi)) {
            let dens = vdb_density_at(k, x, time);
            if (dens > 0.0) {
                var ph = phase_hg(vdb_media[k].phase_g);
// #if FEATURE_PHASES
                ph = wf.phases[k];
// #endif
                m.s += vdb_media[k].sigma_s * dens * phase_p(ph, wo, wi);
                m.sigma_t += vdb_media[k].sigma_t_mean * dens;
            }
        }
    }
// #endif
// #endif
// #if !FEATURE_MIXTURE
// #if FEATURE_HETEROGENEOUS
    if (wf.has_medium != 0u && all(x >= wf.medium_lo) && all(x <= wf.medium_hi)) {
        var tr = medium_tracker(seg.o, seg.dir, Rng(0u, 1u, vec2<u32>(0u), 0u), wf.tracking.estimator);
        tr.time = time;
        let sigma = medium_sigma_t(&tr, t);
        if (sigma > 0.0) {
            var ph = phase_hg(wf.phase_g);
// #if FEATURE_PHASES
            ph = wf.phases[0];
// #endif
            m.s = wf.medium_sigma_s * sigma * phase_p(ph, wo, wi);
            m.sigma_t = wf.medium_sigma_t * sigma;
        }
    }
// #endif
// #endif
    return m;
}

// #if FEATURE_MIXTURE
// GreyView::density_at for VDB medium k at world point x: the raw density its trackers read
// (advected where it is blurred).
fn vdb_density_at(k: u32, x: vec3<f32>, time: f32) -> f32 {
    var p = grid_index_point(vdb_media[k].grid, x);
// #if FEATURE_MOTION
    p = blur_index_point(vdb_media[k].blur, p, time);
// #endif
    return grid_sample_trilinear_in(vdb_media[k].grid, p);
}
// #endif

// distance_pdf: the free-flight density MIS weighs against, from the mean extinction at the
// point and its distance from the segment's start.
fn distance_pdf(sigma_t: f32, t_from_a: f32) -> f32 {
    return sigma_t * exp(-sigma_t * max(t_from_a, 0.0));
}

// equiangular_weight: the strategy's weight (1 without MIS) for its density `eq_pdf` (with the
// light's selection) against free flight's `p_d`.
fn equiangular_weight(eq_pdf: f32, p_d: f32) -> f32 {
    if (wf.volume_sampling == VOLUME_SAMPLING_MIS) {
        return power_heuristic(eq_pdf, light_pmf() * p_d);
    }
    return 1.0;
}

// The punctual light of the i-th point or spot light (Lights::positional).
fn positional_light(i: u32) -> u32 {
    var seen = 0u;
    for (var k = 0u; k < wf.light_count; k++) {
        if (lights[k].kind != LIGHT_DIRECTIONAL) {
            if (seen == i) {
                return k;
            }
            seen += 1u;
        }
    }
    return NO_INDEX;
}

// distance_weight: the weight of a free-flight event's next-event estimate of punctual light
// `source` at the path's event, inside the segment its flight recorded (GpuPathState::seg_*):
// 1 for lights the equiangular strategy does not sample, 1 - w_e for those it does.
fn distance_weight(ps: GpuPathState, source: u32) -> f32 {
    if (wf.volume_sampling == VOLUME_SAMPLING_DISTANCE || (ps.flags & PATH_FLAG_SEGMENT) == 0u
        || source >= wf.light_count || lights[source].kind == LIGHT_DIRECTIONAL) {
        return 1.0;
    }
    var seg: Segment;
    seg.o = ps.o;
    seg.dir = ps.d;
    seg.a = ps.seg_a;
    seg.b = ps.seg_b;
    seg.sigma_max = ps.seg_sigma_max;
    seg.h = segment_lobe(ps.medium);
    let q = 1.0 / f32(wf.positional_count);
    let eq = density_towards(seg, lights[source].position, q);
    if (!eq.valid) {
        return 1.0;
    }
    let p_d = distance_pdf(ps.seg_sigma_t, -ps.seg_a);
    return 1.0 - equiangular_weight(q * equiangular_pdf(eq, 0.0), p_d);
}

// What equiangular_estimate returns: the estimate before the path's throughput and the light
// it sampled (valid false where the CPU's is None).
struct EquiangularEstimate {
    l: vec3<f32>,
    source: u32,
    valid: bool,
}

// A resampled candidate (equiangular.rs's Candidate): the distance, the light's direction,
// distance and incident radiance there, the media's sum sigma_s p, their mean extinction (for
// the MIS weight) and the target p_hat.
struct Candidate {
    t: f32,
    wi: vec3<f32>,
    dist: f32,
    li: vec3<f32>,
    s: vec3<f32>,
    sigma_t: f32,
    p_hat: f32,
    valid: bool,
}

// resample (equiangular.rs): `candidates` equiangular distances (the first from u_t), one kept
// in proportion to p_hat / p_e; the sum of those ratios in w_sum.
fn resample(seg: Segment, eq: Equiangular, k: u32, n: u32, u_t: f32, candidates: u32,
            time: f32, rng: ptr<function, Rng>, w_sum: ptr<function, f32>) -> Candidate {
    var kept: Candidate;
    kept.valid = false;
    *w_sum = 0.0;
    for (var i = 0u; i < candidates; i++) {
        var u = u_t;
        if (i > 0u) {
            u = rng_uniform(rng);
        }
        let t = clamp(equiangular_sample(eq, u), seg.a, seg.b);
        let ls = punctual_incident(k, seg.o + seg.dir * t);
        if (!ls.valid) {
            continue;
        }
        let m = media_at(seg, t, -seg.dir, ls.wi, time);
        let p_e = equiangular_pdf(eq, t) / f32(n);
        let sl = m.s * ls.li;
        let p_hat = max(max(sl.x, sl.y), sl.z);
        if (!(p_hat > 0.0 && p_e > 0.0)) {
            continue;
        }
        let w_i = p_hat / p_e;
        *w_sum += w_i;
        var take = candidates == 1u;
        if (!take) {
            take = rng_uniform(rng) * *w_sum < w_i;
        }
        if (take) {
            kept = Candidate(t, ls.wi, ls.dist, ls.li, m.s, m.sigma_t, p_hat, true);
        }
    }
    return kept;
}

// equiangular_estimate: one equiangular sample over the segment, drawn from the path's
// stream (resampled near the light), with ratio-tracked transmittances to the point and from
// it to the light (averaged over SHADOW_WALKS walks near the light).
fn equiangular_estimate(seg: Segment, ps: ptr<function, GpuPathState>) -> EquiangularEstimate {
    var est = EquiangularEstimate(vec3<f32>(0.0), NO_INDEX, false);
    let n = wf.positional_count;
    var rng = path_rng(*ps);
    let u_select = rng_uniform(&rng);
    let u_t = rng_uniform(&rng);
    (*ps).rng_state = rng.state;
    (*ps).rng_inc = rng.inc;
    if (n == 0u) {
        return est;
    }
    let k = positional_light(min(u32(u_select * f32(n)), n - 1u));
    let eq = density_towards(seg, lights[k].position, 1.0 / f32(n));
    if (!eq.valid) {
        return est;
    }
    est.source = k;
    est.valid = true;
    var candidates = 1u;
    var walks = 1u;
    if (eq.d * seg.sigma_max < NEAR_LIGHT) {
        candidates = EQUIANGULAR_CANDIDATES;
        walks = SHADOW_WALKS;
    }
    var w_sum = 0.0;
    let c = resample(seg, eq, k, n, u_t, candidates, (*ps).time, &rng, &w_sum);
    (*ps).rng_state = rng.state;
    (*ps).rng_inc = rng.inc;
    if (!c.valid) {
        return est;
    }
    let pdf = equiangular_pdf(eq, c.t) / f32(n);
    let w = equiangular_weight(pdf, distance_pdf(c.sigma_t, c.t - seg.a));
    if (!(w > 0.0)) {
        return est;
    }
    // The transmittance to the point and from it to the light, walked as one.
    let x = seg.o + seg.dir * c.t;
    let free = FreeLeg(seg.o + seg.dir * seg.a, seg.dir, c.t - seg.a, true);
    var tr = vec3<f32>(0.0);
    for (var j = 0u; j < walks; j++) {
        tr += walk_transmittance(free, x, c.wi, c.dist * (1.0 - 1e-4), seg.medium, seg.outer, ps);
    }
    let resampled = w_sum / f32(candidates) / c.p_hat;
    est.l = tr * c.s * c.li * (w * resampled / f32(walks));
    return est;
}
