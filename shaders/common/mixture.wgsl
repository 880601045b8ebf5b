// Mirrors src/integrator/mixture.rs (sample_mixture: GreyMix, RgbMix, HomGrey, HomRgb),
// src/sampling/discrete.rs (sample_discrete), src/volume/merge.rs (MergedSegments),
// src/integrator/nested.rs (sample_nested: VDB media side by side inside a homogeneous one)
// and the parts of src/integrator/path.rs that choose between them (vdb_intervals, intervals_overlap, sample_media and transmittance with MIX on):
// the mixture variant (FEATURE_MIXTURE), for scenes with several VDB media, overlapping or
// not, or a VDB medium inside a homogeneous one. Needs types.wgsl, grid.wgsl, dda.wgsl,
// tracking.wgsl, emission.wgsl, wavefront.wgsl and media.wgsl.
//
// Every medium is an entry of `vdb_media` whose grids live in the shared grid buffers and
// whose bounds start at its `bounds_base`. Where media overlap along a flight (or a VDB
// medium lies inside the homogeneous medium the path is in), the free flight tracks ONE
// medium whose coefficients are the sums: the majorant of each piece of the ray is the sum of
// the members' (mix_next merges their segment streams), a tentative collision evaluates every
// member and sums (mix_coeffs), the control is `((1 - alpha_max) sigma_c, alpha_min sigma_c)`
// over the summed minorants, every member's emission is gathered, and a real scattering event
// picks the medium that scattered in proportion to its sigma_s at the point (one more uniform)
// for its phase function and albedo. Elsewhere each medium is tracked alone (vdb_flight), in
// order along the ray; shadow rays multiply the members' own transmittance estimates (the
// transmittance of a sum is the product). See the Rust modules for why each choice is
// unbiased.

@group(1) @binding(18) var<storage, read> vdb_media: array<GpuVdbMedium>;

// One input stream of MergedSegments: a member's majorant walk, or the homogeneous part's one
// constant segment.
struct MixStream {
    dda: Dda,
    cur: GpuMajorantSegment,  // the segment it is in, or the next it will enter
    has: bool,                // `cur` holds a segment
    medium: u32,              // vdb_media index (NO_INDEX: the homogeneous part)
    o: vec3<f32>,             // the member's index-space ray
    d: vec3<f32>,
}

// The mixture of one flight (the sums' state the CPU's GreyMix / RgbMix keep).
struct MixState {
    n: u32,                   // streams: the VDB members, then the homogeneous part if any
    n_vdb: u32,
    t: f32,                   // MergedSegments::t
    alpha_min: f32,           // smallest and largest control albedo of the parts
    alpha_max: f32,
    hom_sigma_a: vec3<f32>,   // the homogeneous part's tracker coefficients (grey: every
    hom_sigma_s: vec3<f32>,   // channel equal), zero without one
}

var<private> mix_streams: array<MixStream, 9>;
var<private> mix_state: MixState;

// The VDB media along a world ray: vdb_intervals' (medium, t_min, t_max), sorted by t_min.
struct Spans {
    n: u32,
    k: array<u32, 8>,
    a: array<f32, 8>,
    b: array<f32, 8>,
}

// path.rs vdb_intervals: every medium whose world bounds the ray crosses within [t0, t1]
// (non-empty, NaN ends skipped), by start (insertion sort: at most MAX_MIX entries;
// backend::gpu::render::supports refuses more media).
fn vdb_spans(o: vec3<f32>, d: vec3<f32>, t0: f32, t1: f32) -> Spans {
    var s: Spans;
    s.n = 0u;
    for (var k = 0u; k < min(wf.vdb_count, MAX_MIX); k++) {
        var te = vec2<f32>(0.0);
        if (!aabb_intersect(vdb_media[k].lo, vdb_media[k].hi, o, d, t0, t1, &te)) {
            continue;
        }
        if (!(te.y > te.x)) {
            continue;
        }
        var i = s.n;
        while (i > 0u && s.a[i - 1u] > te.x) {
            s.k[i] = s.k[i - 1u];
            s.a[i] = s.a[i - 1u];
            s.b[i] = s.b[i - 1u];
            i -= 1u;
        }
        s.k[i] = k;
        s.a[i] = te.x;
        s.b[i] = te.y;
        s.n += 1u;
    }
    return s;
}

// path.rs intervals_overlap.
fn spans_overlap(s: Spans) -> bool {
    for (var i = 1u; i < s.n; i++) {
        if (s.a[i] < s.b[i - 1u]) {
            return true;
        }
    }
    return false;
}

// A world direction in grid g's index space.
fn grid_index_vector(g: GpuGridInfo, v: vec3<f32>) -> vec3<f32> {
    let m = g.index_from_world;
    return vec3<f32>(dot(m[0].xyz, v), dot(m[1].xyz, v), dot(m[2].xyz, v));
}

// medium_tracker for medium k alone (GreyView / RgbView::new of that medium).
fn vdb_tracker(k: u32, o: vec3<f32>, d: vec3<f32>, rng: Rng, estimator: u32) -> Tracker {
    var tr: Tracker;
    let g = vdb_media[k].grid;
    tr.params = vdb_media[k].tracking;
    tr.params.estimator = estimator;
    tr.rng = rng;
    tr.o = grid_index_point(g, o);
    tr.d = grid_index_vector(g, d);
    tr.ow = o;
    tr.dw = d;
    tr.w = vec3<f32>(1.0);
    tr.albedo_rgb = vdb_media[k].albedo_rgb;
    tr.mix = k + 1u;
    return tr;
}

// medium_dda for medium k: its majorant walk over [t0, t1] (media.rs `segments`).
fn vdb_dda(k: u32, tr: Tracker, t0: f32, t1: f32) -> Dda {
    let g = vdb_media[k].grid;
    return dda_new_in(g, vdb_media[k].bounds_base, vdb_media[k].voxel_table != 0u, tr.o, tr.d,
                      t0, t1, g.density_scale * tr.params.majorant_channel_scale,
                      tr.params.majorant_mode);
}

// What a free flight ended with (MediumEvent and the phase function of the medium that
// scattered).
struct Flight {
    event: u32,
    t: f32,            // world ray parameter of a scattering event
    weight: vec3<f32>, // multiplies the throughput (scatter, escape)
    g: f32,
    phase_medium: u32, // the VDB medium whose phase applies (NO_INDEX: the homogeneous medium's)
}

// Folds a flight's tracker into the path: random stream, counters, gathered emission.
fn finish_tracker(tr: Tracker, ps: ptr<function, GpuPathState>, rng: ptr<function, Rng>) {
    *rng = tr.rng;
    add_tracking_stats(tr.stats, false, ps);
// #if FEATURE_EMISSION
    (*ps).l += tr.emitted;
    (*ps).lookups += tr.emission_lookups;
    add_wide(WIDE_EMISSION_LOOKUPS, tr.emission_lookups);
// #endif
}

// media.rs sample_vdb: the free flight through medium k alone over [a, b], as sample_medium's
// one-medium path does it for the `grid_info` medium.
fn vdb_flight(k: u32, ps: ptr<function, GpuPathState>, rng: ptr<function, Rng>, a: f32, b: f32,
              beta: vec3<f32>) -> Flight {
    var tr = vdb_tracker(k, (*ps).o, (*ps).d, *rng, vdb_media[k].tracking.estimator);
    tr.time = (*ps).time;
    let dda = vdb_dda(k, tr, a, b);
    tracking_sample_distance(&tr, dda, b, beta);
    finish_tracker(tr, ps, rng);
    var f = Flight(tr.event, tr.t_event, vec3<f32>(tr.w.x), vdb_media[k].phase_g, k);
    let albedo = vdb_media[k].scatter_albedo;
    if (FEATURE_CHROMATIC && vdb_media[k].spectral != 0u) {
        f.weight = tr.w;
        if (f.event == EVENT_SCATTER) {
            f.weight = tr.w * albedo;
        }
    } else if (f.event == EVENT_SCATTER) {
        f.weight = albedo * tr.w.x;
    }
    return f;
}

// media.rs sample_vdb_in_turn: vdb_flight through the media of `spans` one after another,
// each over its span cut at t_end; the first scattering or absorption ends it (its weight
// times the escape weights before it), else an escape with the product of the weights.
fn vdb_flights_in_turn(spans: Spans, t_end: f32, ps: ptr<function, GpuPathState>,
                       rng: ptr<function, Rng>) -> Flight {
    var weight = vec3<f32>(1.0);
    for (var i = 0u; i < spans.n; i++) {
        if (!(spans.a[i] < t_end)) {
            break;
        }
        let fi = vdb_flight(spans.k[i], ps, rng, spans.a[i], min(spans.b[i], t_end),
                            (*ps).beta * weight);
        if (fi.event == EVENT_ESCAPE) {
            weight *= fi.weight;
            continue;
        }
        var f = fi;
        f.weight = weight * fi.weight;
        return f;
    }
    return Flight(EVENT_ESCAPE, 0.0, weight, 0.0, NO_INDEX);
}

// The raw density of stream i's medium at ray parameter t (GridField::at_index) for a sample
// at time offset `time` (RgbView::density: advected where the medium is blurred).
fn mix_density(i: u32, t: f32, time: f32) -> f32 {
    let m = mix_streams[i].medium;
    var p = mix_streams[i].o + t * mix_streams[i].d;
// #if FEATURE_MOTION
    p = blur_index_point(vdb_media[m].blur, p, time);
// #endif
    return grid_sample_trilinear_in(vdb_media[m].grid, p);
}

// The sum behind GreyMix::coeffs and RgbMix::coeffs: the homogeneous part's tracker
// coefficients plus every member's view (one lookup each), the members' RGB coefficients with
// `rgb`, else their grey ones in every lane.
fn mix_coeffs_sum(tr: ptr<function, Tracker>, t: f32, rgb: bool) -> CoeffsRgb {
    var k = CoeffsRgb(mix_state.hom_sigma_a, mix_state.hom_sigma_s);
    for (var i = 0u; i < mix_state.n_vdb; i++) {
        let m = mix_streams[i].medium;
        let dens = mix_density(i, t, (*tr).time);
        var sigma_a = vec3<f32>(vdb_media[m].grey_sigma_a);
        var sigma_s = vec3<f32>(vdb_media[m].grey_sigma_s);
        if (rgb) {
            sigma_a = vdb_media[m].rgb_sigma_a;
            sigma_s = vdb_media[m].rgb_sigma_s;
        }
        k.sigma_a += sigma_a * dens;
        k.sigma_s += sigma_s * dens;
    }
    (*tr).stats.lookups += mix_state.n_vdb;
    return k;
}

// GreyMix::coeffs.
fn mix_coeffs(tr: ptr<function, Tracker>, t: f32) -> Coeffs {
    let k = mix_coeffs_sum(tr, t, false);
    return Coeffs(k.sigma_a.x, k.sigma_s.x);
}

// RgbMix::coeffs.
fn mix_coeffs_rgb(tr: ptr<function, Tracker>, t: f32) -> CoeffsRgb {
    return mix_coeffs_sum(tr, t, true);
}

// GreyMix::control: the summed minorant split so that it stays below every part's own split.
fn mix_control(sigma_c: f32) -> Coeffs {
    return Coeffs((1.0 - mix_state.alpha_max) * sigma_c, mix_state.alpha_min * sigma_c);
}

// The emission on_collision gathers (emission.wgsl) at world point p, ray parameter t: every
// member's for the mixture, medium k's for a tracker of medium k alone, each read at its own
// advected point where it is blurred (each view's Blur::world_point).
fn mix_emission(tr: ptr<function, Tracker>, p: vec3<f32>, t: f32) -> vec3<f32> {
    if ((*tr).mix == MIX_ALL) {
        var le = vec3<f32>(0.0);
        for (var i = 0u; i < mix_state.n_vdb; i++) {
            let m = mix_streams[i].medium;
            var q = p;
// #if FEATURE_MOTION
            q = blur_world_point(vdb_media[m].blur, p, mix_streams[i].o + t * mix_streams[i].d,
                                 (*tr).time);
// #endif
            le += emission_met(tr, vdb_media[m].emission, m, q,
                               mix_streams[i].o + t * mix_streams[i].d, t);
        }
        return le;
    }
    var e = GpuEmissionParams();
    var q = p;
// #if FEATURE_MOTION
    var blur = wf.blur;
// #endif
    if ((*tr).mix != 0u) {
        e = vdb_media[(*tr).mix - 1u].emission;
// #if FEATURE_MOTION
        blur = vdb_media[(*tr).mix - 1u].blur;
// #endif
    }
// #if FEATURE_MOTION
    q = blur_world_point(blur, p, (*tr).o + t * (*tr).d, (*tr).time);
// #endif
    let qi = (*tr).o + t * (*tr).d;
    if ((*tr).mix == 0u) {
        return emission_met(tr, emission, 0u, q, qi, t);
    }
    return emission_met(tr, e, (*tr).mix - 1u, q, qi, t);
}

// Moves stream i to its next segment.
fn mix_advance(i: u32) {
    if (i >= mix_state.n_vdb) {
        // The homogeneous part has one segment.
        mix_streams[i].has = false;
        return;
    }
    var dda = mix_streams[i].dda;
    var seg: GpuMajorantSegment;
    let ok = dda_next(&dda, &seg);
    mix_streams[i].dda = dda;
    mix_streams[i].cur = seg;
    mix_streams[i].has = ok;
}

// MergedSegments::next: the piece from the earliest point not yet emitted to the nearest
// boundary of any stream, with the sums of the bounds of the streams covering it.
fn mix_next(seg: ptr<function, GpuMajorantSegment>) -> bool {
    let t = mix_state.t;
    let inf = f32_inf();
    var start = inf;
    for (var i = 0u; i < mix_state.n; i++) {
        // Leave behind every segment that ends at or before t (and any empty or NaN one).
        for (var guard = 0u; guard < 0x7fffffffu; guard++) {
            if (!mix_streams[i].has) {
                break;
            }
            let c = mix_streams[i].cur;
            if (!(c.t_max > t) || !(c.t_max > c.t_min)) {
                mix_advance(i);
            } else {
                break;
            }
        }
        if (mix_streams[i].has) {
            start = min(start, max(mix_streams[i].cur.t_min, t));
        }
    }
    if (start == inf) {
        return false;
    }
    var end = inf;
    var sigma_maj = 0.0;
    var sigma_min = 0.0;
    for (var i = 0u; i < mix_state.n; i++) {
        if (!mix_streams[i].has) {
            continue;
        }
        let c = mix_streams[i].cur;
        if (c.t_min > start) {
            end = min(end, c.t_min);
        } else {
            end = min(end, c.t_max);
            sigma_maj += c.sigma_maj;
            sigma_min += c.sigma_min;
        }
    }
    mix_state.t = end;
    *seg = GpuMajorantSegment(start, end, sigma_maj, sigma_min);
    return true;
}

// sample_discrete: index k with probability w[k] / sum(w) (n entries; n when every weight is 0)
// and that probability.
struct Pick {
    k: u32,
    p: f32,
}

fn mix_pick(w: array<f32, 9>, n: u32, u: f32) -> Pick {
    var total = 0.0;
    for (var k = 0u; k < n; k++) {
        total += w[k];
    }
    if (!(total > 0.0)) {
        return Pick(n, 0.0);
    }
    let x = u * total;
    var acc = 0.0;
    var last = n;
    for (var k = 0u; k < n; k++) {
        if (w[k] > 0.0) {
            acc += w[k];
            last = k;
            if (x < acc) {
                return Pick(k, w[k] / total);
            }
        }
    }
    // Rounding left x at the top of the CDF: the last positive entry.
    return Pick(last, w[last] / total);
}

// Whether the sum of the media of `spans` and the homogeneous medium `h` (`has_hom`) is
// tracked spectrally (sample_mixture's RgbMix): when forced, or when any part is chromatic.
fn mix_is_spectral(spans: Spans, h: GpuHomogeneousMedium, has_hom: bool) -> bool {
    var spectral = false;
    if (FEATURE_CHROMATIC) {
        let st = h.sigma_a + h.sigma_s;
        spectral = (wf.flags & WF_FLAG_FORCE_SPECTRAL) != 0u
            || (has_hom && !(st.x == st.y && st.y == st.z));
        for (var i = 0u; i < spans.n; i++) {
            spectral = spectral || vdb_media[spans.k[i]].spectral != 0u;
        }
    }
    return spectral;
}

// The merged segment streams' members: every VDB medium's majorant walk over its span along
// the world ray (o, d), and the control albedos' range over them (mix_state starts empty).
fn mix_start_members(spans: Spans, o: vec3<f32>, d: vec3<f32>) {
    mix_state.n_vdb = spans.n;
    mix_state.n = spans.n;
    mix_state.t = -f32_inf();
    mix_state.alpha_min = 1.0;
    mix_state.alpha_max = 0.0;
    mix_state.hom_sigma_a = vec3<f32>(0.0);
    mix_state.hom_sigma_s = vec3<f32>(0.0);
    // media.rs `segments`: the merged stream has no single grid to cull by, so the culled
    // global walk is walked as the per-leaf DDA, whose collisions it samples.
    var mode = wf.tracking.majorant_mode;
    if (mode == MAJORANT_CULLED) {
        mode = MAJORANT_PER_CELL;
    }
    for (var i = 0u; i < spans.n; i++) {
        let k = spans.k[i];
        let g = vdb_media[k].grid;
        mix_streams[i].medium = k;
        mix_streams[i].o = grid_index_point(g, o);
        mix_streams[i].d = grid_index_vector(g, d);
        // The summed walk does not thin by any medium's voxels (media.rs `segments`).
        mix_streams[i].dda = dda_new_in(g, vdb_media[k].bounds_base, false, mix_streams[i].o,
                                        mix_streams[i].d, spans.a[i], spans.b[i],
                                        g.density_scale, mode);
        mix_advance(i);
        mix_state.alpha_min = min(mix_state.alpha_min, vdb_media[k].control_albedo);
        mix_state.alpha_max = max(mix_state.alpha_max, vdb_media[k].control_albedo);
    }
}

// The homogeneous part of the sum over [t0, t1] (HomRgb when `spectral`, else HomGrey):
// its tracker coefficients, its one constant segment as the last stream, and for HomGrey its
// control albedo in the range; returns the grey tracker's scattering albedo (sigma_s per
// channel over the tracked sigma_s; 0 when spectral).
fn mix_add_homogeneous(h: GpuHomogeneousMedium, t0: f32, t1: f32, spectral: bool) -> vec3<f32> {
    let weight_abs = wf.absorption_weight != 0u;
    // The CPU's ABS with absorption as an event (sample_mixture's dispatch).
    let abs = (wf.flags & WF_FLAG_ABSORPTION) != 0u && !weight_abs;
    var hom_albedo = vec3<f32>(0.0);
    var seg = GpuMajorantSegment(t0, t1, 0.0, 0.0);
    if (spectral) {
        // HomRgb: the medium's coefficients, or (0, sigma_t) with absorption as a weight.
        mix_state.hom_sigma_a = h.sigma_a;
        mix_state.hom_sigma_s = h.sigma_s;
        if (weight_abs) {
            mix_state.hom_sigma_a = vec3<f32>(0.0);
            mix_state.hom_sigma_s = h.sigma_a + h.sigma_s;
        }
        let st = mix_state.hom_sigma_a + mix_state.hom_sigma_s;
        seg.sigma_maj = max(st.x, max(st.y, st.z));
        seg.sigma_min = min(st.x, min(st.y, st.z));
    } else {
        // HomGrey.
        let st3 = h.sigma_a + h.sigma_s;
        let sigma_t = max(st3.x, max(st3.y, st3.z));
        var sigma_s = (h.sigma_s.x + h.sigma_s.y + h.sigma_s.z) / 3.0;
        if (weight_abs) {
            sigma_s = sigma_t;
        }
        var sigma_a = 0.0;
        if (abs) {
            sigma_a = max(sigma_t - sigma_s, 0.0);
        }
        if (sigma_s > 0.0) {
            hom_albedo = h.sigma_s / sigma_s;
        }
        mix_state.hom_sigma_a = vec3<f32>(sigma_a);
        mix_state.hom_sigma_s = vec3<f32>(sigma_s);
        let a_h = sigma_s / max(sigma_a + sigma_s, 1.17549435e-38);
        mix_state.alpha_min = min(mix_state.alpha_min, a_h);
        mix_state.alpha_max = max(mix_state.alpha_max, a_h);
        seg.sigma_maj = sigma_a + sigma_s;
        seg.sigma_min = sigma_a + sigma_s;
    }
    let n = mix_state.n;
    mix_streams[n].medium = NO_INDEX;
    mix_streams[n].cur = seg;
    mix_streams[n].has = true;
    mix_state.n = n + 1u;
    return hom_albedo;
}

// The scattering event of the sum at f.t: which medium scattered, in proportion to its sigma_s
// at the point (one lookup per member, one uniform of the tracker's stream), gives the phase
// function and the weight (its albedo, or for RGB its sigma_s over the tracked sum's);
// absorbed when no medium scatters there (only a majorant violation gets here).
fn mix_scatterer(tr: ptr<function, Tracker>, f: ptr<function, Flight>, h: GpuHomogeneousMedium,
                 has_hom: bool, hom_albedo: vec3<f32>, spectral: bool) {
    let t = (*f).t;
    var w: array<f32, 9>;
    var s_true: array<vec3<f32>, 9>;
    var s_view = vec3<f32>(0.0);
    for (var i = 0u; i < mix_state.n_vdb; i++) {
        let m = mix_streams[i].medium;
        let dens = mix_density(i, t, (*tr).time);
        if (spectral) {
            s_true[i] = vdb_media[m].sigma_s * dens;
            s_view += vdb_media[m].rgb_sigma_s * dens;
            w[i] = s_true[i].x + s_true[i].y + s_true[i].z;
        } else {
            w[i] = vdb_media[m].grey_sigma_s * dens;
        }
    }
    (*tr).stats.lookups += mix_state.n_vdb;
    var n = mix_state.n_vdb;
    if (has_hom) {
        if (spectral) {
            s_true[n] = h.sigma_s;
            s_view += mix_state.hom_sigma_s;
            w[n] = h.sigma_s.x + h.sigma_s.y + h.sigma_s.z;
        } else {
            w[n] = mix_state.hom_sigma_s.x;
        }
        n += 1u;
    }
    let pk = mix_pick(w, n, tracker_uniform(tr));
    if (pk.k >= n) {
        (*f).event = EVENT_ABSORB;
        return;
    }
    let hom_k = pk.k >= mix_state.n_vdb;
    if (hom_k) {
        (*f).g = h.g;
        (*f).phase_medium = NO_INDEX;
    } else {
        (*f).g = vdb_media[mix_streams[pk.k].medium].phase_g;
        (*f).phase_medium = mix_streams[pk.k].medium;
    }
    if (spectral) {
        let den = s_view * pk.p;
        (*f).weight = (*tr).w * select(vec3<f32>(0.0), s_true[pk.k] / den, den > vec3<f32>(0.0));
    } else if (hom_k) {
        (*f).weight = hom_albedo * (*tr).w.x;
    } else {
        (*f).weight = vdb_media[mix_streams[pk.k].medium].scatter_albedo * (*tr).w.x;
    }
}

// mixture::sample_mixture: the free flight through the sum of the media of `spans` and the
// homogeneous medium `hom` (NO_INDEX: none) over [t0, t1].
fn mix_flight(spans: Spans, hom: u32, ps: ptr<function, GpuPathState>, rng: ptr<function, Rng>,
              t0: f32, t1: f32) -> Flight {
    var h: GpuHomogeneousMedium;
    let has_hom = hom != NO_INDEX;
    if (has_hom) {
        h = homogeneous[hom];
    }
    let spectral = mix_is_spectral(spans, h, has_hom);
    // The streams: every member's walk over its span, then the homogeneous part.
    mix_start_members(spans, (*ps).o, (*ps).d);
    var hom_albedo = vec3<f32>(0.0);
    if (has_hom) {
        hom_albedo = mix_add_homogeneous(h, t0, t1, spectral);
    }
    // The tracker of the sum: the render's estimator and knobs (the first member's record
    // carries them), spectral tracking when any part is chromatic.
    var tr: Tracker;
    tr.params = vdb_media[spans.k[0]].tracking;
    tr.params.estimator = wf.mix_estimator;
    if (spectral) {
        tr.params.estimator = ESTIMATOR_SPECTRAL;
    }
    tr.rng = *rng;
    tr.ow = (*ps).o;
    tr.dw = (*ps).d;
    tr.w = vec3<f32>(1.0);
    tr.mix = MIX_ALL;
    tr.time = (*ps).time;
    var no_walk: Dda;
    no_walk.done = true;
    tracking_sample_distance(&tr, no_walk, t1, (*ps).beta);
    var f = Flight(tr.event, tr.t_event, vec3<f32>(tr.w.x), 0.0, NO_INDEX);
    if (spectral) {
        f.weight = tr.w;
    }
    if (tr.event == EVENT_SCATTER) {
        mix_scatterer(&tr, &f, h, has_hom, hom_albedo, spectral);
    }
    finish_tracker(tr, ps, rng);
    return f;
}

// nested.rs nested_applies: absorption as a weight, and grey extinction or no emitting member
// (an emitting medium's record has its emission region: prepare.rs builds one with every
// Emission, upload.rs marks it).
fn nested_applies(spans: Spans, hom: u32) -> bool {
    if (wf.absorption_weight == 0u) {
        return false;
    }
    let st = homogeneous[hom].sigma_a + homogeneous[hom].sigma_s;
    if (st.x == st.y && st.y == st.z) {
        return true;
    }
    for (var i = 0u; i < spans.n; i++) {
        if (vdb_media[spans.k[i]].emission.has_region != 0u) {
            return false;
        }
    }
    return true;
}

// nested.rs transmittance_over_survival: T_h(t) / S_h(t) of sample_homogeneous' draw (1 for
// grey extinction).
fn nested_tr_over_survival(h: GpuHomogeneousMedium, t: f32) -> vec3<f32> {
    let sigma_t = h.sigma_a + h.sigma_s;
    if (!FEATURE_CHROMATIC || (sigma_t.x == sigma_t.y && sigma_t.y == sigma_t.z)) {
        return vec3<f32>(1.0);
    }
    let tr = exp_neg(sigma_t, t);
    let survival = (tr.x + tr.y + tr.z) / 3.0;
    if (survival > 0.0) {
        return tr / survival;
    }
    return vec3<f32>(0.0);
}

// nested.rs sample_nested: the homogeneous medium's closed-form flight over [t0, t1], then each
// VDB medium's own flight (vdb_flight) over its span cut at the homogeneous collision.
fn nested_flight(spans: Spans, hom: u32, ps: ptr<function, GpuPathState>,
                 rng: ptr<function, Rng>, t0: f32, t1: f32) -> Flight {
    let h = homogeneous[hom];
    // Absorption is a weight here (nested_applies): no absorption event.
    let ev = sample_homogeneous(h, t1 - t0, true, rng);
    var t_h = t1;
    if (ev.event == EVENT_SCATTER) {
        t_h = t0 + ev.t;
    }
    // Then the VDB media in turn, each cut at t_h.
    var f = vdb_flights_in_turn(spans, t_h, ps, rng);
    if (f.event == EVENT_SCATTER) {
        f.weight *= nested_tr_over_survival(h, f.t - t0);
    }
    if (f.event != EVENT_ESCAPE) {
        return f;
    }
    let weight = f.weight;
    if (ev.event == EVENT_SCATTER) {
        return Flight(EVENT_SCATTER, t_h, weight * ev.weight, h.g, NO_INDEX);
    }
    return Flight(EVENT_ESCAPE, 0.0, weight * ev.weight, h.g, NO_INDEX);
}

// path.rs sample_media with MIX: the sum where media overlap along the flight, VDB media side
// by side inside the homogeneous medium the path is in by nested_flight where it applies (else
// by the sum too), else the homogeneous medium in closed form, else each VDB medium in turn.
fn sample_media_mix(ps: ptr<function, GpuPathState>, rng0: Rng, t_hit: f32) -> Flight {
    var rng = rng0;
    let t0 = (*ps).t0;
    let spans = vdb_spans((*ps).o, (*ps).d, t0, t_hit);
    var hom = NO_INDEX;
// #if FEATURE_HOMOGENEOUS
    hom = (*ps).medium;
// #endif
    var f = Flight(EVENT_ESCAPE, 0.0, vec3<f32>(1.0), 0.0, NO_INDEX);
    let overlap = spans_overlap(spans);
    var nested = false;
// #if FEATURE_HOMOGENEOUS
    if (hom != NO_INDEX && spans.n > 0u && !overlap && nested_applies(spans, hom)) {
        f = nested_flight(spans, hom, ps, &rng, t0, t_hit);
        nested = true;
    }
// #endif
    if (nested) {
        // nested_flight answered.
    } else if ((hom != NO_INDEX && spans.n > 0u) || overlap) {
        f = mix_flight(spans, hom, ps, &rng, t0, t_hit);
    } else if (hom != NO_INDEX) {
// #if FEATURE_HOMOGENEOUS
        let h = homogeneous[hom];
        let ev = sample_homogeneous(h, t_hit - t0, wf.absorption_weight != 0u, &rng);
        f = Flight(ev.event, t0 + ev.t, ev.weight, h.g, NO_INDEX);
// #endif
    } else {
        f = vdb_flights_in_turn(spans, t_hit, ps, &rng);
    }
    (*ps).rng_state = rng.state;
    (*ps).rng_inc = rng.inc;
    return f;
}

// path.rs transmittance's VDB factor with MIX: the product of every medium's own estimate
// over its part of [t0, t1] (ratio, residual ratio or spectral tracking as that medium's
// shadow rays use), drawn from the path's stream.
fn mix_transmittance(o: vec3<f32>, wi: vec3<f32>, t0: f32, t1: f32,
                     ps: ptr<function, GpuPathState>) -> vec3<f32> {
    let spans = vdb_spans(o, wi, t0, t1);
    var t = vec3<f32>(1.0);
    for (var i = 0u; i < spans.n; i++) {
        let k = spans.k[i];
        let est_id = vdb_media[k].shadow_estimator;
        var tr = vdb_tracker(k, o, wi, path_rng(*ps), est_id);
        // The shadow ray belongs to its path's camera sample, and sees its instant.
        tr.time = (*ps).time;
        // WalkPlan::shadow (each medium's estimate is its own walk: a culled one
        // culls, unlike the merged free flights' per-leaf stand-in).
        tr.params.majorant_mode = vdb_media[k].shadow_majorant_mode;
        let dda = vdb_dda(k, tr, spans.a[i], spans.b[i]);
        let est = tracking_transmittance(&tr, dda, spans.b[i]);
        if (est_id == ESTIMATOR_SPECTRAL) {
            t *= est;
        } else {
            t *= vec3<f32>(est.x);
        }
        (*ps).rng_state = tr.rng.state;
        (*ps).rng_inc = tr.rng.inc;
        add_tracking_stats(tr.stats, true, ps);
        if (all(t == vec3<f32>(0.0))) {
            break;
        }
    }
    return t;
}
