// Mirrors src/volume/tracking/: the ONE free-flight loop `sample_free_flight` (mod.rs), the
// flight every estimator shares around its collision rule (flight.rs: `Outcome` and the tail
// of `fly`), each estimator's `distance_rule` and `transmittance_rule` (delta.rs,
// weighted_delta.rs, decomposition.rs, weighted_decomposition.rs, ratio.rs, residual_ratio.rs,
// spectral.rs), and sampling::sample_discrete.
// Needs types.wgsl, math.wgsl, rng.wgsl, grid.wgsl and dda.wgsl.
//
// WGSL has no closures, so where the CPU passes a majorant closure and a collision rule, the
// loop here calls `tracking_majorant` and `tracking_collide`, whose rules (`transmittance_rule`,
// `distance_rule`) switch on the estimator id (ESTIMATOR_* constants, emitted from
// gpu_types::GpuEstimator by backend::gpu::shader) and return an Outcome that one tail,
// `flight_outcome`, counts and applies.
//
// Random-number order is the CPU's (tracking/mod.rs): one uniform per tentative collision for
// its exponential depth, drawn by the loop; then what the callback draws for that collision (one uniform for the event
// choice, one more only when Russian roulette fires). With the same Rng stream the GPU walk
// therefore takes the same decisions as the CPU one up to rounding: exponential steps use
// ln_f32 (math.wgsl, equal to f32::ln for 92 % of arguments, else 1 ulp off), exp() is WGSL's,
// and the driver may rewrite arithmetic (Mesa's NIR turns `(1 - a) s + a s` into
// `s ((1 - a) + a)`, for one). tests/gpu/transmittance.rs reports how many samples are
// bit-identical to the CPU's.
//
// The medium is a SparseGrid seen along an index-space ray: sigma_t = density_scale * value
// (times channel_scale per channel for spectral tracking), sigma_s = albedo sigma_t.

// tracking::MAJORANT_TOLERANCE.
const MAJORANT_TOLERANCE: f32 = 1e-4;
// tracking::ROULETTE_THRESHOLD.
const ROULETTE_THRESHOLD: f32 = 0.1;
// tracking::MAX_TENTATIVE_COLLISIONS (per free flight).
const MAX_TENTATIVE_COLLISIONS: u32 = 16777216u;
// Largest finite f32 (`is_finite` for a non-negative value is `<= F32_MAX`).
const F32_MAX: f32 = 3.40282347e38;

// Per-invocation TrackingStats (folded into GpuTrackingStats with atomics by the kernel).
struct Stats {
    lookups: u32,
    null_collisions: u32,
    real_collisions: u32,
    control_collisions: u32,
    majorant_violations: u32,
    invalid_majorants: u32,
    collision_cap_hits: u32,
    roulette_kills: u32,
    max_abs_weight: f32,
    segments: u32,
}

// tracking::Coeffs.
struct Coeffs {
    sigma_a: f32,
    sigma_s: f32,
}

// One estimator walking one ray: the state the CPU closures capture.
struct Tracker {
    params: GpuTrackingParams,
    rng: Rng,
    stats: Stats,
    o: vec3<f32>,  // index-space ray origin
    d: vec3<f32>,  // index-space ray direction
    w: vec3<f32>,  // the estimate or weight being built (grey estimators use .x)
    distance: bool, // sample_distance (true) or transmittance (false)
    beta: vec3<f32>, // path throughput before the flight (spectral sample_distance history)
    event: u32,    // EVENT_* of sample_distance
    t_event: f32,  // ray parameter of an absorb/scatter event
    albedo_rgb: vec3<f32>, // per-channel sigma_s / sigma_t of spectral lookups (RgbView)
    ow: vec3<f32>, // world-space ray origin (GreyView::ray_w; emission is looked up there)
    dw: vec3<f32>, // world-space ray direction
    emitted: vec3<f32>, // emission gathered by on_collision, already weighted by beta
    emission_lookups: u32, // emission and temperature grid reads
    sum_control: bool, // ControlDepthWalk: sum the control's optical depth during the walk
    tau_c: f32,        // the control optical depth summed so far
    // Which medium (the mixture variant, mixture.wgsl): 0 the `grid_info` uniform's, k + 1
    // entry k of vdb_media, MIX_ALL the sum of the media of the flight in `mix`.
    mix: u32,
    // The camera sample's time offset (TrackingConfig::time): a blurred medium's lookups are
    // advected by it (advection.wgsl); 0 in the tracking kernels.
    time: f32,
}

// Tracker::mix of a tracker of the sum of several media.
const MIX_ALL: u32 = 0xFFFFFFFFu;

// tracking::CONTROL_DEPTH_CUTOFF: exp(-tau_c) is 0 in f32 beyond it.
const CONTROL_DEPTH_CUTOFF: f32 = 104.0;

// tracking::Event variants.
const EVENT_ESCAPE: u32 = 0u;
const EVENT_ABSORB: u32 = 1u;
const EVENT_SCATTER: u32 = 2u;
// sampling::discrete::ONE_MINUS_EPSILON, the largest f32 below 1 (0x3f7fffff).
const ONE_MINUS_EPSILON: f32 = 0.99999994;

// Coeffs::from_sigma_t.
fn coeffs_from_sigma_t(sigma_t: f32, albedo: f32) -> Coeffs {
    return Coeffs((1.0 - albedo) * sigma_t, albedo * sigma_t);
}

// Coeffs::sigma_t.
fn coeffs_sigma_t(k: Coeffs) -> f32 {
    return k.sigma_a + k.sigma_s;
}

// f32::copysign: the magnitude of x with the sign bit of y (so -0.0 counts as negative).
fn copysign(x: f32, y: f32) -> f32 {
    return bitcast<f32>((bitcast<u32>(x) & 0x7fffffffu) | (bitcast<u32>(y) & 0x80000000u));
}

// The medium's extinction at ray parameter t, before channel and albedo splits: the density
// at the index point the lookup reads (advected where the medium is blurred, GreyView::coeffs).
fn medium_sigma_t(tr: ptr<function, Tracker>, t: f32) -> f32 {
    var p = (*tr).o + t * (*tr).d;
    var g = grid_info;
// #if FEATURE_MOTION
    var blur = wf.blur;
// #endif
// #if FEATURE_MIXTURE
    if ((*tr).mix != 0u) {
        g = vdb_media[(*tr).mix - 1u].grid;
// #if FEATURE_MOTION
        blur = vdb_media[(*tr).mix - 1u].blur;
// #endif
    }
// #endif
// #if FEATURE_MOTION
    // One advection and one lookup whichever medium: every inlined copy of this function
    // carries one of each.
    p = blur_index_point(blur, p, (*tr).time);
// #endif
    return g.density_scale * grid_sample_trilinear_in(g, p);
}

// tracking::lookup: one counted density lookup (the mixture: one per medium, summed).
fn lookup(tr: ptr<function, Tracker>, t: f32) -> Coeffs {
// #if FEATURE_MIXTURE
    if ((*tr).mix == MIX_ALL) {
        return mix_coeffs(tr, t);
    }
// #endif
    (*tr).stats.lookups += 1u;
    return coeffs_from_sigma_t(medium_sigma_t(tr, t), (*tr).params.albedo);
}

// tracking::CoeffsRgb.
struct CoeffsRgb {
    sigma_a: vec3<f32>,
    sigma_s: vec3<f32>,
}

// tracking::lookup_rgb: sigma_t,c = channel_scale[c] * density, split by the per-channel
// albedo (the kernels set it to params.albedo in every channel; the wavefront integrator to
// the medium's sigma_s / sigma_t, as RgbView does).
fn lookup_rgb(tr: ptr<function, Tracker>, t: f32) -> CoeffsRgb {
// #if FEATURE_MIXTURE
    if ((*tr).mix == MIX_ALL) {
        return mix_coeffs_rgb(tr, t);
    }
// #endif
    (*tr).stats.lookups += 1u;
    let s = (*tr).params.channel_scale * medium_sigma_t(tr, t);
    let albedo = (*tr).albedo_rgb;
    return CoeffsRgb((1.0 - albedo) * s, albedo * s);
}

// CoeffsRgb::sigma_t of one lookup.
fn lookup_rgb_sigma_t(tr: ptr<function, Tracker>, t: f32) -> vec3<f32> {
    let k = lookup_rgb(tr, t);
    return k.sigma_a + k.sigma_s;
}

// ControlExtinction::sigma_c.
fn control_sigma_c(tr: ptr<function, Tracker>, seg: GpuMajorantSegment) -> f32 {
    switch (*tr).params.control_mode {
        case CONTROL_CONSTANT: { return (*tr).params.control_value; }
        case CONTROL_FRACTION_OF_BOUND: { return (*tr).params.control_value * seg.sigma_maj; }
        case CONTROL_SEGMENT_MINORANT: { return seg.sigma_min; }
        case CONTROL_FRACTION_OF_BOUND_CAPPED: { return min((*tr).params.control_value * seg.sigma_maj, seg.sigma_min); }
        default: { return 0.0; }
    }
}

// Medium::control of FnMedium::with_control: Coeffs::from_sigma_t(sigma_c, control_albedo).
fn control(tr: ptr<function, Tracker>, seg: GpuMajorantSegment) -> Coeffs {
// #if FEATURE_MIXTURE
    if ((*tr).mix == MIX_ALL) {
        return mix_control(control_sigma_c(tr, seg));
    }
// #endif
    return coeffs_from_sigma_t(control_sigma_c(tr, seg), (*tr).params.control_albedo);
}

// tracking::check_bound.
fn check_bound(tr: ptr<function, Tracker>, sigma_t: f32, sigma_maj: f32) {
    if (sigma_t > sigma_maj * (1.0 + MAJORANT_TOLERANCE)) {
        (*tr).stats.majorant_violations += 1u;
    }
}

// decomposition::check_residual.
fn check_residual(tr: ptr<function, Tracker>, r_a: f32, r_s: f32, sigma_maj: f32) {
    let slack = -MAJORANT_TOLERANCE * sigma_maj;
    if (r_a < slack || r_s < slack) {
        (*tr).stats.majorant_violations += 1u;
    }
}

// TrackingStats::note_weight.
fn note_weight(tr: ptr<function, Tracker>, w: f32) {
    (*tr).stats.max_abs_weight = max((*tr).stats.max_abs_weight, abs(w));
}

// tracking::residual_majorant: b * max(bound - sigma_c, sigma_c - sigma_min, 0).
fn residual_majorant(b: f32, seg: GpuMajorantSegment, sigma_c: f32) -> f32 {
    return b * max(max(seg.sigma_maj - sigma_c, sigma_c - seg.sigma_min), 0.0);
}

// The tracker's next uniform. The stream is copied out and back because naga 30's SPIR-V
// writer panics ("Expression [n] is not cached!") on a call taking `&(*tr).rng`, a pointer to
// a member of a pointer argument.
fn tracker_uniform(tr: ptr<function, Tracker>) -> f32 {
    var rng = (*tr).rng;
    let u = rng_uniform(&rng);
    (*tr).rng = rng;
    return u;
}

// tracking::RECYCLE_MIN_P and tracking::thin: keeps a tentative collision with probability r
// (a NaN ratio culls) and hands a queued uniform on, rescaled into [0, 1), where the outcome
// had probability at least RECYCLE_MIN_P: u / r if kept, (u - r) / (1 - r) if culled.
const RECYCLE_MIN_P: f32 = 0.25;

fn tracker_thin(tr: ptr<function, Tracker>, r: f32) -> bool {
    var rng = (*tr).rng;
    // Only a queued value (a sampler's point, or one handed on) is handed on.
    let queued = rng.n_queued > 0u;
    let u = rng_uniform(&rng);
    let keep = u < r;
    // The outcome's interval of u, [0, r) or [r, 1), of length p (NaN fails both tests).
    var below = u - r;
    var p = 1.0 - r;
    if (keep) {
        below = u;
        p = r;
    }
    if (queued && p >= RECYCLE_MIN_P && p <= 1.0) {
        rng_push_front(&rng, below / p);
    }
    (*tr).rng = rng;
    return keep;
}

// tracking::sample_exponential. ln_f32 (math.wgsl), not WGSL's log(): the built-in may be off
// by 2^-21 absolutely near 1, i.e. by percents on the short steps of small u.
fn sample_exponential(u: f32, sigma: f32) -> f32 {
    return -ln_f32(1.0 - u) / sigma;
}

// tracking::roulette (grey).
fn roulette(tr: ptr<function, Tracker>, w: f32) -> f32 {
    let a = abs(w);
    if (a >= ROULETTE_THRESHOLD || a == 0.0) {
        return w;
    }
    if (tracker_uniform(tr) < a / ROULETTE_THRESHOLD) {
        return copysign(ROULETTE_THRESHOLD, w);
    }
    (*tr).stats.roulette_kills += 1u;
    return 0.0;
}

// SpectralProbabilities::reduce (0 = history-aware max, 1 = average).
fn spectral_reduce(mode: u32, v: vec3<f32>) -> f32 {
    let a = abs(v);
    if (mode == 0u) {
        return max(a.x, max(a.y, a.z));
    }
    return (a.x + a.y + a.z) * (1.0 / 3.0);
}

// flight::Weight::roulette of an RGB weight: roulette on max |w|, every channel rescaled.
fn roulette_rgb(tr: ptr<function, Tracker>, w: vec3<f32>) -> vec3<f32> {
    let a = abs(w);
    let m = max(a.x, max(a.y, a.z));
    if (m >= ROULETTE_THRESHOLD || m == 0.0) {
        return w;
    }
    if (tracker_uniform(tr) < m / ROULETTE_THRESHOLD) {
        return w * (ROULETTE_THRESHOLD / m);
    }
    (*tr).stats.roulette_kills += 1u;
    return vec3<f32>(0.0);
}

// The majorant closure each estimator's `transmittance` passes to sample_free_flight.
fn transmittance_majorant(tr: ptr<function, Tracker>, seg: GpuMajorantSegment) -> f32 {
    let b = (*tr).params.b;
    switch (*tr).params.estimator {
        case ESTIMATOR_DELTA: { return seg.sigma_maj; }
        case ESTIMATOR_DECOMPOSITION: {
            return max(seg.sigma_maj - coeffs_sigma_t(control(tr, seg)), 0.0);
        }
        case ESTIMATOR_WEIGHTED_DECOMPOSITION, ESTIMATOR_RESIDUAL_RATIO: {
            return residual_majorant(b, seg, coeffs_sigma_t(control(tr, seg)));
        }
        // weighted delta, ratio, spectral: scaled_majorant(b).
        default: { return b * seg.sigma_maj; }
    }
}

// sampling::sample_discrete over three weights: the chosen index (3 = none), its pmf and the
// remapped uniform.
struct DiscreteSample {
    index: u32,
    pmf: f32,
    u_remapped: f32,
}

fn sample_discrete3(w: array<f32, 3>, u: f32) -> DiscreteSample {
    let sum = w[0] + w[1] + w[2];
    if (!(sum > 0.0)) {
        return DiscreteSample(3u, 0.0, 0.0);
    }
    let up = u * sum;
    var acc = 0.0;
    var last = 3u;
    for (var i = 0u; i < 3u; i++) {
        if (w[i] <= 0.0) {
            continue;
        }
        last = i;
        if (up < acc + w[i]) {
            return DiscreteSample(i, w[i] / sum, clamp((up - acc) / w[i], 0.0, ONE_MINUS_EPSILON));
        }
        acc += w[i];
    }
    // Rounding: u * sum reached the rounded total; the mass goes to the last real entry.
    return DiscreteSample(last, w[last] / sum, ONE_MINUS_EPSILON);
}

// Ends a distance walk with an event at t (weight in (*tr).w).
fn end_flight(tr: ptr<function, Tracker>, event: u32, t: f32) -> bool {
    (*tr).event = event;
    (*tr).t_event = t;
    return false;
}

// Each estimator's `Estimator::majorant`: the majorant of its distance walk.
fn distance_majorant(tr: ptr<function, Tracker>, seg: GpuMajorantSegment) -> f32 {
    let b = (*tr).params.b;
    switch (*tr).params.estimator {
        case ESTIMATOR_DELTA, ESTIMATOR_DECOMPOSITION: { return seg.sigma_maj; }
        case ESTIMATOR_WEIGHTED_DECOMPOSITION: {
            let sigma_c = coeffs_sigma_t(control(tr, seg));
            return sigma_c + residual_majorant(b, seg, sigma_c);
        }
        // weighted delta, spectral: scaled_majorant(b).
        default: { return b * seg.sigma_maj; }
    }
}

// flight::Outcome kinds. The first three are in the order of the event CDF [absorb, scatter,
// null] that sample_discrete3 picks an index from.
const OUTCOME_ABSORB: u32 = 0u;          // Outcome::Real(Real::Absorb, ..)
const OUTCOME_SCATTER: u32 = 1u;         // Outcome::Real(Real::Scatter, ..)
const OUTCOME_NULL: u32 = 2u;            // Outcome::Null
const OUTCOME_CONTROL_ABSORB: u32 = 3u;  // Outcome::Control(Real::Absorb)
const OUTCOME_CONTROL_SCATTER: u32 = 4u; // Outcome::Control(Real::Scatter)
const OUTCOME_SKIP: u32 = 5u;            // Outcome::Skip
const OUTCOME_DEAD: u32 = 6u;            // Outcome::Dead
const OUTCOME_STOP: u32 = 7u;            // no rule (an unknown estimator): stop, record nothing

// flight::Outcome: what a collision rule decided, and the factor the weight takes (`weighted`
// false: the weight is unchanged and not recorded, as in the analog trackers; grey in .x).
struct Outcome {
    kind: u32,
    weighted: bool,
    factor: vec3<f32>,
}

fn outcome(kind: u32) -> Outcome {
    return Outcome(kind, false, vec3<f32>(0.0));
}

fn outcome_weighted(kind: u32, factor: f32) -> Outcome {
    return Outcome(kind, true, vec3<f32>(factor, 0.0, 0.0));
}

fn outcome_rgb(kind: u32, factor: vec3<f32>) -> Outcome {
    return Outcome(kind, true, factor);
}

// delta::bernoulli: real with probability sigma / sigma_maj (the transmittance rules of
// delta and decomposition tracking).
fn bernoulli(tr: ptr<function, Tracker>, sigma: f32, sigma_maj: f32) -> Outcome {
    if (tracker_uniform(tr) * sigma_maj < sigma) {
        return outcome(OUTCOME_ABSORB);
    }
    return outcome(OUTCOME_NULL);
}

// weighted_delta::real_or_null: events {real |sigma|, null |sigma_maj - sigma|}, the null
// weighted by sign(sigma_n) total / sigma_maj.
fn real_or_null(tr: ptr<function, Tracker>, sigma: f32, sigma_maj: f32) -> Outcome {
    let sigma_n = sigma_maj - sigma;
    let total = abs(sigma) + abs(sigma_n);
    if (tracker_uniform(tr) * total < abs(sigma)) {
        return outcome(OUTCOME_ABSORB);
    }
    return outcome_weighted(OUTCOME_NULL, copysign(total / sigma_maj, sigma_n));
}

// weighted_delta::weighted_choice: P_x = |sigma_x| / total over [absorb, scatter, null] with
// uniform u, weight sign(sigma_x) total / sigma_maj.
fn weighted_choice(sigma: array<f32, 3>, sigma_maj: f32, u: f32) -> Outcome {
    let p = array<f32, 3>(abs(sigma[0]), abs(sigma[1]), abs(sigma[2]));
    let total = p[0] + p[1] + p[2];
    let c = sample_discrete3(p, u);
    if (c.index == 3u) {
        return outcome(OUTCOME_SKIP);
    }
    return outcome_weighted(c.index, copysign(total / sigma_maj, sigma[c.index]));
}

// The collision rule of each estimator's `transmittance`.
fn transmittance_rule(tr: ptr<function, Tracker>, t: f32, sigma_maj: f32,
                      seg: GpuMajorantSegment) -> Outcome {
    switch (*tr).params.estimator {
        case ESTIMATOR_DELTA: {
            let sigma_t = coeffs_sigma_t(lookup(tr, t));
            check_bound(tr, sigma_t, sigma_maj);
            return bernoulli(tr, sigma_t, sigma_maj);
        }
        case ESTIMATOR_WEIGHTED_DELTA: {
            return real_or_null(tr, coeffs_sigma_t(lookup(tr, t)), sigma_maj);
        }
        // The residual against bound - sigma_c.
        case ESTIMATOR_DECOMPOSITION: {
            let ctl = control(tr, seg);
            let k = lookup(tr, t);
            check_bound(tr, coeffs_sigma_t(k), seg.sigma_maj);
            check_residual(tr, k.sigma_a - ctl.sigma_a, k.sigma_s - ctl.sigma_s, seg.sigma_maj);
            return bernoulli(tr, coeffs_sigma_t(k) - coeffs_sigma_t(ctl), sigma_maj);
        }
        case ESTIMATOR_WEIGHTED_DECOMPOSITION: {
            let sigma_r = coeffs_sigma_t(lookup(tr, t)) - coeffs_sigma_t(control(tr, seg));
            return real_or_null(tr, sigma_r, sigma_maj);
        }
        // ratio: T *= 1 - sigma_t / sigma_maj.
        case ESTIMATOR_RATIO: {
            let sigma_t = coeffs_sigma_t(lookup(tr, t));
            return outcome_weighted(OUTCOME_NULL, 1.0 - sigma_t / sigma_maj);
        }
        // residual ratio: T *= 1 - sigma_r / r_bar.
        case ESTIMATOR_RESIDUAL_RATIO: {
            let sigma_r = coeffs_sigma_t(lookup(tr, t)) - coeffs_sigma_t(control(tr, seg));
            return outcome_weighted(OUTCOME_NULL, 1.0 - sigma_r / sigma_maj);
        }
        case ESTIMATOR_SPECTRAL: {
            return spectral_transmittance_rule(tr, t, sigma_maj);
        }
        default: {
            return outcome(OUTCOME_STOP);
        }
    }
}

// Spectral's transmittance_rule: history-aware real/null choice, RGB weights.
fn spectral_transmittance_rule(tr: ptr<function, Tracker>, t: f32, sigma_maj: f32) -> Outcome {
    let sigma_t = lookup_rgb_sigma_t(tr, t);
    let sigma_n = vec3<f32>(sigma_maj) - sigma_t;
    let mode = (*tr).params.spectral_mode;
    let p_real = spectral_reduce(mode, sigma_t * (*tr).w);
    let p_null = spectral_reduce(mode, sigma_n * (*tr).w);
    let total = p_real + p_null;
    // `||` short-circuits: no uniform is drawn when total is not positive (as on the CPU).
    if (!(total > 0.0) || tracker_uniform(tr) * total < p_real) {
        return outcome(OUTCOME_ABSORB);
    }
    return outcome_rgb(OUTCOME_NULL, sigma_n * (total / (sigma_maj * p_null)));
}

// Each estimator's `distance_rule`.
fn distance_rule(tr: ptr<function, Tracker>, t: f32, sigma_maj: f32,
                 seg: GpuMajorantSegment) -> Outcome {
    switch (*tr).params.estimator {
        // delta: one uniform against [sigma_a, sigma_a + sigma_s, sigma_maj].
        case ESTIMATOR_DELTA: {
            let k = lookup(tr, t);
            check_bound(tr, coeffs_sigma_t(k), sigma_maj);
            let x = tracker_uniform(tr) * sigma_maj;
            if (x < k.sigma_a) {
                return outcome(OUTCOME_ABSORB);
            }
            if (x < k.sigma_a + k.sigma_s) {
                return outcome(OUTCOME_SCATTER);
            }
            return outcome(OUTCOME_NULL);
        }
        case ESTIMATOR_WEIGHTED_DELTA: {
            let k = lookup(tr, t);
            let sigma_n = sigma_maj - coeffs_sigma_t(k);
            return weighted_choice(array<f32, 3>(k.sigma_a, k.sigma_s, sigma_n), sigma_maj,
                                   tracker_uniform(tr));
        }
        case ESTIMATOR_DECOMPOSITION: {
            return decomposition_distance_rule(tr, t, sigma_maj, seg);
        }
        case ESTIMATOR_WEIGHTED_DECOMPOSITION: {
            return weighted_decomposition_distance_rule(tr, t, sigma_maj, seg);
        }
        case ESTIMATOR_SPECTRAL: {
            return spectral_distance_rule(tr, t, sigma_maj);
        }
        default: {
            return outcome(OUTCOME_STOP);
        }
    }
}

// Decomposition's distance_rule: the control part of the CDF first (no lookup).
fn decomposition_distance_rule(tr: ptr<function, Tracker>, t: f32, sigma_maj: f32,
                               seg: GpuMajorantSegment) -> Outcome {
    let ctl = control(tr, seg);
    var x = tracker_uniform(tr) * sigma_maj;
    if (x < ctl.sigma_a) {
        return outcome(OUTCOME_CONTROL_ABSORB);
    }
    if (x < coeffs_sigma_t(ctl)) {
        return outcome(OUTCOME_CONTROL_SCATTER);
    }
    let k = lookup(tr, t);
    check_bound(tr, coeffs_sigma_t(k), sigma_maj);
    let r_a = k.sigma_a - ctl.sigma_a;
    let r_s = k.sigma_s - ctl.sigma_s;
    check_residual(tr, r_a, r_s, sigma_maj);
    x = x - coeffs_sigma_t(ctl);
    if (x < r_a) {
        return outcome(OUTCOME_ABSORB);
    }
    if (x < r_a + r_s) {
        return outcome(OUTCOME_SCATTER);
    }
    return outcome(OUTCOME_NULL);
}

// WeightedDecomposition's distance_rule: control first, then weighted residual
// events with the remapped uniform.
fn weighted_decomposition_distance_rule(tr: ptr<function, Tracker>, t: f32, sigma_maj: f32,
                                        seg: GpuMajorantSegment) -> Outcome {
    let ctl = control(tr, seg);
    let sigma_c = coeffs_sigma_t(ctl);
    let x = tracker_uniform(tr) * sigma_maj;
    if (x < sigma_c) {
        return outcome(select(OUTCOME_CONTROL_SCATTER, OUTCOME_CONTROL_ABSORB, x < ctl.sigma_a));
    }
    // Without a control, the collision's majorant itself (culling may have thinned it).
    var r_bar = sigma_maj;
    if (sigma_c != 0.0) {
        r_bar = residual_majorant((*tr).params.b, seg, sigma_c);
    }
    if (!(r_bar > 0.0)) {
        return outcome(OUTCOME_SKIP);
    }
    let u = clamp((x - sigma_c) / r_bar, 0.0, ONE_MINUS_EPSILON);
    let k = lookup(tr, t);
    let r_a = k.sigma_a - ctl.sigma_a;
    let r_s = k.sigma_s - ctl.sigma_s;
    let r_n = r_bar - r_a - r_s;
    return weighted_choice(array<f32, 3>(r_a, r_s, r_n), r_bar, u);
}

// Spectral's distance_rule: history-aware probabilities, RGB weights.
fn spectral_distance_rule(tr: ptr<function, Tracker>, t: f32, sigma_maj: f32) -> Outcome {
    let k = lookup_rgb(tr, t);
    let sigma_n = vec3<f32>(sigma_maj) - (k.sigma_a + k.sigma_s);
    let h = (*tr).beta * (*tr).w;
    let mode = (*tr).params.spectral_mode;
    let p = array<f32, 3>(spectral_reduce(mode, k.sigma_a * h),
                          spectral_reduce(mode, k.sigma_s * h),
                          spectral_reduce(mode, sigma_n * h));
    let c = sample_discrete3(p, tracker_uniform(tr));
    if (c.index == 3u) {
        // All history is zero: nothing can contribute any more.
        return outcome(OUTCOME_DEAD);
    }
    let sigma_x = array<vec3<f32>, 3>(k.sigma_a, k.sigma_s, sigma_n)[c.index];
    return outcome_rgb(c.index, sigma_x / (sigma_maj * c.pmf));
}

// The weight takes the outcome's factor and is recorded (TrackingStats::note_weight).
fn take_factor(tr: ptr<function, Tracker>, o: Outcome) {
    if (!o.weighted) {
        return;
    }
    if ((*tr).params.estimator == ESTIMATOR_SPECTRAL) {
        (*tr).w *= o.factor;
        let a = abs((*tr).w);
        note_weight(tr, max(a.x, max(a.y, a.z)));
    } else {
        (*tr).w.x *= o.factor.x;
        note_weight(tr, (*tr).w.x);
    }
}

// Walk::roulette: Russian roulette after the null collisions of ratio, residual ratio and
// spectral tracking; false when it left no weight.
fn null_roulette(tr: ptr<function, Tracker>) -> bool {
    let est = (*tr).params.estimator;
    if (est == ESTIMATOR_SPECTRAL) {
        (*tr).w = roulette_rgb(tr, (*tr).w);
        return any((*tr).w != vec3<f32>(0.0));
    }
    if (est == ESTIMATOR_RATIO || est == ESTIMATOR_RESIDUAL_RATIO) {
        (*tr).w.x = roulette(tr, (*tr).w.x);
        return (*tr).w.x != 0.0;
    }
    return true;
}

// flight::fly's tail, written once for every rule: counts the outcome, applies its factor
// and the roulette, and ends the walk with its event (distance sampling; absorbed when no
// weight is left) or its estimate (transmittance: the weight, 0 after a real collision).
// False stops the walk.
fn flight_outcome(tr: ptr<function, Tracker>, o: Outcome, t: f32) -> bool {
    switch o.kind {
        case OUTCOME_NULL: {
            (*tr).stats.null_collisions += 1u;
            take_factor(tr, o);
            if (null_roulette(tr)) {
                return true;
            }
            if ((*tr).distance) {
                return end_flight(tr, EVENT_ABSORB, t);
            }
            return false;
        }
        case OUTCOME_ABSORB, OUTCOME_SCATTER: {
            (*tr).stats.real_collisions += 1u;
            if ((*tr).distance) {
                take_factor(tr, o);
                let event = select(EVENT_SCATTER, EVENT_ABSORB, o.kind == OUTCOME_ABSORB);
                return end_flight(tr, event, t);
            }
            if ((*tr).params.estimator == ESTIMATOR_SPECTRAL) {
                (*tr).w = vec3<f32>(0.0);
            } else {
                (*tr).w.x = 0.0;
            }
            return false;
        }
        case OUTCOME_CONTROL_ABSORB, OUTCOME_CONTROL_SCATTER: {
            (*tr).stats.control_collisions += 1u;
            let event = select(EVENT_SCATTER, EVENT_ABSORB, o.kind == OUTCOME_CONTROL_ABSORB);
            return end_flight(tr, event, t);
        }
        case OUTCOME_SKIP: {
            return true;
        }
        case OUTCOME_DEAD: {
            (*tr).w = vec3<f32>(0.0);
            return end_flight(tr, EVENT_ABSORB, t);
        }
        default: {
            return false;
        }
    }
}

// The majorant of the walk in progress.
fn tracking_majorant(tr: ptr<function, Tracker>, seg: GpuMajorantSegment) -> f32 {
    if ((*tr).distance) {
        return distance_majorant(tr, seg);
    }
    return transmittance_majorant(tr, seg);
}

// The collision callback of the walk in progress (flight::fly under sample_distance and
// transmittance): a distance walk first calls Medium::on_collision with the weight so
// far (the including module defines `on_collision`: emission.wgsl in the wavefront
// integrator, a no-op in the test kernels), then the estimator's rule decides and
// flight_outcome does the rest. False stops the walk.
fn tracking_collide(tr: ptr<function, Tracker>, t: f32, sigma_maj: f32,
                    seg: GpuMajorantSegment) -> bool {
    if ((*tr).distance) {
        on_collision(tr, t, sigma_maj);
        return flight_outcome(tr, distance_rule(tr, t, sigma_maj, seg), t);
    }
    return flight_outcome(tr, transmittance_rule(tr, t, sigma_maj, seg), t);
}

// tracking::sample_free_flight (pbrt-v4's SampleT_maj): walks the majorant segments of `dda`
// clipped to t <= t_max; tentative collisions come where the majorant optical depth walked
// since the last one reaches an exponential depth -ln(1 - u), carried across segments (one
// uniform per collision, none per segment), and go to tracking_collide. The culled global
// walk (dda.cull) first keeps each with probability r = dda_cull_ratio (one more uniform when
// r < 1, handed on by tracker_thin) and hands the kept ones on with majorant r * sigma_maj;
// the per-leaf and culled walks (dda.voxel) then keep each with probability r2 =
// dda_voxel_ratio (majorant r2 * r * sigma_maj). Returns T_maj as the CPU does.
fn sample_free_flight(tr: ptr<function, Tracker>, dda_start: Dda, t_max: f32) -> f32 {
    var dda = dda_start;
    var seg: GpuMajorantSegment;
    // Depth left before the next collision (negative: none drawn), depth since the last one.
    var tau_left = -1.0;
    var tau_since = 0.0;
    var n_collisions = 0u;
    // tracking::voxel_stage, decided once per flight: the per-voxel stage only for walks that
    // have it, never for spectral tracking nor for ratio and residual ratio tracking (whose
    // variance it would raise), for estimators with a majorant scale b only under b >= 1, and
    // for those with a control only where it is 0 (tested per segment: seg_voxel).
    let est = (*tr).params.estimator;
    let with_control = est == ESTIMATOR_DECOMPOSITION || est == ESTIMATOR_WEIGHTED_DECOMPOSITION;
    let with_b = est == ESTIMATOR_WEIGHTED_DELTA || est == ESTIMATOR_WEIGHTED_DECOMPOSITION;
    let voxel = dda.voxel && est != ESTIMATOR_SPECTRAL && est != ESTIMATOR_RATIO
        && est != ESTIMATOR_RESIDUAL_RATIO && (!with_b || (*tr).params.b >= 1.0);
    loop {
        // ControlDepthWalk::next: the walk ends once the control factor has underflowed.
        if ((*tr).sum_control && (*tr).tau_c > CONTROL_DEPTH_CUTOFF) {
            break;
        }
        var more = false;
// #if FEATURE_MIXTURE
        if ((*tr).mix == MIX_ALL) {
            more = mix_next(&seg);
        } else {
            more = dda_next(&dda, &seg);
        }
// #endif
// #if !FEATURE_MIXTURE
        more = dda_next(&dda, &seg);
// #endif
        if (!more) {
            break;
        }
        if ((*tr).sum_control && seg.t_min < t_max) {
            let len_c = min(seg.t_max, t_max) - seg.t_min;
            let sigma_c = coeffs_sigma_t(control(tr, seg));
            if (len_c > 0.0 && sigma_c > 0.0) {
                (*tr).tau_c += sigma_c * len_c;
            }
        }
        if (seg.t_min >= t_max) {
            break;
        }
        let t1 = min(seg.t_max, t_max);
        if (!(t1 > seg.t_min)) {
            continue;
        }
        (*tr).stats.segments += 1u;
        let sigma_maj = tracking_majorant(tr, seg);
        if (!(sigma_maj >= 0.0 && sigma_maj <= F32_MAX)) {
            (*tr).stats.invalid_majorants += 1u;
            continue;
        }
        if (sigma_maj == 0.0) {
            continue;
        }
        let seg_voxel = voxel && (!with_control || coeffs_sigma_t(control(tr, seg)) == 0.0);
        var t = seg.t_min;
        loop {
            if (tau_left < 0.0) {
                tau_left = sample_exponential(tracker_uniform(tr), 1.0);
            }
            // The segment's optical depth decides first (a multiply, no division per segment).
            let tau_seg = sigma_maj * (t1 - t);
            var t_next = t1;
            if (tau_left < tau_seg) {
                t_next = t + tau_left / sigma_maj;
            }
            if (!(t_next < t1)) {
                // Escaped this segment: carry the rest of the depth.
                tau_left = max(tau_left - tau_seg, 0.0);
                tau_since += tau_seg;
                break;
            }
            t = t_next;
            tau_left = -1.0;
            tau_since = 0.0;
            n_collisions += 1u;
            if (n_collisions > MAX_TENTATIVE_COLLISIONS) {
                (*tr).stats.collision_cap_hits += 1u;
                return 0.0;
            }
            var sigma_kept = sigma_maj;
            var r = 1.0;
            if (dda.cull) {
                r = dda_cull_ratio(&dda, t);
                if (r < 1.0) {
                    // `!(u < r)`: a NaN ratio culls too.
                    if (!tracker_thin(tr, r)) {
                        (*tr).stats.null_collisions += 1u;
                        continue;
                    }
                    sigma_kept = r * sigma_maj;
                }
            }
            // The second stage (voxel_stage).
            if (seg_voxel) {
                let r2 = dda_voxel_ratio(&dda, t, r * seg.sigma_maj);
                if (r2 < 1.0) {
                    if (!tracker_thin(tr, r2)) {
                        (*tr).stats.null_collisions += 1u;
                        continue;
                    }
                    sigma_kept = r2 * sigma_kept;
                }
            }
            if (!tracking_collide(tr, t, sigma_kept, seg)) {
                return 1.0;
            }
        }
    }
    return exp(-tau_since);
}

// The `transmittance` function of the estimator `(*tr).params.estimator` over the segments of
// `dda`: grey estimates in .x, the RGB estimate of spectral tracking in .xyz.
fn tracking_transmittance(tr: ptr<function, Tracker>, dda: Dda, t_max: f32) -> vec3<f32> {
    let est = (*tr).params.estimator;
    // The closed-form control factor is summed during the same walk (ControlDepthWalk).
    let control_based = est == ESTIMATOR_DECOMPOSITION
        || est == ESTIMATOR_WEIGHTED_DECOMPOSITION || est == ESTIMATOR_RESIDUAL_RATIO;
    (*tr).sum_control = control_based;
    (*tr).tau_c = 0.0;
    (*tr).w = vec3<f32>(1.0);
    (*tr).distance = false;
    sample_free_flight(tr, dda, t_max);
    (*tr).sum_control = false;
    var t_control = 1.0;
    if (control_based) {
        // ControlDepthWalk::control_transmittance. As on the CPU, an underflowed control
        // factor makes the estimate 0 (the residual weight could overflow: 0 * inf is NaN).
        t_control = select(exp(-(*tr).tau_c), 0.0, (*tr).tau_c > CONTROL_DEPTH_CUTOFF);
        if (t_control == 0.0) {
            return vec3<f32>(0.0);
        }
    }
    if (est == ESTIMATOR_SPECTRAL) {
        return (*tr).w;
    }
    if (est == ESTIMATOR_DECOMPOSITION) {
        // decomposition keeps `tr = exp(-tau_c)` and zeroes it on a real collision.
        return vec3<f32>(select(0.0, t_control, (*tr).w.x != 0.0), 0.0, 0.0);
    }
    return vec3<f32>(t_control * (*tr).w.x, 0.0, 0.0);
}

// `tracking::sample_distance` with the estimator `(*tr).params.estimator` (delta,
// weighted_delta, decomposition, weighted_decomposition, spectral) over the segments of `dda`:
// sets (*tr).event, (*tr).t_event and the weight (*tr).w (grey in .x; 1 for analog trackers).
// `beta` is the path throughput, used by spectral tracking's history-aware probabilities.
fn tracking_sample_distance(tr: ptr<function, Tracker>, dda: Dda, t_max: f32, beta: vec3<f32>) {
    (*tr).w = vec3<f32>(1.0);
    (*tr).beta = beta;
    (*tr).distance = true;
    (*tr).sum_control = false;
    (*tr).event = EVENT_ESCAPE;
    (*tr).t_event = 0.0;
    sample_free_flight(tr, dda, t_max);
}
