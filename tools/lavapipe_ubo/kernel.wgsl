// Brume's generic sample_medium kernel with the blackbody table bound as a uniform block
// (three uniform blocks in bind group 0: grid_info, emission, blackbody_table), reduced to
// what the entry point reaches, comments dropped: a frozen input of tools/lavapipe_ubo/run.sh,
// not a shader Brume runs (shaders/ holds those, and keeps the table in storage).

const FEATURE_SURFACES: bool = true;

const FEATURE_CHROMATIC: bool = true;

const SAMPLER_SOBOL: bool = true;

const ESTIMATOR_DELTA: u32 = 0u;

const ESTIMATOR_WEIGHTED_DELTA: u32 = 1u;

const ESTIMATOR_DECOMPOSITION: u32 = 2u;

const ESTIMATOR_WEIGHTED_DECOMPOSITION: u32 = 3u;

const ESTIMATOR_RATIO: u32 = 4u;

const ESTIMATOR_RESIDUAL_RATIO: u32 = 5u;

const ESTIMATOR_SPECTRAL: u32 = 6u;

const MAJORANT_GLOBAL: u32 = 1u;

const MAJORANT_ADAPTIVE: u32 = 2u;

const CONTROL_CONSTANT: u32 = 1u;

const CONTROL_FRACTION_OF_BOUND: u32 = 2u;

const CONTROL_SEGMENT_MINORANT: u32 = 3u;

const CONTROL_FRACTION_OF_BOUND_CAPPED: u32 = 4u;

const QUEUE_MEDIUM0: u32 = 0u;

const QUEUE_DONE0: u32 = 2u;

const QUEUE_SCATTER: u32 = 4u;

const QUEUE_ESCAPE: u32 = 7u;

const QUEUE_SURFACE: u32 = 8u;

const WIDE_LOOKUPS: u32 = 0u;

const WIDE_NULL_COLLISIONS: u32 = 1u;

const WIDE_REAL_COLLISIONS: u32 = 2u;

const WIDE_CONTROL_COLLISIONS: u32 = 3u;

const WIDE_SHADOW_LOOKUPS: u32 = 4u;

const WIDE_EMISSION_LOOKUPS: u32 = 6u;

const WIDE_SEGMENTS: u32 = 7u;

const WIDE_SHADOW_SEGMENTS: u32 = 8u;

const PATH_FLAG_FLIGHT_STARTED: u32 = 4u;

const NO_INDEX: u32 = 4294967295u;

const WF_FLAG_ABSORPTION: u32 = 1u;

const WF_FLAG_FORCE_SPECTRAL: u32 = 2u;

const MAX_MIX: u32 = 8u;

const TEXTURE_WRAP_CLAMP: u32 = 1u;

const TEXTURE_WRAP_MIRROR: u32 = 2u;

const MATERIAL_DOUBLE_SIDED: u32 = 1u;

const BLACKBODY_TABLE_LEN: u32 = 1121u;

const BLACKBODY_T_MIN: f32 = 800.0f;

const BLACKBODY_T_MAX: f32 = 12000.0f;

const BLACKBODY_STEP: f32 = 10.0f;

const STEFAN_BOLTZMANN_SCALE: f32 = 1.8049357e-14f;

struct GpuGridInfo {
    dims: vec3<u32>,
    brick_count: u32,
    cell_origin: vec3<i32>,
    constant_count: u32,
    index_from_world: array<vec4<f32>, 3>,
    background: f32,
    density_scale: f32,
    global_bounds_index: u32,
    cell_offset: u32,
}

struct GpuMajorantSegment {
    t_min: f32,
    t_max: f32,
    sigma_maj: f32,
    sigma_min: f32,
}

struct CellBounds {
    min: f32,
    max: f32,
}

struct GpuTrackingParams {
    estimator: u32,
    majorant_mode: u32,
    control_mode: u32,
    spectral_mode: u32,
    b: f32,
    control_value: f32,
    albedo: f32,
    control_albedo: f32,
    channel_scale: vec3<f32>,
    seed: u32,
    majorant_channel_scale: f32,
    samples_per_ray: u32,
    invocation_count: u32,
    _pad0: u32,
}

struct GpuPathState {
    o: vec3<f32>,
    t0: f32,
    d: vec3<f32>,
    prev_pdf: f32,
    beta: vec3<f32>,
    sample_id: u32,
    l: vec3<f32>,
    depth: u32,
    rng_state: u32,
    rng_inc: u32,
    flags: u32,
    collisions: u32,
    lookups: u32,
    medium: u32,
    hit_prim: u32,
    hit_t: f32,
    hit_b1: f32,
    hit_b2: f32,
    outer: u32,
    phase_g: f32,
}

struct GpuTexture {
    row0: vec3<f32>,
    offset: u32,
    row1: vec3<f32>,
    width: u32,
    height: u32,
    wrap_s: u32,
    wrap_t: u32,
    nearest: u32,
}

struct GpuEnvMap {
    row0: vec4<f32>,
    row1: vec4<f32>,
    row2: vec4<f32>,
    scale: vec3<f32>,
    integral: f32,
    width: u32,
    height: u32,
    func_offset: u32,
    cond_offset: u32,
    marg_offset: u32,
    uniform: u32,
    _pad0: u32,
    _pad1: u32,
}

struct GpuHomogeneousMedium {
    sigma_a: vec3<f32>,
    g: f32,
    sigma_s: vec3<f32>,
    _pad0: f32,
}

struct Material {
    base_color: vec4<f32>,
    emission: vec3<f32>,
    metallic: f32,
    roughness: f32,
    transmission: f32,
    ior: f32,
    base_color_texture: u32,
    interior_medium: u32,
    emissive_texture: u32,
    flags: u32,
    _pad: u32,
}

struct GpuWavefrontCounters {
    queue_count: array<atomic<u32>, 9>,
    next_sample: atomic<u32>,
    live: atomic<u32>,
    guard_fired: atomic<u32>,
    majorant_violations: atomic<u32>,
    invalid_majorants: atomic<u32>,
    collision_cap_hits: atomic<u32>,
    _pad0: u32,
    wide: array<atomic<u32>, 18>,
    _pad1: u32,
    _pad2: u32,
}

struct GpuEmissionParams {
    grid: GpuGridInfo,
    temperature: GpuGridInfo,
    strength_color: vec3<f32>,
    has_grid: u32,
    tint: vec3<f32>,
    has_blackbody: u32,
    temperature_scale: f32,
    temperature_offset: f32,
    intensity: f32,
    _pad0: u32,
}

struct GpuWavefrontParams {
    camera: array<vec4<f32>, 3>,
    tan_half: f32,
    aspect: f32,
    znear: f32,
    seed: u32,
    forward: vec3<f32>,
    width: u32,
    height: u32,
    pixel0: u32,
    s0: u32,
    spp_batch: u32,
    total_samples: u32,
    path_count: u32,
    light_count: u32,
    parity: u32,
    env: vec3<f32>,
    env_pdf: f32,
    max_depth: u32,
    rr_depth: u32,
    max_collisions: u32,
    has_env: u32,
    medium_lo: vec3<f32>,
    phase_g: f32,
    medium_hi: vec3<f32>,
    has_medium: u32,
    scatter_albedo: vec3<f32>,
    spectral: u32,
    albedo_rgb: vec3<f32>,
    shadow_estimator: u32,
    tracking: GpuTrackingParams,
    camera_medium: u32,
    area_count: u32,
    rr_throughput: f32,
    absorption_weight: u32,
    camera_outer: u32,
    vdb_count: u32,
    flags: u32,
    mix_estimator: u32,
    continuation_albedo: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

struct GpuVdbMedium {
    grid: GpuGridInfo,
    tracking: GpuTrackingParams,
    emission: GpuEmissionParams,
    lo: vec3<f32>,
    phase_g: f32,
    hi: vec3<f32>,
    spectral: u32,
    scatter_albedo: vec3<f32>,
    shadow_estimator: u32,
    albedo_rgb: vec3<f32>,
    grey_sigma_a: f32,
    rgb_sigma_a: vec3<f32>,
    grey_sigma_s: f32,
    rgb_sigma_s: vec3<f32>,
    bounds_base: u32,
    sigma_s: vec3<f32>,
    control_albedo: f32,
}

const LN2_HI: f32 = 6.9313812256e-01;

const LN2_LO: f32 = 9.0580006145e-06;

const LG1: f32 = 0.66666662693;

const LG2: f32 = 0.40000972152;

const LG3: f32 = 0.28498786688;

const LG4: f32 = 0.24279078841;

fn ln_f32(x_in: f32) -> f32 {
    var ix = bitcast<u32>(x_in);
    ix += 0x3f800000u - 0x3f3504f3u;
    let k = i32(ix >> 23u) - 0x7f;
    ix = (ix & 0x007fffffu) + 0x3f3504f3u;
    let f = bitcast<f32>(ix) - 1.0;
    let s = f / (2.0 + f);
    let z = s * s;
    let w = z * z;
    let t1 = w * (LG2 + w * LG4);
    let t2 = z * (LG1 + w * LG3);
    let r = t2 + t1;
    let hfsq = 0.5 * f * f;
    let dk = f32(k);
    return s * (hfsq + r) + dk * LN2_LO - hfsq + f + dk * LN2_HI;
}

const PCG_MULT: u32 = 747796405u;

const PCG_INC: u32 = 2891336453u;

const RXS_M_XS_MULT: u32 = 277803737u;

struct Rng {
    state: u32,
    inc: u32,
    queued: vec2<u32>,
    n_queued: u32,
}

fn rxs_m_xs(s: u32) -> u32 {
    let w = ((s >> ((s >> 28u) + 4u)) ^ s) * RXS_M_XS_MULT;
    return (w >> 22u) ^ w;
}

fn pcg_hash(x: u32) -> u32 {
    return rxs_m_xs(x * PCG_MULT + PCG_INC);
}

fn rng_next_u32(rng: ptr<function, Rng>) -> u32 {
    let old = (*rng).state;
    (*rng).state = old * PCG_MULT + (*rng).inc;
    return rxs_m_xs(old);
}

fn rng_uniform(rng: ptr<function, Rng>) -> f32 {
    var v = 0u;
    if ((*rng).n_queued > 0u) {
        (*rng).n_queued -= 1u;
        v = (*rng).queued[1u - (*rng).n_queued];
    } else {
        v = rng_next_u32(rng) >> 8u;
    }
    return f32(v) * (1.0 / 16777216.0);
}

fn rng_queue_uniforms(rng: ptr<function, Rng>, a: u32, b: u32) {
    (*rng).queued = vec2<u32>(a >> 8u, b >> 8u);
    (*rng).n_queued = 2u;
}

const SOBOL_SALT: u32 = 0x5EED50B0u;

const DIMS_PER_BOUNCE: u32 = 6u;

const DIM_DISTANCE: u32 = 0u;

fn bounce_dim(depth: u32, offset: u32) -> u32 {
    return 1u + depth * DIMS_PER_BOUNCE + offset;
}

fn laine_karras(x_in: u32, seed: u32) -> u32 {
    var x = x_in + seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return x;
}

fn owen_scramble(v: u32, seed: u32) -> u32 {
    return reverseBits(laine_karras(reverseBits(v), seed));
}

fn sobol_dim1(i_in: u32) -> u32 {
    var i = i_in;
    var v = 0x80000000u;
    var r = 0u;
    while (i != 0u) {
        if ((i & 1u) != 0u) {
            r ^= v;
        }
        i = i >> 1u;
        v ^= v >> 1u;
    }
    return r;
}

fn sobol_block_seed(pixel: u32, block: u32, seed: u32) -> u32 {
    return pcg_hash(pcg_hash(pcg_hash(seed ^ SOBOL_SALT) ^ pixel) ^ block);
}

fn sobol_point_u32(pixel: u32, sample: u32, block: u32, seed: u32) -> vec2<u32> {
    let s = sobol_block_seed(pixel, block, seed);
    let i = owen_scramble(sample, pcg_hash(s));
    return vec2<u32>(owen_scramble(reverseBits(i), pcg_hash(s ^ 1u)),
                     owen_scramble(sobol_dim1(i), pcg_hash(s ^ 2u)));
}

const CONSTANT_BIT: u32 = 0x80000000u;

@group(0) @binding(0) var<uniform> grid_info: GpuGridInfo;

@group(0) @binding(1) var<storage, read> grid_cells: array<u32>;

@group(0) @binding(2) var<storage, read> grid_bricks: array<f32>;

@group(0) @binding(3) var<storage, read> grid_constants: array<f32>;

fn grid_entry_at_in(g: GpuGridInfo, v: vec3<i32>, entry: ptr<function, u32>) -> bool {
    let c = vec3<u32>((v >> vec3<u32>(3u)) - g.cell_origin);
    if (any(c >= g.dims)) {
        return false;
    }
    *entry = grid_cells[g.cell_offset + c.x + g.dims.x * (c.y + g.dims.y * c.z)];
    return true;
}

fn grid_entry_value(entry: u32, local: u32) -> f32 {
    if ((entry & CONSTANT_BIT) != 0u) {
        return grid_constants[entry & ~CONSTANT_BIT];
    }
    return grid_bricks[entry * 512u + local];
}

fn grid_voxel_in(g: GpuGridInfo, v: vec3<i32>) -> f32 {
    var entry = 0u;
    if (!grid_entry_at_in(g, v, &entry)) {
        return g.background;
    }
    let l = vec3<u32>(v & vec3<i32>(7));
    return grid_entry_value(entry, l.x + 8u * l.y + 64u * l.z);
}

fn grid_all_background_near(g: GpuGridInfo, p: vec3<f32>) -> bool {
    let lo = vec3<f32>(g.cell_origin * 8);
    let hi = lo + vec3<f32>(g.dims * 8u);
    return !(all(p >= lo - 1.0) && all(p < hi));
}

fn lerp_vdb(a: f32, b: f32, w: f32) -> f32 {
    return a + (b - a) * w;
}

fn trilinear_vdb(v: array<f32, 8>, f: vec3<f32>) -> f32 {
    let a = lerp_vdb(lerp_vdb(v[0], v[1], f.z), lerp_vdb(v[2], v[3], f.z), f.y);
    let b = lerp_vdb(lerp_vdb(v[4], v[5], f.z), lerp_vdb(v[6], v[7], f.z), f.y);
    return lerp_vdb(a, b, f.x);
}

fn grid_sample_trilinear_in(g: GpuGridInfo, p: vec3<f32>) -> f32 {
    if (grid_all_background_near(g, p)) {
        return g.background;
    }
    let fl = floor(p);
    let i = vec3<i32>(fl);
    let f = p - fl;
    var v: array<f32, 8>;
    var entry = 0u;
    if (all((i & vec3<i32>(7)) != vec3<i32>(7)) && grid_entry_at_in(g, i, &entry)) {
        if ((entry & CONSTANT_BIT) != 0u) {
            return grid_constants[entry & ~CONSTANT_BIT];
        }
        let l = vec3<u32>(i & vec3<i32>(7));
        let base = entry * 512u + l.x + 8u * l.y + 64u * l.z;
        for (var c = 0u; c < 8u; c++) {
            v[c] = grid_bricks[base + (c >> 2u) + 8u * ((c >> 1u) & 1u) + 64u * (c & 1u)];
        }
    } else {
        for (var c = 0u; c < 8u; c++) {
            let o = vec3<i32>(i32(c >> 2u), i32((c >> 1u) & 1u), i32(c & 1u));
            v[c] = grid_voxel_in(g, i + o);
        }
    }
    return trilinear_vdb(v, f);
}

fn grid_sample_trilinear(p: vec3<f32>) -> f32 {
    return grid_sample_trilinear_in(grid_info, p);
}

fn grid_index_point(g: GpuGridInfo, p: vec3<f32>) -> vec3<f32> {
    let m = g.index_from_world;
    let q = vec4<f32>(p, 1.0);
    return vec3<f32>(dot(m[0], q), dot(m[1], q), dot(m[2], q));
}

@group(0) @binding(4) var<storage, read> grid_bounds: array<CellBounds>;

const CELL_WIDTH: f32 = 8.0;

fn f32_inf() -> f32 {
    var bits = 0x7f800000u;
    return bitcast<f32>(bits);
}

struct Dda {
    dims: vec3<i32>,
    lo: vec3<f32>,
    width: vec3<f32>,
    o: vec3<f32>,
    d: vec3<f32>,
    inv_d: vec3<f32>,
    scale: f32,
    global: bool,
    adaptive: bool,
    cell: vec3<i32>,
    step: vec3<i32>,
    next_crossing: vec3<f32>,
    t: f32,
    t_exit: f32,
    done: bool,
    bounds_base: u32,
    global_index: u32,
}

fn aabb_intersect(lo: vec3<f32>, hi: vec3<f32>, o: vec3<f32>, d: vec3<f32>, t0: f32, t1: f32,
                  out_t: ptr<function, vec2<f32>>) -> bool {
    var t_near = t0;
    var t_far = t1;
    for (var a = 0; a < 3; a++) {
        let inv = 1.0 / d[a];
        var ta = (lo[a] - o[a]) * inv;
        var tb = (hi[a] - o[a]) * inv;
        if (ta > tb) {
            let tmp = ta;
            ta = tb;
            tb = tmp;
        }
        if (ta > t_near) {
            t_near = ta;
        }
        if (tb < t_far) {
            t_far = tb;
        }
        if (t_near > t_far) {
            return false;
        }
    }
    *out_t = vec2<f32>(t_near, t_far);
    return true;
}

fn dda_step(d: f32, inv: f32) -> i32 {
    if (!(abs(inv) <= 3.40282347e38)) {
        return 0;
    }
    return select(-1, 1, d > 0.0);
}

fn dda_crossing(it: ptr<function, Dda>, axis: i32) -> f32 {
    let s = (*it).step[axis];
    if (s == 0) {
        return f32_inf();
    }
    let plane_cell = select((*it).cell[axis], (*it).cell[axis] + 1, s == 1);
    let plane = (*it).lo[axis] + f32(plane_cell) * (*it).width[axis];
    return (plane - (*it).o[axis]) * (*it).inv_d[axis];
}

fn dda_new_in(g: GpuGridInfo, bounds_base: u32, o: vec3<f32>, d: vec3<f32>, t0: f32, t1: f32,
              scale: f32, mode: u32) -> Dda {
    var it: Dda;
    it.bounds_base = bounds_base;
    it.global_index = g.global_bounds_index;
    let global = mode == MAJORANT_GLOBAL;
    it.o = o;
    it.d = d;
    it.inv_d = vec3<f32>(1.0) / d;
    it.scale = scale;
    it.global = global;
    it.adaptive = mode == MAJORANT_ADAPTIVE;
    it.lo = vec3<f32>(g.cell_origin) * CELL_WIDTH;
    let grid_dims = vec3<i32>(g.dims);
    let empty = any(grid_dims <= vec3<i32>(0));
    if (global) {
        it.width = vec3<f32>(grid_dims) * CELL_WIDTH;
        it.dims = select(vec3<i32>(1), vec3<i32>(0), empty);
    } else {
        it.width = vec3<f32>(CELL_WIDTH);
        it.dims = grid_dims;
    }
    it.cell = vec3<i32>(0);
    it.step = vec3<i32>(0);
    it.next_crossing = vec3<f32>(f32_inf());
    it.t = 0.0;
    it.t_exit = 0.0;
    it.done = true;
    if (any(it.dims <= vec3<i32>(0))) {
        return it;
    }
    let hi = it.lo + it.width * vec3<f32>(it.dims);
    var te = vec2<f32>(0.0);
    if (!aabb_intersect(it.lo, hi, o, d, t0, t1, &te)) {
        return it;
    }
    if (!(te.x < te.y)) {
        return it;
    }
    let p = o + te.x * d;
    for (var a = 0; a < 3; a++) {
        let x = select(p[a], o[a], d[a] == 0.0);
        let g = floor((x - it.lo[a]) / it.width[a]);
        it.cell[a] = select(clamp(i32(g), 0, it.dims[a] - 1), 0, g != g);
        it.step[a] = dda_step(d[a], it.inv_d[a]);
        it.next_crossing[a] = dda_crossing(&it, a);
    }
    it.t = te.x;
    it.t_exit = te.y;
    it.done = false;
    return it;
}

fn dda_cell_bounds(it: ptr<function, Dda>) -> CellBounds {
    if ((*it).global) {
        return grid_bounds[(*it).bounds_base + (*it).global_index];
    }
    let c = vec3<u32>((*it).cell);
    let n = vec3<u32>((*it).dims);
    return grid_bounds[(*it).bounds_base + c.x + n.x * (c.y + n.y * c.z)];
}

fn adaptive_table(it: ptr<function, Dda>, slot: u32) -> u32 {
    let base = (*it).bounds_base;
    let b = grid_bounds[base + (*it).global_index + 1u + slot / 2u];
    return base + u32(select(b.min, b.max, (slot & 1u) == 1u));
}

fn adaptive_level(it: ptr<function, Dda>, c: vec3<i32>) -> u32 {
    let n = vec3<u32>((*it).dims);
    let i = u32(c.x) + n.x * (u32(c.y) + n.y * u32(c.z));
    let b = grid_bounds[adaptive_table(it, 14u) + i / 8u];
    let w = u32(select(b.min, b.max, ((i / 4u) & 1u) == 1u));
    return (w >> (4u * (i % 4u))) & 15u;
}

fn adaptive_node(it: ptr<function, Dda>, l: u32, node: vec3<i32>) -> CellBounds {
    let dims = (vec3<u32>((*it).dims) + vec3<u32>((1u << l) - 1u)) >> vec3<u32>(l);
    let i = u32(node.x) + dims.x * (u32(node.y) + dims.y * u32(node.z));
    return grid_bounds[adaptive_table(it, l) + i];
}

fn adaptive_crossing(it: ptr<function, Dda>, axis: i32, node: i32, l: u32) -> f32 {
    let s = (*it).step[axis];
    if (s == 0) {
        return f32_inf();
    }
    let plane_node = select(node, node + 1, s == 1);
    let plane = (*it).lo[axis] + f32(plane_node << l) * CELL_WIDTH;
    return (plane - (*it).o[axis]) * (*it).inv_d[axis];
}

fn adaptive_next(it: ptr<function, Dda>, seg: ptr<function, GpuMajorantSegment>) -> bool {
    while (!(*it).done) {
        let l = adaptive_level(it, (*it).cell);
        let node = (*it).cell >> vec3<u32>(l);
        let c = vec3<f32>(adaptive_crossing(it, 0, node.x, l), adaptive_crossing(it, 1, node.y, l),
                          adaptive_crossing(it, 2, node.z, l));
        var axis = 2;
        if (c[0] <= c[1] && c[0] <= c[2]) {
            axis = 0;
        } else if (c[1] <= c[2]) {
            axis = 1;
        }
        var next_cell = (node[axis] << l) - 1;
        if ((*it).step[axis] > 0) {
            next_cell = (node[axis] + 1) << l;
        }
        let leaving = c[axis] >= (*it).t_exit || next_cell < 0 || next_cell >= (*it).dims[axis];
        let t_min = (*it).t;
        var t_max = t_min;
        if (leaving) {
            t_max = (*it).t_exit;
        } else if (c[axis] > t_min) {
            t_max = c[axis];
        }
        let b = adaptive_node(it, l, node);
        if (leaving) {
            (*it).done = true;
        } else {
            let p = (*it).o + t_max * (*it).d;
            for (var a = 0; a < 3; a++) {
                if (a == axis || l == 0u || (*it).step[a] == 0) {
                    continue;
                }
                let g = floor((p[a] - (*it).lo[a]) / CELL_WIDTH);
                let first = node[a] << l;
                let last = min(((node[a] + 1) << l) - 1, (*it).dims[a] - 1);
                if (g == g) {
                    (*it).cell[a] = clamp(i32(g), first, last);
                }
            }
            (*it).cell[axis] = next_cell;
            (*it).t = t_max;
        }
        if (t_max > t_min) {
            *seg = GpuMajorantSegment(t_min, t_max, (*it).scale * b.max, (*it).scale * b.min);
            return true;
        }
    }
    return false;
}

fn dda_next(it: ptr<function, Dda>, seg: ptr<function, GpuMajorantSegment>) -> bool {
    if ((*it).adaptive) {
        return adaptive_next(it, seg);
    }
    while (!(*it).done) {
        let c = (*it).next_crossing;
        var axis = 2;
        if (c[0] <= c[1] && c[0] <= c[2]) {
            axis = 0;
        } else if (c[1] <= c[2]) {
            axis = 1;
        }
        let next_cell = (*it).cell[axis] + (*it).step[axis];
        let leaving = (*it).next_crossing[axis] >= (*it).t_exit || next_cell < 0
            || next_cell >= (*it).dims[axis];
        let t_min = (*it).t;
        let crossing = (*it).next_crossing[axis];
        var t_max = t_min;
        if (leaving) {
            t_max = (*it).t_exit;
        } else if (crossing > t_min) {
            t_max = crossing;
        }
        let b = dda_cell_bounds(it);
        if (leaving) {
            (*it).done = true;
        } else {
            (*it).cell[axis] = next_cell;
            (*it).next_crossing[axis] = dda_crossing(it, axis);
            (*it).t = t_max;
        }
        if (t_max > t_min) {
            *seg = GpuMajorantSegment(t_min, t_max, (*it).scale * b.max, (*it).scale * b.min);
            return true;
        }
    }
    return false;
}

const INV_4PI: f32 = 0.0795774715459476679;

const PI: f32 = 3.14159265358979323846;

const MAJORANT_TOLERANCE: f32 = 1e-4;

const ROULETTE_THRESHOLD: f32 = 0.1;

const MAX_TENTATIVE_COLLISIONS: u32 = 16777216u;

const F32_MAX: f32 = 3.40282347e38;

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

struct Coeffs {
    sigma_a: f32,
    sigma_s: f32,
}

struct Tracker {
    params: GpuTrackingParams,
    rng: Rng,
    stats: Stats,
    o: vec3<f32>,
    d: vec3<f32>,
    w: vec3<f32>,
    distance: bool,
    beta: vec3<f32>,
    event: u32,
    t_event: f32,
    albedo_rgb: vec3<f32>,
    ow: vec3<f32>,
    dw: vec3<f32>,
    emitted: vec3<f32>,
    emission_lookups: u32,
    sum_control: bool,
    tau_c: f32,
    mix: u32,
}

const MIX_ALL: u32 = 0xFFFFFFFFu;

const CONTROL_DEPTH_CUTOFF: f32 = 104.0;

const EVENT_ESCAPE: u32 = 0u;

const EVENT_ABSORB: u32 = 1u;

const EVENT_SCATTER: u32 = 2u;

const ONE_MINUS_EPSILON: f32 = 0.99999994;

fn coeffs_from_sigma_t(sigma_t: f32, albedo: f32) -> Coeffs {
    return Coeffs((1.0 - albedo) * sigma_t, albedo * sigma_t);
}

fn coeffs_sigma_t(k: Coeffs) -> f32 {
    return k.sigma_a + k.sigma_s;
}

fn copysign(x: f32, y: f32) -> f32 {
    return bitcast<f32>((bitcast<u32>(x) & 0x7fffffffu) | (bitcast<u32>(y) & 0x80000000u));
}

fn medium_sigma_t(tr: ptr<function, Tracker>, t: f32) -> f32 {
    if ((*tr).mix != 0u) {
        let g = vdb_media[(*tr).mix - 1u].grid;
        return g.density_scale * grid_sample_trilinear_in(g, (*tr).o + t * (*tr).d);
    }
    return grid_info.density_scale * grid_sample_trilinear((*tr).o + t * (*tr).d);
}

fn lookup(tr: ptr<function, Tracker>, t: f32) -> Coeffs {
    if ((*tr).mix == MIX_ALL) {
        return mix_coeffs(tr, t);
    }
    (*tr).stats.lookups += 1u;
    return coeffs_from_sigma_t(medium_sigma_t(tr, t), (*tr).params.albedo);
}

struct CoeffsRgb {
    sigma_a: vec3<f32>,
    sigma_s: vec3<f32>,
}

fn lookup_rgb(tr: ptr<function, Tracker>, t: f32) -> CoeffsRgb {
    if ((*tr).mix == MIX_ALL) {
        return mix_coeffs_rgb(tr, t);
    }
    (*tr).stats.lookups += 1u;
    let s = (*tr).params.channel_scale * medium_sigma_t(tr, t);
    let albedo = (*tr).albedo_rgb;
    return CoeffsRgb((1.0 - albedo) * s, albedo * s);
}

fn lookup_rgb_sigma_t(tr: ptr<function, Tracker>, t: f32) -> vec3<f32> {
    let k = lookup_rgb(tr, t);
    return k.sigma_a + k.sigma_s;
}

fn control_sigma_c(tr: ptr<function, Tracker>, seg: GpuMajorantSegment) -> f32 {
    switch (*tr).params.control_mode {
        case CONTROL_CONSTANT: { return (*tr).params.control_value; }
        case CONTROL_FRACTION_OF_BOUND: { return (*tr).params.control_value * seg.sigma_maj; }
        case CONTROL_SEGMENT_MINORANT: { return seg.sigma_min; }
        case CONTROL_FRACTION_OF_BOUND_CAPPED: { return min((*tr).params.control_value * seg.sigma_maj, seg.sigma_min); }
        default: { return 0.0; }
    }
}

fn control(tr: ptr<function, Tracker>, seg: GpuMajorantSegment) -> Coeffs {
    if ((*tr).mix == MIX_ALL) {
        return mix_control(control_sigma_c(tr, seg));
    }
    return coeffs_from_sigma_t(control_sigma_c(tr, seg), (*tr).params.control_albedo);
}

fn check_bound(tr: ptr<function, Tracker>, sigma_t: f32, sigma_maj: f32) {
    if (sigma_t > sigma_maj * (1.0 + MAJORANT_TOLERANCE)) {
        (*tr).stats.majorant_violations += 1u;
    }
}

fn check_residual(tr: ptr<function, Tracker>, r_a: f32, r_s: f32, sigma_maj: f32) {
    let slack = -MAJORANT_TOLERANCE * sigma_maj;
    if (r_a < slack || r_s < slack) {
        (*tr).stats.majorant_violations += 1u;
    }
}

fn note_weight(tr: ptr<function, Tracker>, w: f32) {
    (*tr).stats.max_abs_weight = max((*tr).stats.max_abs_weight, abs(w));
}

fn residual_majorant(b: f32, seg: GpuMajorantSegment, sigma_c: f32) -> f32 {
    return b * max(max(seg.sigma_maj - sigma_c, sigma_c - seg.sigma_min), 0.0);
}

fn tracker_uniform(tr: ptr<function, Tracker>) -> f32 {
    var rng = (*tr).rng;
    let u = rng_uniform(&rng);
    (*tr).rng = rng;
    return u;
}

fn sample_exponential(u: f32, sigma: f32) -> f32 {
    return -ln_f32(1.0 - u) / sigma;
}

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

fn spectral_reduce(mode: u32, v: vec3<f32>) -> f32 {
    let a = abs(v);
    if (mode == 0u) {
        return max(a.x, max(a.y, a.z));
    }
    return (a.x + a.y + a.z) * (1.0 / 3.0);
}

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
        default: { return b * seg.sigma_maj; }
    }
}

fn transmittance_collide(tr: ptr<function, Tracker>, t: f32, sigma_maj: f32,
                    seg: GpuMajorantSegment) -> bool {
    switch (*tr).params.estimator {
        case ESTIMATOR_DELTA: {
            let sigma_t = coeffs_sigma_t(lookup(tr, t));
            check_bound(tr, sigma_t, sigma_maj);
            if (tracker_uniform(tr) * sigma_maj < sigma_t) {
                (*tr).stats.real_collisions += 1u;
                (*tr).w.x = 0.0;
                return false;
            }
            (*tr).stats.null_collisions += 1u;
            return true;
        }
        case ESTIMATOR_WEIGHTED_DELTA: {
            let sigma_t = coeffs_sigma_t(lookup(tr, t));
            let sigma_n = sigma_maj - sigma_t;
            let total = abs(sigma_t) + abs(sigma_n);
            if (tracker_uniform(tr) * total < abs(sigma_t)) {
                (*tr).stats.real_collisions += 1u;
                (*tr).w.x = 0.0;
                return false;
            }
            (*tr).stats.null_collisions += 1u;
            (*tr).w.x *= copysign(total / sigma_maj, sigma_n);
            note_weight(tr, (*tr).w.x);
            return true;
        }
        case ESTIMATOR_DECOMPOSITION: {
            let ctl = control(tr, seg);
            let k = lookup(tr, t);
            check_bound(tr, coeffs_sigma_t(k), seg.sigma_maj);
            check_residual(tr, k.sigma_a - ctl.sigma_a, k.sigma_s - ctl.sigma_s, seg.sigma_maj);
            let sigma_r = coeffs_sigma_t(k) - coeffs_sigma_t(ctl);
            if (tracker_uniform(tr) * sigma_maj < sigma_r) {
                (*tr).stats.real_collisions += 1u;
                (*tr).w.x = 0.0;
                return false;
            }
            (*tr).stats.null_collisions += 1u;
            return true;
        }
        case ESTIMATOR_WEIGHTED_DECOMPOSITION: {
            let sigma_r = coeffs_sigma_t(lookup(tr, t)) - coeffs_sigma_t(control(tr, seg));
            let r_n = sigma_maj - sigma_r;
            let total = abs(sigma_r) + abs(r_n);
            if (tracker_uniform(tr) * total < abs(sigma_r)) {
                (*tr).stats.real_collisions += 1u;
                (*tr).w.x = 0.0;
                return false;
            }
            (*tr).stats.null_collisions += 1u;
            (*tr).w.x *= copysign(total / sigma_maj, r_n);
            note_weight(tr, (*tr).w.x);
            return true;
        }
        case ESTIMATOR_RATIO: {
            let sigma_t = coeffs_sigma_t(lookup(tr, t));
            (*tr).stats.null_collisions += 1u;
            (*tr).w.x *= 1.0 - sigma_t / sigma_maj;
            note_weight(tr, (*tr).w.x);
            (*tr).w.x = roulette(tr, (*tr).w.x);
            return (*tr).w.x != 0.0;
        }
        case ESTIMATOR_RESIDUAL_RATIO: {
            let sigma_r = coeffs_sigma_t(lookup(tr, t)) - coeffs_sigma_t(control(tr, seg));
            (*tr).stats.null_collisions += 1u;
            (*tr).w.x *= 1.0 - sigma_r / sigma_maj;
            note_weight(tr, (*tr).w.x);
            (*tr).w.x = roulette(tr, (*tr).w.x);
            return (*tr).w.x != 0.0;
        }
        case ESTIMATOR_SPECTRAL: {
            let sigma_t = lookup_rgb_sigma_t(tr, t);
            let sigma_n = vec3<f32>(sigma_maj) - sigma_t;
            let mode = (*tr).params.spectral_mode;
            let p_real = spectral_reduce(mode, sigma_t * (*tr).w);
            let p_null = spectral_reduce(mode, sigma_n * (*tr).w);
            let total = p_real + p_null;
            if (!(total > 0.0) || tracker_uniform(tr) * total < p_real) {
                (*tr).stats.real_collisions += 1u;
                (*tr).w = vec3<f32>(0.0);
                return false;
            }
            (*tr).stats.null_collisions += 1u;
            (*tr).w *= sigma_n * (total / (sigma_maj * p_null));
            let a = abs((*tr).w);
            note_weight(tr, max(a.x, max(a.y, a.z)));
            (*tr).w = roulette_rgb(tr, (*tr).w);
            return any((*tr).w != vec3<f32>(0.0));
        }
        default: {
            return false;
        }
    }
}

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
    return DiscreteSample(last, w[last] / sum, ONE_MINUS_EPSILON);
}

fn end_flight(tr: ptr<function, Tracker>, event: u32, t: f32) -> bool {
    (*tr).event = event;
    (*tr).t_event = t;
    return false;
}

fn distance_majorant(tr: ptr<function, Tracker>, seg: GpuMajorantSegment) -> f32 {
    let b = (*tr).params.b;
    switch (*tr).params.estimator {
        case ESTIMATOR_DELTA, ESTIMATOR_DECOMPOSITION: { return seg.sigma_maj; }
        case ESTIMATOR_WEIGHTED_DECOMPOSITION: {
            let sigma_c = coeffs_sigma_t(control(tr, seg));
            return sigma_c + residual_majorant(b, seg, sigma_c);
        }
        default: { return b * seg.sigma_maj; }
    }
}

fn distance_collide(tr: ptr<function, Tracker>, t: f32, sigma_maj: f32,
                    seg: GpuMajorantSegment) -> bool {
    on_collision(tr, t, sigma_maj);
    switch (*tr).params.estimator {
        case ESTIMATOR_DELTA: {
            let k = lookup(tr, t);
            check_bound(tr, coeffs_sigma_t(k), sigma_maj);
            let x = tracker_uniform(tr) * sigma_maj;
            if (x < k.sigma_a) {
                (*tr).stats.real_collisions += 1u;
                return end_flight(tr, EVENT_ABSORB, t);
            }
            if (x < k.sigma_a + k.sigma_s) {
                (*tr).stats.real_collisions += 1u;
                return end_flight(tr, EVENT_SCATTER, t);
            }
            (*tr).stats.null_collisions += 1u;
            return true;
        }
        case ESTIMATOR_WEIGHTED_DELTA: {
            let k = lookup(tr, t);
            let sigma_n = sigma_maj - coeffs_sigma_t(k);
            let p = array<f32, 3>(abs(k.sigma_a), abs(k.sigma_s), abs(sigma_n));
            let total = p[0] + p[1] + p[2];
            let c = sample_discrete3(p, tracker_uniform(tr));
            if (c.index == 3u) {
                return true;
            }
            let sigma_x = array<f32, 3>(k.sigma_a, k.sigma_s, sigma_n)[c.index];
            (*tr).w.x *= copysign(total / sigma_maj, sigma_x);
            note_weight(tr, (*tr).w.x);
            if (c.index == 0u) {
                (*tr).stats.real_collisions += 1u;
                return end_flight(tr, EVENT_ABSORB, t);
            }
            if (c.index == 1u) {
                (*tr).stats.real_collisions += 1u;
                return end_flight(tr, EVENT_SCATTER, t);
            }
            (*tr).stats.null_collisions += 1u;
            return true;
        }
        case ESTIMATOR_DECOMPOSITION: {
            let ctl = control(tr, seg);
            var x = tracker_uniform(tr) * sigma_maj;
            if (x < ctl.sigma_a) {
                (*tr).stats.control_collisions += 1u;
                return end_flight(tr, EVENT_ABSORB, t);
            }
            if (x < coeffs_sigma_t(ctl)) {
                (*tr).stats.control_collisions += 1u;
                return end_flight(tr, EVENT_SCATTER, t);
            }
            let k = lookup(tr, t);
            check_bound(tr, coeffs_sigma_t(k), sigma_maj);
            let r_a = k.sigma_a - ctl.sigma_a;
            let r_s = k.sigma_s - ctl.sigma_s;
            check_residual(tr, r_a, r_s, sigma_maj);
            x = x - coeffs_sigma_t(ctl);
            if (x < r_a) {
                (*tr).stats.real_collisions += 1u;
                return end_flight(tr, EVENT_ABSORB, t);
            }
            if (x < r_a + r_s) {
                (*tr).stats.real_collisions += 1u;
                return end_flight(tr, EVENT_SCATTER, t);
            }
            (*tr).stats.null_collisions += 1u;
            return true;
        }
        case ESTIMATOR_WEIGHTED_DECOMPOSITION: {
            let ctl = control(tr, seg);
            let sigma_c = coeffs_sigma_t(ctl);
            let x = tracker_uniform(tr) * sigma_maj;
            if (x < sigma_c) {
                (*tr).stats.control_collisions += 1u;
                return end_flight(tr, select(EVENT_SCATTER, EVENT_ABSORB, x < ctl.sigma_a), t);
            }
            let r_bar = residual_majorant((*tr).params.b, seg, sigma_c);
            if (!(r_bar > 0.0)) {
                return true;
            }
            let u = clamp((x - sigma_c) / r_bar, 0.0, ONE_MINUS_EPSILON);
            let k = lookup(tr, t);
            let r_a = k.sigma_a - ctl.sigma_a;
            let r_s = k.sigma_s - ctl.sigma_s;
            let r_n = r_bar - r_a - r_s;
            let p = array<f32, 3>(abs(r_a), abs(r_s), abs(r_n));
            let total = p[0] + p[1] + p[2];
            let c = sample_discrete3(p, u);
            if (c.index == 3u) {
                return true;
            }
            let sigma_x = array<f32, 3>(r_a, r_s, r_n)[c.index];
            (*tr).w.x *= copysign(total / r_bar, sigma_x);
            note_weight(tr, (*tr).w.x);
            if (c.index == 0u) {
                (*tr).stats.real_collisions += 1u;
                return end_flight(tr, EVENT_ABSORB, t);
            }
            if (c.index == 1u) {
                (*tr).stats.real_collisions += 1u;
                return end_flight(tr, EVENT_SCATTER, t);
            }
            (*tr).stats.null_collisions += 1u;
            return true;
        }
        case ESTIMATOR_SPECTRAL: {
            let k = lookup_rgb(tr, t);
            let sigma_n = vec3<f32>(sigma_maj) - (k.sigma_a + k.sigma_s);
            let h = (*tr).beta * (*tr).w;
            let mode = (*tr).params.spectral_mode;
            let p = array<f32, 3>(spectral_reduce(mode, k.sigma_a * h),
                                  spectral_reduce(mode, k.sigma_s * h),
                                  spectral_reduce(mode, sigma_n * h));
            let c = sample_discrete3(p, tracker_uniform(tr));
            if (c.index == 3u) {
                (*tr).w = vec3<f32>(0.0);
                return end_flight(tr, EVENT_ABSORB, t);
            }
            let sigma_x = array<vec3<f32>, 3>(k.sigma_a, k.sigma_s, sigma_n)[c.index];
            (*tr).w *= sigma_x / (sigma_maj * c.pmf);
            let a = abs((*tr).w);
            note_weight(tr, max(a.x, max(a.y, a.z)));
            if (c.index == 0u) {
                (*tr).stats.real_collisions += 1u;
                return end_flight(tr, EVENT_ABSORB, t);
            }
            if (c.index == 1u) {
                (*tr).stats.real_collisions += 1u;
                return end_flight(tr, EVENT_SCATTER, t);
            }
            (*tr).stats.null_collisions += 1u;
            (*tr).w = roulette_rgb(tr, (*tr).w);
            if (all((*tr).w == vec3<f32>(0.0))) {
                return end_flight(tr, EVENT_ABSORB, t);
            }
            return true;
        }
        default: {
            return false;
        }
    }
}

fn tracking_majorant(tr: ptr<function, Tracker>, seg: GpuMajorantSegment) -> f32 {
    if ((*tr).distance) {
        return distance_majorant(tr, seg);
    }
    return transmittance_majorant(tr, seg);
}

fn tracking_collide(tr: ptr<function, Tracker>, t: f32, sigma_maj: f32,
                    seg: GpuMajorantSegment) -> bool {
    if ((*tr).distance) {
        return distance_collide(tr, t, sigma_maj, seg);
    }
    return transmittance_collide(tr, t, sigma_maj, seg);
}

fn sample_free_flight(tr: ptr<function, Tracker>, dda_start: Dda, t_max: f32) -> f32 {
    var dda = dda_start;
    var seg: GpuMajorantSegment;
    var tau_left = -1.0;
    var tau_since = 0.0;
    var n_collisions = 0u;
    loop {
        if ((*tr).sum_control && (*tr).tau_c > CONTROL_DEPTH_CUTOFF) {
            break;
        }
        var more = false;
        if ((*tr).mix == MIX_ALL) {
            more = mix_next(&seg);
        } else {
            more = dda_next(&dda, &seg);
        }
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
        var t = seg.t_min;
        loop {
            if (tau_left < 0.0) {
                tau_left = sample_exponential(tracker_uniform(tr), 1.0);
            }
            let tau_seg = sigma_maj * (t1 - t);
            var t_next = t1;
            if (tau_left < tau_seg) {
                t_next = t + tau_left / sigma_maj;
            }
            if (!(t_next < t1)) {
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
            if (!tracking_collide(tr, t, sigma_maj, seg)) {
                return 1.0;
            }
        }
    }
    return exp(-tau_since);
}

fn tracking_sample_distance(tr: ptr<function, Tracker>, dda: Dda, t_max: f32, beta: vec3<f32>) {
    (*tr).w = vec3<f32>(1.0);
    (*tr).beta = beta;
    (*tr).distance = true;
    (*tr).sum_control = false;
    (*tr).event = EVENT_ESCAPE;
    (*tr).t_event = 0.0;
    sample_free_flight(tr, dda, t_max);
}

@group(0) @binding(5) var<uniform> emission: GpuEmissionParams;

@group(0) @binding(6) var<uniform> blackbody_table: array<vec4<f32>, BLACKBODY_TABLE_LEN>;

fn blackbody_rgb(t: f32) -> vec3<f32> {
    let x = max((clamp(t, BLACKBODY_T_MIN, BLACKBODY_T_MAX) - BLACKBODY_T_MIN) / BLACKBODY_STEP, 0.0);
    let i = min(u32(x), BLACKBODY_TABLE_LEN - 2u);
    let f = x - f32(i);
    let a = blackbody_table[i].xyz;
    let b = blackbody_table[i + 1u].xyz;
    return a + (b - a) * f;
}

fn blackbody_emission(t_kelvin: f32, intensity: f32) -> vec3<f32> {
    let t = max(t_kelvin, 0.0);
    let t2 = t * t;
    let scale = STEFAN_BOLTZMANN_SCALE * (1.0 - intensity)
        + ((STEFAN_BOLTZMANN_SCALE * intensity) * t2) * t2;
    return blackbody_rgb(t) * scale;
}

fn emission_radiance(tr: ptr<function, Tracker>, p: vec3<f32>) -> vec3<f32> {
    return emission_radiance_of(tr, emission, p);
}

fn emission_radiance_of(tr: ptr<function, Tracker>, emission: GpuEmissionParams, p: vec3<f32>) -> vec3<f32> {
    var e = vec3<f32>(0.0);
    if (any(emission.strength_color != vec3<f32>(0.0))) {
        var scale = 1.0;
        if (emission.has_grid != 0u) {
            (*tr).emission_lookups += 1u;
            scale = grid_sample_trilinear_in(emission.grid, grid_index_point(emission.grid, p));
        }
        e += emission.strength_color * scale;
    }
    if (emission.has_blackbody != 0u) {
        (*tr).emission_lookups += 1u;
        let g = emission.temperature;
        let t = emission.temperature_scale * grid_sample_trilinear_in(g, grid_index_point(g, p))
            + emission.temperature_offset;
        e += emission.tint * blackbody_emission(t, emission.intensity);
    }
    return e;
}

fn on_collision(tr: ptr<function, Tracker>, t: f32, sigma_maj: f32) {
    let p = (*tr).ow + t * (*tr).dw;
    var le = vec3<f32>(0.0);
    le = mix_emission(tr, p);
    if ((*tr).params.estimator == ESTIMATOR_SPECTRAL) {
        (*tr).emitted += (*tr).beta * (*tr).w * le / sigma_maj;
    } else {
        (*tr).emitted += (*tr).beta * ((*tr).w.x / sigma_maj) * le;
    }
}

@group(1) @binding(0) var<uniform> wf: GpuWavefrontParams;

@group(1) @binding(1) var<storage, read_write> paths: array<GpuPathState>;

@group(1) @binding(2) var<storage, read_write> queues: array<u32>;

@group(1) @binding(3) var<storage, read_write> counters: GpuWavefrontCounters;

fn queue_medium_in() -> u32 { return QUEUE_MEDIUM0 + wf.parity; }

fn queue_done_out() -> u32 { return QUEUE_DONE0 + 1u - wf.parity; }

fn queue_item(q: u32, i: u32, slot: ptr<function, u32>) -> bool {
    if (i >= atomicLoad(&counters.queue_count[q])) {
        return false;
    }
    *slot = queues[q * wf.path_count + i];
    return true;
}

fn queue_push(q: u32, slot: u32) {
    let i = atomicAdd(&counters.queue_count[q], 1u);
    queues[q * wf.path_count + i] = slot;
}

fn add_wide(k: u32, x: u32) {
    if (x == 0u) {
        return;
    }
    let old = atomicAdd(&counters.wide[2u * k], x);
    if (old + x < old) {
        atomicAdd(&counters.wide[2u * k + 1u], 1u);
    }
}

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

fn path_rng(ps: GpuPathState) -> Rng {
    return Rng(ps.rng_state, ps.rng_inc, vec2<u32>(0u), 0u);
}

fn path_pixel(sample_id: u32) -> u32 {
    return wf.pixel0 + sample_id / wf.spp_batch;
}

fn path_sample_index(sample_id: u32) -> u32 {
    return wf.s0 + sample_id % wf.spp_batch;
}

fn sampler_queue_on_stream(sample_id: u32, block: u32, rng: ptr<function, Rng>) {
    if (SAMPLER_SOBOL) {
        let p = sobol_point_u32(path_pixel(sample_id), path_sample_index(sample_id), block, wf.seed);
        rng_queue_uniforms(rng, p.x, p.y);
    }
}

@group(1) @binding(14) var<storage, read> textures: array<GpuTexture>;

@group(1) @binding(15) var<storage, read> texels: array<vec4<f32>>;

fn rem_euclid_i32(i: i32, n: i32) -> i32 {
    let r = i % n;
    return select(r, r + n, r < 0);
}

fn wrap_index(i: i32, n: i32, wrap: u32) -> i32 {
    if (wrap == TEXTURE_WRAP_CLAMP) {
        return clamp(i, 0, n - 1);
    }
    if (wrap == TEXTURE_WRAP_MIRROR) {
        let m = rem_euclid_i32(i, 2 * n);
        return select(m, 2 * n - 1 - m, m >= n);
    }
    return rem_euclid_i32(i, n);
}

fn floor_index(x: f32) -> i32 {
    return i32(clamp(floor(x), -1.0e9, 1.0e9));
}

fn texel(t: GpuTexture, i: i32, j: i32) -> vec4<f32> {
    let w = i32(t.width);
    let x = wrap_index(i, w, t.wrap_s);
    let y = wrap_index(j, i32(t.height), t.wrap_t);
    return texels[t.offset + u32(y * w + x)];
}

fn texture_sample(t: GpuTexture, uv: vec2<f32>) -> vec4<f32> {
    let st = vec2<f32>(
        t.row0.x * uv.x + t.row0.y * uv.y + t.row0.z,
        t.row1.x * uv.x + t.row1.y * uv.y + t.row1.z,
    );
    let w = f32(t.width);
    let h = f32(t.height);
    if (t.nearest != 0u) {
        return texel(t, floor_index(st.x * w), floor_index(st.y * h));
    }
    let x = st.x * w - 0.5;
    let y = st.y * h - 0.5;
    let fx = x - floor(x);
    let fy = y - floor(y);
    let i = floor_index(x);
    let j = floor_index(y);
    let top = texel(t, i, j) * (1.0 - fx) + texel(t, i + 1, j) * fx;
    let bottom = texel(t, i, j + 1) * (1.0 - fx) + texel(t, i + 1, j + 1) * fx;
    return top * (1.0 - fy) + bottom * fy;
}

fn texture_rgb(k: u32, uv: vec2<f32>) -> vec3<f32> {
    var c = vec3<f32>(1.0);
    if (k != NO_INDEX) {
        c = texture_sample(textures[k], uv).xyz;
    }
    return c;
}

fn emission_at(m: Material, uv: vec2<f32>) -> vec3<f32> {
    return m.emission * texture_rgb(m.emissive_texture, uv);
}

fn emitted(m: Material, uv: vec2<f32>, cos_l: f32) -> vec3<f32> {
    let double_sided = (m.flags & MATERIAL_DOUBLE_SIDED) != 0u;
    if (cos_l > 0.0 || (double_sided && cos_l < 0.0)) {
        return emission_at(m, uv);
    }
    return vec3<f32>(0.0);
}

@group(1) @binding(12) var<storage, read> homogeneous: array<GpuHomogeneousMedium>;

struct MediumEvent {
    event: u32,
    t: f32,
    weight: vec3<f32>,
}

fn sample_homogeneous(h: GpuHomogeneousMedium, t_max: f32, absorption_weight: bool, rng: ptr<function, Rng>) -> MediumEvent {
    let sigma_t = h.sigma_a + h.sigma_s;
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

fn exp_neg(sigma_t: vec3<f32>, d: f32) -> vec3<f32> {
    return select(exp(-sigma_t * d), vec3<f32>(1.0), sigma_t == vec3<f32>(0.0));
}

@group(1) @binding(18) var<storage, read> vdb_media: array<GpuVdbMedium>;

struct MixStream {
    dda: Dda,
    cur: GpuMajorantSegment,
    has: bool,
    medium: u32,
    o: vec3<f32>,
    d: vec3<f32>,
}

struct MixState {
    n: u32,
    n_vdb: u32,
    t: f32,
    alpha_min: f32,
    alpha_max: f32,
    hom_sigma_a: vec3<f32>,
    hom_sigma_s: vec3<f32>,
}

var<private> mix_streams: array<MixStream, 9>;

var<private> mix_state: MixState;

struct Spans {
    n: u32,
    k: array<u32, 8>,
    a: array<f32, 8>,
    b: array<f32, 8>,
}

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

fn spans_overlap(s: Spans) -> bool {
    for (var i = 1u; i < s.n; i++) {
        if (s.a[i] < s.b[i - 1u]) {
            return true;
        }
    }
    return false;
}

fn grid_index_vector(g: GpuGridInfo, v: vec3<f32>) -> vec3<f32> {
    let m = g.index_from_world;
    return vec3<f32>(dot(m[0].xyz, v), dot(m[1].xyz, v), dot(m[2].xyz, v));
}

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

fn vdb_dda(k: u32, tr: Tracker, t0: f32, t1: f32) -> Dda {
    let g = vdb_media[k].grid;
    return dda_new_in(g, vdb_media[k].bounds_base, tr.o, tr.d, t0, t1,
                      g.density_scale * tr.params.majorant_channel_scale, tr.params.majorant_mode);
}

struct Flight {
    event: u32,
    t: f32,
    weight: vec3<f32>,
    g: f32,
}

fn finish_tracker(tr: Tracker, ps: ptr<function, GpuPathState>, rng: ptr<function, Rng>) {
    *rng = tr.rng;
    add_tracking_stats(tr.stats, false, ps);
    (*ps).l += tr.emitted;
    (*ps).lookups += tr.emission_lookups;
    add_wide(WIDE_EMISSION_LOOKUPS, tr.emission_lookups);
}

fn vdb_flight(k: u32, ps: ptr<function, GpuPathState>, rng: ptr<function, Rng>, a: f32, b: f32,
              beta: vec3<f32>) -> Flight {
    var tr = vdb_tracker(k, (*ps).o, (*ps).d, *rng, vdb_media[k].tracking.estimator);
    let dda = vdb_dda(k, tr, a, b);
    tracking_sample_distance(&tr, dda, b, beta);
    finish_tracker(tr, ps, rng);
    var f = Flight(tr.event, tr.t_event, vec3<f32>(tr.w.x), vdb_media[k].phase_g);
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

fn mix_density(i: u32, t: f32) -> f32 {
    let g = vdb_media[mix_streams[i].medium].grid;
    return grid_sample_trilinear_in(g, mix_streams[i].o + t * mix_streams[i].d);
}

fn mix_coeffs(tr: ptr<function, Tracker>, t: f32) -> Coeffs {
    var k = Coeffs(mix_state.hom_sigma_a.x, mix_state.hom_sigma_s.x);
    for (var i = 0u; i < mix_state.n_vdb; i++) {
        let m = mix_streams[i].medium;
        let dens = mix_density(i, t);
        k.sigma_a += vdb_media[m].grey_sigma_a * dens;
        k.sigma_s += vdb_media[m].grey_sigma_s * dens;
    }
    (*tr).stats.lookups += mix_state.n_vdb;
    return k;
}

fn mix_coeffs_rgb(tr: ptr<function, Tracker>, t: f32) -> CoeffsRgb {
    var k = CoeffsRgb(mix_state.hom_sigma_a, mix_state.hom_sigma_s);
    for (var i = 0u; i < mix_state.n_vdb; i++) {
        let m = mix_streams[i].medium;
        let dens = mix_density(i, t);
        k.sigma_a += vdb_media[m].rgb_sigma_a * dens;
        k.sigma_s += vdb_media[m].rgb_sigma_s * dens;
    }
    (*tr).stats.lookups += mix_state.n_vdb;
    return k;
}

fn mix_control(sigma_c: f32) -> Coeffs {
    return Coeffs((1.0 - mix_state.alpha_max) * sigma_c, mix_state.alpha_min * sigma_c);
}

fn mix_emission(tr: ptr<function, Tracker>, p: vec3<f32>) -> vec3<f32> {
    if ((*tr).mix == MIX_ALL) {
        var le = vec3<f32>(0.0);
        for (var i = 0u; i < mix_state.n_vdb; i++) {
            le += emission_radiance_of(tr, vdb_media[mix_streams[i].medium].emission, p);
        }
        return le;
    }
    if ((*tr).mix == 0u) {
        return emission_radiance(tr, p);
    }
    return emission_radiance_of(tr, vdb_media[(*tr).mix - 1u].emission, p);
}

fn mix_advance(i: u32) {
    if (i >= mix_state.n_vdb) {
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

fn mix_next(seg: ptr<function, GpuMajorantSegment>) -> bool {
    let t = mix_state.t;
    let inf = f32_inf();
    var start = inf;
    for (var i = 0u; i < mix_state.n; i++) {
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
    return Pick(last, w[last] / total);
}

fn mix_flight(spans: Spans, hom: u32, ps: ptr<function, GpuPathState>, rng: ptr<function, Rng>,
              t0: f32, t1: f32) -> Flight {
    let o = (*ps).o;
    let d = (*ps).d;
    let weight_abs = wf.absorption_weight != 0u;
    let abs = (wf.flags & WF_FLAG_ABSORPTION) != 0u && !weight_abs;
    var spectral = false;
    var h: GpuHomogeneousMedium;
    let has_hom = hom != NO_INDEX;
    if (has_hom) {
        h = homogeneous[hom];
    }
    if (FEATURE_CHROMATIC) {
        let st = h.sigma_a + h.sigma_s;
        spectral = (wf.flags & WF_FLAG_FORCE_SPECTRAL) != 0u
            || (has_hom && !(st.x == st.y && st.y == st.z));
        for (var i = 0u; i < spans.n; i++) {
            spectral = spectral || vdb_media[spans.k[i]].spectral != 0u;
        }
    }
    mix_state.n_vdb = spans.n;
    mix_state.n = spans.n;
    mix_state.t = -f32_inf();
    mix_state.alpha_min = 1.0;
    mix_state.alpha_max = 0.0;
    mix_state.hom_sigma_a = vec3<f32>(0.0);
    mix_state.hom_sigma_s = vec3<f32>(0.0);
    let mode = wf.tracking.majorant_mode;
    for (var i = 0u; i < spans.n; i++) {
        let k = spans.k[i];
        let g = vdb_media[k].grid;
        mix_streams[i].medium = k;
        mix_streams[i].o = grid_index_point(g, o);
        mix_streams[i].d = grid_index_vector(g, d);
        mix_streams[i].dda = dda_new_in(g, vdb_media[k].bounds_base, mix_streams[i].o,
                                        mix_streams[i].d, spans.a[i], spans.b[i],
                                        g.density_scale, mode);
        mix_advance(i);
        mix_state.alpha_min = min(mix_state.alpha_min, vdb_media[k].control_albedo);
        mix_state.alpha_max = max(mix_state.alpha_max, vdb_media[k].control_albedo);
    }
    var hom_albedo = vec3<f32>(0.0);
    if (has_hom) {
        var seg = GpuMajorantSegment(t0, t1, 0.0, 0.0);
        if (spectral) {
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
    }
    var tr: Tracker;
    tr.params = vdb_media[spans.k[0]].tracking;
    tr.params.estimator = wf.mix_estimator;
    if (spectral) {
        tr.params.estimator = ESTIMATOR_SPECTRAL;
    }
    tr.rng = *rng;
    tr.ow = o;
    tr.dw = d;
    tr.w = vec3<f32>(1.0);
    tr.mix = MIX_ALL;
    var no_walk: Dda;
    no_walk.done = true;
    tracking_sample_distance(&tr, no_walk, t1, (*ps).beta);
    var f = Flight(tr.event, tr.t_event, vec3<f32>(tr.w.x), 0.0);
    if (spectral) {
        f.weight = tr.w;
    }
    if (tr.event == EVENT_SCATTER) {
        let t = tr.t_event;
        var w: array<f32, 9>;
        var s_true: array<vec3<f32>, 9>;
        var s_view = vec3<f32>(0.0);
        for (var i = 0u; i < mix_state.n_vdb; i++) {
            let m = mix_streams[i].medium;
            let dens = mix_density(i, t);
            if (spectral) {
                s_true[i] = vdb_media[m].sigma_s * dens;
                s_view += vdb_media[m].rgb_sigma_s * dens;
                w[i] = s_true[i].x + s_true[i].y + s_true[i].z;
            } else {
                w[i] = vdb_media[m].grey_sigma_s * dens;
            }
        }
        tr.stats.lookups += mix_state.n_vdb;
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
        let pk = mix_pick(w, n, tracker_uniform(&tr));
        if (pk.k >= n) {
            f.event = EVENT_ABSORB;
        } else {
            let hom_k = pk.k >= mix_state.n_vdb;
            if (hom_k) {
                f.g = h.g;
            } else {
                f.g = vdb_media[mix_streams[pk.k].medium].phase_g;
            }
            if (spectral) {
                let den = s_view * pk.p;
                f.weight = tr.w * select(vec3<f32>(0.0), s_true[pk.k] / den, den > vec3<f32>(0.0));
            } else if (hom_k) {
                f.weight = hom_albedo * tr.w.x;
            } else {
                f.weight = vdb_media[mix_streams[pk.k].medium].scatter_albedo * tr.w.x;
            }
        }
    }
    finish_tracker(tr, ps, rng);
    return f;
}

fn sample_media_mix(ps: ptr<function, GpuPathState>, rng0: Rng, t_hit: f32) -> Flight {
    var rng = rng0;
    let t0 = (*ps).t0;
    let spans = vdb_spans((*ps).o, (*ps).d, t0, t_hit);
    var hom = NO_INDEX;
    hom = (*ps).medium;
    var f = Flight(EVENT_ESCAPE, 0.0, vec3<f32>(1.0), 0.0);
    if ((hom != NO_INDEX && spans.n > 0u) || spans_overlap(spans)) {
        f = mix_flight(spans, hom, ps, &rng, t0, t_hit);
    } else if (hom != NO_INDEX) {
        let h = homogeneous[hom];
        let ev = sample_homogeneous(h, t_hit - t0, wf.absorption_weight != 0u, &rng);
        f = Flight(ev.event, t0 + ev.t, ev.weight, h.g);
    } else {
        var weight = vec3<f32>(1.0);
        for (var i = 0u; i < spans.n; i++) {
            let fi = vdb_flight(spans.k[i], ps, &rng, spans.a[i], spans.b[i], (*ps).beta * weight);
            if (fi.event == EVENT_ESCAPE) {
                weight *= fi.weight;
                continue;
            }
            f = fi;
            f.weight = weight * fi.weight;
            break;
        }
        if (f.event == EVENT_ESCAPE) {
            f.weight = weight;
        }
    }
    (*ps).rng_state = rng.state;
    (*ps).rng_inc = rng.inc;
    return f;
}

@group(1) @binding(16) var<uniform> env_map: GpuEnvMap;

@group(1) @binding(17) var<storage, read> env_data: array<f32>;

fn env_lookup_dir(w: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(env_map.row0.xyz, w), dot(env_map.row1.xyz, w), dot(env_map.row2.xyz, w));
}

fn env_direction_to_uv(d: vec3<f32>) -> vec2<f32> {
    var u = 0.5 - atan2(d.y, d.x) * (0.5 / PI);
    if (u >= 1.0) {
        u -= 1.0;
    }
    let v = acos(clamp(d.z, -1.0, 1.0)) / PI;
    return vec2<f32>(u, v);
}

fn env_pdf_uv(uv: vec2<f32>) -> f32 {
    let nu = env_map.width;
    let c = min(u32(uv.x * f32(nu)), nu - 1u);
    let v = min(u32(uv.y * f32(env_map.height)), env_map.height - 1u);
    return env_data[env_map.func_offset + v * nu + c] / env_map.integral;
}

fn env_pdf(w: vec3<f32>) -> f32 {
    if (env_map.uniform != 0u) {
        return INV_4PI;
    }
    let d = env_lookup_dir(w);
    let sin_theta = sqrt(max(1.0 - d.z * d.z, 0.0));
    if (!(sin_theta > 0.0)) {
        return 0.0;
    }
    return env_pdf_uv(env_direction_to_uv(d)) / (2.0 * PI * PI * sin_theta);
}

fn light_count() -> u32 {
    return wf.light_count + wf.has_env + select(0u, 1u, wf.area_count > 0u);
}

@compute @workgroup_size(64)
fn sample_medium(@builtin(global_invocation_id) id: vec3<u32>) {
    var slot = 0u;
    if (!queue_item(queue_medium_in(), id.x, &slot)) {
        return;
    }
    var ps = paths[slot];
    let hit = FEATURE_SURFACES && ps.hit_prim != NO_INDEX;
    var t_hit = f32_inf();
    if (hit) {
        t_hit = ps.hit_t;
    }
    var event = EVENT_ESCAPE;
    var t_event = 0.0;
    var weight = vec3<f32>(1.0);
    var in_homogeneous = false;
    var rng0 = path_rng(ps);
    if ((ps.flags & PATH_FLAG_FLIGHT_STARTED) == 0u) {
        sampler_queue_on_stream(ps.sample_id, bounce_dim(ps.depth, DIM_DISTANCE), &rng0);
        ps.flags |= PATH_FLAG_FLIGHT_STARTED;
    }
    let f = sample_media_mix(&ps, rng0, t_hit);
    event = f.event;
    t_event = f.t;
    weight = f.weight;
    ps.phase_g = f.g;
    if (ps.collisions > wf.max_collisions) {
        atomicAdd(&counters.guard_fired, 1u);
        paths[slot] = ps;
        queue_push(queue_done_out(), slot);
        return;
    }
    switch event {
        case EVENT_SCATTER: {
            ps.beta *= weight;
            ps.o = ps.o + t_event * ps.d;
            paths[slot] = ps;
            queue_push(QUEUE_SCATTER, slot);
        }
        case EVENT_ABSORB: {
            paths[slot] = ps;
            queue_push(queue_done_out(), slot);
        }
        default: {
            ps.beta *= weight;
            paths[slot] = ps;
            if (hit) {
                queue_push(QUEUE_SURFACE, slot);
            } else {
                queue_push(QUEUE_ESCAPE, slot);
            }
        }
    }
}
