// Mirrors the homogeneous media of src/integrator/homogeneous.rs (sample_homogeneous,
// transmittance_homogeneous: KHR_materials_volume media inside closed meshes, sampled in
// closed form, no tracking and no lookups) and MediumStack::cross (src/render/stack.rs) for
// a stack of three entries (GpuPathState::medium and ::outer; backend::gpu::render::supports
// refuses deeper nesting). Needs
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

// MediumStack::cross on the GPU's stack of three: `top` (NO_INDEX: empty) and `outer`, the two
// entries below it as 16-bit halves (low: the next one down; STACK_NONE: none). Crossing a
// boundary inwards pushes its interior medium (a full stack ignores the push, as on the CPU;
// backend::gpu::render::supports refuses scenes that nest deeper); outwards removes that
// medium's topmost entry; a boundary without a medium (thin-walled) changes nothing.
const STACK_NONE: u32 = 0xFFFFu;

// Returns the new (top, outer).
fn stack_cross(top: u32, outer: u32, interior: u32, entering: bool) -> vec2<u32> {
    if (interior == NO_INDEX) {
        return vec2<u32>(top, outer);
    }
    // Unpack, outermost first.
    var e = array<u32, 3>(NO_INDEX, NO_INDEX, NO_INDEX);
    var n = 0u;
    let below2 = outer >> 16u;
    let below1 = outer & STACK_NONE;
    if (below2 != STACK_NONE) {
        e[n] = below2;
        n += 1u;
    }
    if (below1 != STACK_NONE) {
        e[n] = below1;
        n += 1u;
    }
    if (top != NO_INDEX) {
        e[n] = top;
        n += 1u;
    }
    if (entering) {
        if (n < 3u) {
            e[n] = interior;
            n += 1u;
        }
    } else {
        // Remove the topmost entry of `interior`, if any.
        var k = 3u;
        for (var i = 0u; i < 3u; i++) {
            if (i < n && e[i] == interior) {
                k = i;
            }
        }
        if (k < n) {
            for (var j = 0u; j < 2u; j++) {
                if (j >= k) {
                    e[j] = e[j + 1u];
                }
            }
            n -= 1u;
        }
    }
    var new_top = NO_INDEX;
    var b1 = STACK_NONE;
    var b2 = STACK_NONE;
    if (n > 0u) {
        new_top = e[n - 1u];
    }
    if (n > 1u) {
        b1 = e[n - 2u];
    }
    if (n > 2u) {
        b2 = e[n - 3u];
    }
    return vec2<u32>(new_top, b1 | (b2 << 16u));
}

// The phase function at the path's scattering event: its homogeneous medium's, else the VDB
// medium's; in the mixture variant, that of the VDB medium the event picked where it picked
// one (recorded by the medium stage in GpuPathState::phase_medium and phase_g, as sample_media
// returns them with the event), else the homogeneous medium's the path is in.
fn path_phase(ps: GpuPathState) -> GpuPhase {
    var ph = phase_hg(wf.phase_g);
// #if FEATURE_PHASES
    ph = wf.phases[0];
// #endif
    if (FEATURE_HOMOGENEOUS && ps.medium != NO_INDEX) {
        ph = phase_hg(homogeneous[ps.medium].g);
// #if FEATURE_PHASES
        ph = homogeneous[ps.medium].phase;
// #endif
    }
// #if FEATURE_MIXTURE
    if (ps.phase_medium != NO_INDEX) {
        ph = phase_hg(ps.phase_g);
// #if FEATURE_PHASES
        ph = wf.phases[ps.phase_medium];
// #endif
    }
// #endif
    return ph;
}
