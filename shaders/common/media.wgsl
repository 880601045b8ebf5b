// Mirrors the homogeneous media of src/integrator/media.rs (sample_homogeneous,
// transmittance_homogeneous: KHR_materials_volume media inside closed meshes, sampled in
// closed form, no tracking and no lookups) and MediumStack::cross (src/integrator/stack.rs) for
// a stack of depth one (the GPU refuses nested media, see backend::gpu::render::supports). Needs
// rng.wgsl, tracking.wgsl (sample_exponential, EVENT_*) and wavefront.wgsl (wf).

@group(1) @binding(12) var<storage, read> homogeneous: array<GpuHomogeneousMedium>;

// MediumEvent of sample_homogeneous (t relative to the start of the interval).
struct MediumEvent {
    event: u32,          // EVENT_ESCAPE, EVENT_ABSORB or EVENT_SCATTER
    t: f32,
    weight: vec3<f32>,   // multiplies the throughput (scatter, escape)
}

// sample_homogeneous over [0, t_max]. Grey extinction: an exponential step, then (absorption
// as an event) absorb or scatter in proportion to the mean albedo with albedo / mean as
// weight, or (absorption as a weight) scatter with the RGB albedo as weight, drawing no
// uniform. Chromatic
// extinction (spectral MIS, as on the CPU): the distance is drawn from one channel chosen
// uniformly and weighted by the one-sample balance heuristic over channels,
// pdf(t) = mean_c sigma_t,c exp(-sigma_t,c t); absorption is a weight then.
fn sample_homogeneous(h: GpuHomogeneousMedium, t_max: f32, absorption_weight: bool, rng: ptr<function, Rng>) -> MediumEvent {
    let sigma_t = h.sigma_a + h.sigma_s;
// #if FEATURE_CHROMATIC
    if (!(sigma_t.x == sigma_t.y && sigma_t.y == sigma_t.z)) {
        let c = min(u32(rng_uniform(rng) * 3.0), 2u);
        let st_c = sigma_t[c];
        var t = f32_inf();
        if (st_c > 0.0) {
            t = sample_exponential(rng_uniform(rng), st_c);
        }
        if (t < t_max) {
            let tr = exp_neg(sigma_t, t);
            let pdf = (sigma_t.x * tr.x + sigma_t.y * tr.y + sigma_t.z * tr.z) / 3.0;
            return MediumEvent(EVENT_SCATTER, t, h.sigma_s * tr / pdf);
        }
        let tr = exp_neg(sigma_t, t_max);
        let p_escape = (tr.x + tr.y + tr.z) / 3.0;
        return MediumEvent(EVENT_ESCAPE, 0.0, tr / p_escape);
    }
// #endif
    // Grey (or a variant without chromatic media, where the CPU uses sigma_t.x alike).
    let st = sigma_t.x;
    if (!(st > 0.0)) {
        return MediumEvent(EVENT_ESCAPE, 0.0, vec3<f32>(1.0));
    }
    let t = sample_exponential(rng_uniform(rng), st);
    if (t >= t_max) {
        return MediumEvent(EVENT_ESCAPE, 0.0, vec3<f32>(1.0));
    }
    let albedo = h.sigma_s / st;
    if (absorption_weight) {
        return MediumEvent(EVENT_SCATTER, t, albedo);
    }
    let p_scatter = (albedo.x + albedo.y + albedo.z) / 3.0;
    if (rng_uniform(rng) < p_scatter) {
        return MediumEvent(EVENT_SCATTER, t, albedo / p_scatter);
    }
    return MediumEvent(EVENT_ABSORB, t, vec3<f32>(0.0));
}

// transmittance_homogeneous: exp(-sigma_t d), exact.
fn transmittance_homogeneous(h: GpuHomogeneousMedium, d: f32) -> vec3<f32> {
    return exp_neg(h.sigma_a + h.sigma_s, d);
}

// exp_neg: exp(-sigma_t d) with a clear channel (sigma_t = 0) transmitting 1 even over an
// infinite distance, where 0 * inf would be NaN (media.rs exp_neg).
fn exp_neg(sigma_t: vec3<f32>, d: f32) -> vec3<f32> {
    return select(exp(-sigma_t * d), vec3<f32>(1.0), sigma_t == vec3<f32>(0.0));
}

// MediumStack::cross with one entry: crossing a boundary inwards enters its interior medium;
// outwards leaves it (back to no medium); a boundary without a medium (thin-walled) changes
// nothing, nor does leaving a medium the path is not in.
fn enter_or_leave(current: u32, interior: u32, entering: bool) -> u32 {
    if (interior == NO_INDEX) {
        return current;
    }
    if (entering) {
        return interior;
    }
    return select(current, NO_INDEX, current == interior);
}

// The phase function's g where the path is: its homogeneous medium's, else the VDB medium's.
fn medium_phase_g(medium: u32) -> f32 {
    if (FEATURE_HOMOGENEOUS && medium != NO_INDEX) {
        return homogeneous[medium].g;
    }
    return wf.phase_g;
}
