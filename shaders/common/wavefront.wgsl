// Mirrors the scheduling of src/backend/gpu/graph.rs (`Stage`) and src/gpu_types/wavefront.rs
// (`GpuQueue`): the bindings every wavefront stage shares (group 1), queue access and the
// 64-bit counters. A stage is one function over the items of its input queue (one path slot
// each); it appends the slot to the queue of the stage that handles the path next (Cycles'
// state_flow.h in spirit). The medium
// and done queues are double-buffered by iteration parity: X0 + parity is read this
// iteration, X0 + 1 - parity is filled for the next one.

@group(1) @binding(0) var<uniform> wf: GpuWavefrontParams;
@group(1) @binding(1) var<storage, read_write> paths: array<GpuPathState>;
@group(1) @binding(2) var<storage, read_write> queues: array<u32>;
@group(1) @binding(3) var<storage, read_write> counters: GpuWavefrontCounters;
// One pending shadow ray per path slot (written by the scatter and surface stages).
@group(1) @binding(4) var<storage, read_write> shadows: array<GpuShadowRay>;

// The radiance split by light pass and by light group (PathState::passes, PathState::groups):
// LIGHT_ENTRIES RGB accumulators (w unused) per path slot from slot * LIGHT_ENTRIES, the light
// passes first where kept, then the light groups where kept. Apart from the path state so that
// it stays small; one buffer for both so that the groups bind nothing more (trace_shadow is
// one binding short of a stage's 16); only the variants that keep either bind it.
@group(1) @binding(19) var<storage, read_write> path_passes: array<vec4<f32>>;
const PASS_ENTRIES: u32 = LIGHT_PASSES * u32(FEATURE_LIGHT_PASSES);
const LIGHT_ENTRIES: u32 = PASS_ENTRIES + LIGHT_GROUPS * u32(FEATURE_LIGHT_GROUPS);

// #if FEATURE_LIGHT_PASSES

// PathState::pass_of: `seen` (PASS_EMISSION or PASS_BACKGROUND) before any scattering event;
// after it, the first event's kind (PATH_FLAG_FIRST_IN_MEDIUM), direct at depth 1, indirect
// deeper.
fn pass_of(ps: GpuPathState, seen: u32) -> u32 {
    if (ps.depth == 0u) {
        return seen;
    }
    var first = PASS_SURFACE_DIRECT;
    if ((ps.flags & PATH_FLAG_FIRST_IN_MEDIUM) != 0u) {
        first = PASS_VOLUME_DIRECT;
    }
    return select(first + 1u, first, ps.depth == 1u);
}

// PathState::gather's pass half: what a stage adds to ps.l, added to the pass pass_of names.
fn gather_pass(slot: u32, ps: GpuPathState, x: vec3<f32>, seen: u32) {
    let i = slot * LIGHT_ENTRIES + pass_of(ps, seen);
    path_passes[i] = vec4<f32>(path_passes[i].xyz + x, 0.0);
}

// PathState::gather_next: `x`, a next-event estimate at a scattering event of the flight that
// follows (depth + 1, the first event in a medium at depth 1), added as gather would there.
fn gather_next_pass(slot: u32, ps: GpuPathState, x: vec3<f32>) {
    var next = ps;
    next.depth += 1u;
    if (next.depth == 1u) {
        next.flags |= PATH_FLAG_FIRST_IN_MEDIUM;
    }
    gather_pass(slot, next, x, PASS_EMISSION);
}

// A new path's passes: all zero (generate's PathState).
fn clear_passes(slot: u32) {
    for (var k = 0u; k < LIGHT_PASSES; k++) {
        path_passes[slot * LIGHT_ENTRIES + k] = vec4<f32>(0.0);
    }
}
// #endif

// #if FEATURE_LIGHT_GROUPS
// PathState::gather's group half: x added to light group `group` (NO_GROUP, past the groups,
// gathers nothing).
fn gather_group(slot: u32, group: u32, x: vec3<f32>) {
    if (group < LIGHT_GROUPS) {
        let i = slot * LIGHT_ENTRIES + PASS_ENTRIES + group;
        path_passes[i] = vec4<f32>(path_passes[i].xyz + x, 0.0);
    }
}

// A new path's groups: all zero (generate's PathState).
fn clear_groups(slot: u32) {
    for (var k = 0u; k < LIGHT_GROUPS; k++) {
        path_passes[slot * LIGHT_ENTRIES + PASS_ENTRIES + k] = vec4<f32>(0.0);
    }
}

// LightGroups::of_source: the group of the light a LightSample's `source` names (its index
// among the punctual lights, the environment and the area lights, light_count() order).
fn light_group_of(source: u32) -> u32 {
    if (source < wf.light_count) {
        return (wf.punctual_groups[source / 4u] >> (8u * (source % 4u))) & 0xFFu;
    }
    if (wf.has_env != 0u && source == wf.light_count) {
        return wf.environment_group;
    }
    return wf.surfaces_group;
}

// Emitted::add's group half for a flight: each medium's emission (on_collision, emission.wgsl)
// gathered into its group's entry of flight_groups, added to the path's groups.
fn gather_flight_groups(slot: u32) {
    for (var g = 0u; g < LIGHT_GROUPS; g++) {
        if (any(flight_groups[g] != vec3<f32>(0.0))) {
            gather_group(slot, g, flight_groups[g]);
        }
    }
}
// #endif

// #if FEATURE_DATA_PASSES
// The data passes (PathState::data): one GpuDataPasses per path slot, apart from the path
// state as the light passes are; whether each has been recorded is in the path's flags
// (PATH_FLAG_ALBEDO_SEEN, PATH_FLAG_DEPTH_SEEN).
@group(1) @binding(21) var<storage, read_write> path_data: array<GpuDataPasses>;

// The albedo and normal of the path's first event that is not a smooth dielectric (or the
// sky's albedo), recorded once.
fn record_albedo(slot: u32, ps: ptr<function, GpuPathState>, albedo: vec3<f32>,
                 normal: vec3<f32>) {
    if (((*ps).flags & PATH_FLAG_ALBEDO_SEEN) != 0u) {
        return;
    }
    path_data[slot].albedo = albedo;
    path_data[slot].normal = normal;
    (*ps).flags |= PATH_FLAG_ALBEDO_SEEN;
}

// The camera ray's depth (the camera-space Z of its first surface, or BACKGROUND_DEPTH),
// recorded once.
fn record_depth(slot: u32, ps: ptr<function, GpuPathState>, depth: f32) {
    if (((*ps).flags & PATH_FLAG_DEPTH_SEEN) != 0u) {
        return;
    }
    path_data[slot].depth = depth;
    (*ps).flags |= PATH_FLAG_DEPTH_SEEN;
}

// A new path's data passes: all zero (generate's PathState).
fn clear_data(slot: u32) {
    path_data[slot] = GpuDataPasses(vec3<f32>(0.0), 0.0, vec3<f32>(0.0), 0u);
}
// #endif

// Every stage runs 64 invocations a workgroup; the indirect arguments divide by it.
const WORKGROUP: u32 = 64u;

fn queue_medium_in() -> u32 { return QUEUE_MEDIUM0 + wf.parity; }
fn queue_medium_out() -> u32 { return QUEUE_MEDIUM0 + 1u - wf.parity; }
fn queue_done_in() -> u32 { return QUEUE_DONE0 + wf.parity; }
fn queue_done_out() -> u32 { return QUEUE_DONE0 + 1u - wf.parity; }

// The slot of item i of queue q, or false past its end. Each queue holds at most
// wf.path_count items (its region of `queues`); a count past that is an overflow that
// queue_push refused, so no item past the region is ever read.
fn queue_item(q: u32, i: u32, slot: ptr<function, u32>) -> bool {
    if (i >= min(atomicLoad(&counters.queue_count[q]), wf.path_count)) {
        return false;
    }
    *slot = queues[q * wf.path_count + i];
    return true;
}

// Appends a path slot to queue q. A push past the queue's wf.path_count entries would write
// into the next queue's region (or past the buffer): it is counted instead, and the host fails
// the render (Wavefront::iterations).
fn queue_push(q: u32, slot: u32) {
    let i = atomicAdd(&counters.queue_count[q], 1u);
    if (i >= wf.path_count) {
        atomicAdd(&counters.queue_overflows, 1u);
        return;
    }
    queues[q * wf.path_count + i] = slot;
}

// Adds x to the 64-bit counter k (low word, carry into the high word).
fn add_wide(k: u32, x: u32) {
    if (x == 0u) {
        return;
    }
    let old = atomicAdd(&counters.wide[2u * k], x);
    if (old + x < old) {
        atomicAdd(&counters.wide[2u * k + 1u], 1u);
    }
}

// Folds one tracker's TrackingStats into the render's counters and the path's tallies.
fn add_tracking_stats(s: Stats, shadow: bool, ps: ptr<function, GpuPathState>) {
    add_wide(WIDE_LOOKUPS, s.lookups);
    add_wide(WIDE_NULL_COLLISIONS, s.null_collisions);
    add_wide(WIDE_REAL_COLLISIONS, s.real_collisions);
    add_wide(WIDE_CONTROL_COLLISIONS, s.control_collisions);
    add_wide(WIDE_SEGMENTS, s.segments);
    if (shadow) {
        add_wide(WIDE_SHADOW_LOOKUPS, s.lookups);
        add_wide(WIDE_SHADOW_SEGMENTS, s.segments);
    }
    if (s.majorant_violations != 0u) {
        atomicAdd(&counters.majorant_violations, s.majorant_violations);
    }
    if (s.invalid_majorants != 0u) {
        atomicAdd(&counters.invalid_majorants, s.invalid_majorants);
    }
    if (s.collision_cap_hits != 0u) {
        atomicAdd(&counters.collision_cap_hits, s.collision_cap_hits);
    }
    (*ps).collisions += s.null_collisions + s.real_collisions + s.control_collisions;
    (*ps).lookups += s.lookups;
}

// The path's random stream (the state lives in the path, between stages).
fn path_rng(ps: GpuPathState) -> Rng {
    return Rng(ps.rng_state, ps.rng_inc, vec2<u32>(0u), 0u);
}

// Sampler::get2d / get1d (src/sampling/sobol.rs) for the path of batch entry `sample_id`:
// its pixel and global sample index follow from the entry while the batch runs (generate's
// mapping), so the path state needs no extra field. SAMPLER_SOBOL: the Owen-scrambled Sobol
// point of `block`; otherwise the path's stream in call order (the independent sampler).
fn path_pixel(sample_id: u32) -> u32 {
    return wf.pixel0 + sample_id / wf.spp_batch;
}

fn path_sample_index(sample_id: u32) -> u32 {
    return wf.s0 + sample_id % wf.spp_batch;
}

fn sampler_2d(sample_id: u32, block: u32, rng: ptr<function, Rng>) -> vec2<f32> {
    if (SAMPLER_SOBOL) {
        return sobol_point(path_pixel(sample_id), path_sample_index(sample_id), block, wf.seed);
    }
    let x = rng_uniform(rng);
    let y = rng_uniform(rng);
    return vec2<f32>(x, y);
}

// Sampler::queue_on_stream: under SAMPLER_SOBOL, block `block`'s point becomes the next two
// uniforms of `rng` (the first exponential depth and event choice of a free flight).
fn sampler_queue_on_stream(sample_id: u32, block: u32, rng: ptr<function, Rng>) {
    if (SAMPLER_SOBOL) {
        let p = sobol_point_u32(path_pixel(sample_id), path_sample_index(sample_id), block, wf.seed);
        rng_queue_uniforms(rng, p.x, p.y);
    }
}

// The block's first coordinate (Sampler::get1d).
fn sampler_1d(sample_id: u32, block: u32, rng: ptr<function, Rng>) -> f32 {
    if (SAMPLER_SOBOL) {
        let p = sobol_point_u32(path_pixel(sample_id), path_sample_index(sample_id), block, wf.seed);
        return f32(p.x >> 8u) * (1.0 / 16777216.0);
    }
    return rng_uniform(rng);
}

// A world-space point in the medium's index space (rows of grid_info.index_from_world).
fn index_point(p: vec3<f32>) -> vec3<f32> {
    return grid_index_point(grid_info, p);
}

// A world-space direction in the medium's index space.
fn index_vector(v: vec3<f32>) -> vec3<f32> {
    let m = grid_info.index_from_world;
    return vec3<f32>(dot(m[0].xyz, v), dot(m[1].xyz, v), dot(m[2].xyz, v));
}

// A tracker for the VDB medium along a world ray (GreyView / RgbView::new): the index-space
// ray, the path's stream and the medium's optics.
fn medium_tracker(o: vec3<f32>, d: vec3<f32>, rng: Rng, estimator: u32) -> Tracker {
    var tr: Tracker;
    tr.params = wf.tracking;
    tr.params.estimator = estimator;
    tr.rng = rng;
    tr.o = index_point(o);
    tr.d = index_vector(d);
    tr.ow = o;
    tr.dw = d;
    tr.w = vec3<f32>(1.0);
    tr.albedo_rgb = wf.albedo_rgb;
    return tr;
}

// The majorant DDA of a tracker over [t0, t1] (media.rs `segments`).
fn medium_dda(tr: Tracker, t0: f32, t1: f32) -> Dda {
    let scale = grid_info.density_scale * tr.params.majorant_channel_scale;
    return dda_new(tr.o, tr.d, t0, t1, scale, tr.params.majorant_mode);
}

// path.rs `vdb_intervals` for the one VDB medium: its world bounds along the ray within
// [t0, t1], non-empty.
fn medium_interval(o: vec3<f32>, d: vec3<f32>, t0: f32, t1: f32,
                   out_t: ptr<function, vec2<f32>>) -> bool {
    if (wf.has_medium == 0u) {
        return false;
    }
    var te = vec2<f32>(0.0);
    if (!aabb_intersect(wf.medium_lo, wf.medium_hi, o, d, t0, t1, &te)) {
        return false;
    }
    *out_t = te;
    return te.y > te.x;
}

// russian_roulette (src/integrator/path.rs): unbiased roulette on the throughput (times
// `scale`, cone_scale's) after rr_depth events, or earlier, from the EARLY_RR_DEPTH-th event
// on, once it is below rr_throughput: survive with probability min(sqrt(max(beta) scale),
// 0.95), then divide by it.
fn russian_roulette(beta: ptr<function, vec3<f32>>, scale: f32, depth: u32, sample_id: u32,
                    rng: ptr<function, Rng>) -> bool {
    let a = abs(*beta);
    let q_beta = max(a.x, max(a.y, a.z)) * scale;
    let early = depth >= EARLY_RR_DEPTH && q_beta < wf.rr_throughput;
    if (depth < wf.rr_depth && !early) {
        return true;
    }
    let q = min(sqrt(q_beta), 0.95);
    if (!(q > 0.0) || sampler_1d(sample_id, bounce_dim(depth - 1u, DIM_RR), rng) >= q) {
        return false;
    }
    *beta /= q;
    return true;
}

// The end of radiance's loop body: russian_roulette, then the next iteration or done.
// cone_scale (src/integrator/path.rs): the ratio of a direction's mixture density with the
// lamps' cones to the phase function's or BSDF's alone, at least 1.
fn cone_scale(pdf: f32, pdf_alone: f32) -> f32 {
    if (pdf_alone > 0.0) {
        return max(pdf / pdf_alone, 1.0);
    }
    return 1.0;
}

// `rr_scale` is the roulette's scale (cone_scale; 1 without the lamps' cones).
fn continue_or_finish(ps_in: GpuPathState, slot: u32, rng_in: Rng, rr_scale: f32) {
    var ps = ps_in;
    var rng = rng_in;
    // (beta is copied out and back: naga 30's SPIR-V writer panics on `&ps.beta`.)
    var beta = ps.beta;
    let alive = russian_roulette(&beta, rr_scale, ps.depth, ps.sample_id, &rng);
    ps.beta = beta;
    ps.rng_state = rng.state;
    ps.rng_inc = rng.inc;
    paths[slot] = ps;
    if (alive) {
        queue_push(queue_medium_out(), slot);
    } else {
        queue_push(queue_done_out(), slot);
    }
}

// Queues a shadow ray from `o` towards a light `light_dist` away (inf: directional or
// environment) carrying `contribution`; it stops just short of the light, as on the CPU.
fn push_shadow_ray(slot: u32, o: vec3<f32>, wi: vec3<f32>, light_dist: f32, medium: u32,
                   outer: u32, contribution: vec3<f32>) {
    var dist = f32_inf();
    if (light_dist <= F32_MAX) {
        dist = light_dist * (1.0 - 1e-4);
    }
    var sh: GpuShadowRay;
    sh.o = o;
    sh.dist = dist;
    sh.wi = wi;
    sh.medium = medium;
    sh.outer = outer;
    sh.contribution = contribution;
    shadows[slot] = sh;
    queue_push(QUEUE_SHADOW, slot);
}
