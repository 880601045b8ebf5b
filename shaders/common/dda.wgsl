// Mirrors DdaMajorantIterator (src/volume/dda.rs: `new`, `global`, `walk`, `crossing`, `next`)
// and Aabb::intersect (src/math/mod.rs). Needs grid.wgsl (grid_info) and types.wgsl.
//
// The same robust walk as the CPU (Amanatides & Woo 1987, as pbrt-v4's DDAMajorantIterator, with
// plane crossings recomputed from each plane's position and segment ends clamped to be
// non-decreasing), with the same IEEE special cases: `1 / d` is +-infinity on an axis-parallel
// ray, `-0.0` never steps, NaN comparisons fail. The segments therefore equal the CPU's as long
// as the device divides and adds with IEEE rounding; an FMA contraction of the entry point
// `o + t d` may move it by an ulp (tests/gpu_dda.rs measures it).

// Per-cell bounds (LeafBounds::cells, x fastest) followed by the global bound at
// grid_info.global_bounds_index.
@group(0) @binding(4) var<storage, read> grid_bounds: array<CellBounds>;

// Edge of one bounds cell in index units.
const CELL_WIDTH: f32 = 8.0;

// +infinity. WGSL has no literal for it; naga refuses infinite constants, so it is built at run
// time from its bits.
fn f32_inf() -> f32 {
    var bits = 0x7f800000u;
    return bitcast<f32>(bits);
}

struct Dda {
    dims: vec3<i32>,          // cells per axis (1 for the global walk)
    lo: vec3<f32>,            // index-space minimum corner of the cell box
    width: vec3<f32>,         // cell edge per axis
    o: vec3<f32>,             // ray origin
    d: vec3<f32>,             // ray direction
    scale: f32,               // sigma = scale * bound
    global: bool,             // read the global bound instead of the cell's
    cell: vec3<i32>,
    step: vec3<i32>,          // -1, 0 or +1 per axis
    next_crossing: vec3<f32>, // ray parameter of the next plane crossing per axis
    t: f32,                   // start of the next segment
    t_exit: f32,
    done: bool,
}

// Aabb::intersect: the parameter interval of the ray inside [lo, hi], clipped to [t0, t1].
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
        // `x > NaN` is false: a NaN bound never shrinks the interval.
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

// DdaMajorantIterator::crossing.
fn dda_crossing(it: ptr<function, Dda>, axis: i32) -> f32 {
    let s = (*it).step[axis];
    if (s == 0) {
        return f32_inf();
    }
    let plane_cell = select((*it).cell[axis], (*it).cell[axis] + 1, s == 1);
    let plane = (*it).lo[axis] + f32(plane_cell) * (*it).width[axis];
    return (plane - (*it).o[axis]) / (*it).d[axis];
}

// DdaMajorantIterator::new (global = false) and ::global (global = true), through `walk`.
fn dda_new(o: vec3<f32>, d: vec3<f32>, t0: f32, t1: f32, scale: f32, global: bool) -> Dda {
    var it: Dda;
    it.o = o;
    it.d = d;
    it.scale = scale;
    it.global = global;
    it.lo = vec3<f32>(grid_info.cell_origin) * CELL_WIDTH;
    let grid_dims = vec3<i32>(grid_info.dims);
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
    // Written positively so NaN parameters are rejected too.
    if (!(te.x < te.y)) {
        return it;
    }
    let p = o + te.x * d;
    for (var a = 0; a < 3; a++) {
        // On an axis the ray does not move along, t_enter may be infinite: use the origin.
        let x = select(p[a], o[a], d[a] == 0.0);
        let g = floor((x - it.lo[a]) / it.width[a]);
        // Clamp into the box (rounding can put the entry a hair outside); NaN -> 0.
        it.cell[a] = select(clamp(i32(g), 0, it.dims[a] - 1), 0, g != g);
        // -0.0 compares equal to 0.0: no step, as for +0.0.
        it.step[a] = select(select(0, -1, d[a] < 0.0), 1, d[a] > 0.0);
        it.next_crossing[a] = dda_crossing(&it, a);
    }
    it.t = te.x;
    it.t_exit = te.y;
    it.done = false;
    return it;
}

// DdaMajorantIterator::cell_bounds.
fn dda_cell_bounds(it: ptr<function, Dda>) -> CellBounds {
    if ((*it).global) {
        return grid_bounds[grid_info.global_bounds_index];
    }
    let c = vec3<u32>((*it).cell);
    let n = vec3<u32>((*it).dims);
    return grid_bounds[c.x + n.x * (c.y + n.y * c.z)];
}

// DdaMajorantIterator::next: writes the next segment and returns true, or returns false when
// the walk is over.
fn dda_next(it: ptr<function, Dda>, seg: ptr<function, GpuMajorantSegment>) -> bool {
    while (!(*it).done) {
        // The axis whose cell boundary the ray meets first.
        let c = (*it).next_crossing;
        var axis = 2;
        if (c[0] <= c[1] && c[0] <= c[2]) {
            axis = 0;
        } else if (c[1] <= c[2]) {
            axis = 1;
        }
        let next_cell = (*it).cell[axis] + (*it).step[axis];
        // The last segment always ends exactly at the box exit.
        let leaving = (*it).next_crossing[axis] >= (*it).t_exit || next_cell < 0
            || next_cell >= (*it).dims[axis];
        let t_min = (*it).t;
        // Never move backwards; keep t_min's own bits when the crossing merely equals it.
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
        // Crossing an edge or corner visits cells for zero length; they carry nothing.
        if (t_max > t_min) {
            *seg = GpuMajorantSegment(t_min, t_max, (*it).scale * b.max, (*it).scale * b.min);
            return true;
        }
    }
    return false;
}
