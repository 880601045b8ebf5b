// Mirrors DdaMajorantIterator (src/volume/dda/mod.rs: `new`, `global`, `walk`, `next`,
// `reciprocal_and_step`), LeafCulling and VoxelCulling (src/volume/cull.rs: `new`, `ratio`),
// AdaptiveMajorantIterator (src/volume/adaptive/walk.rs: `new`, `crossing`, `next`) and
// Aabb::intersect (src/math/mod.rs). Needs grid.wgsl (grid_info) and types.wgsl.
//
// The same robust walk as the CPU (Amanatides & Woo 1987, as pbrt-v4's DDAMajorantIterator, with
// plane crossings recomputed from each plane's position and segment ends clamped to be
// non-decreasing, crossings as `(plane - o) * (1 / d)`), with the same special cases: an axis
// steps only where `1 / d` is finite (so `-0.0` and subnormal components never step), NaN
// comparisons fail. The CPU steps incrementally (flat cell index, planes moved by a cell width,
// level-0 regions of the adaptive walk as DDA steps); the planes are exact integers, so
// recomputing them here gives the same values. The segments therefore equal the CPU's as long
// as the device divides and adds with IEEE rounding; an FMA contraction of the entry point
// `o + t d` may move it by an ulp (tests/gpu/dda.rs measures it).

// Per-cell bounds (LeafBounds::cells, x fastest) followed by the global bound at
// grid_info.global_bounds_index and the walk box (LeafBounds::gpu_walk_box: per axis the
// index-space min and max); for adaptive walks then the hierarchy's table, nodes and packed
// levels (AdaptiveMajorants::gpu_bounds).
@group(0) @binding(4) var<storage, read> grid_bounds: array<CellBounds>;

// LeafBounds::voxel_q of the density grids whose walks thin by them, four bytes to a word
// (GpuGrid::voxels, pack_voxel_q), indexed by the shared bricks buffer's brick index (a grid's
// table at its bricks' place); one zero word where there is none.
@group(0) @binding(7) var<storage, read> grid_voxels: array<u32>;

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
    inv_d: vec3<f32>,         // 1 / d (dda_reciprocal)
    scale: f32,               // sigma = scale * bound
    global: bool,             // read the global bound instead of the cell's
    cull: bool,               // the culled global walk: cull collisions by the leaf cells
    cell_dims: vec3<i32>,     // the grid's cells per axis (for culling)
    voxel: bool,              // thin kept collisions by the per-voxel bounds (VoxelCulling)
    adaptive: bool,           // walk the adaptive hierarchy (cell is then a leaf cell)
    cell: vec3<i32>,
    step: vec3<i32>,          // -1, 0 or +1 per axis
    next_crossing: vec3<f32>, // ray parameter of the next plane crossing per axis
    t: f32,                   // start of the next segment
    t_exit: f32,
    done: bool,
    bounds_base: u32,         // first entry of the grid's bounds in grid_bounds
    cell_offset: u32,         // first entry of the grid's cells in grid_cells
    global_index: u32,        // its global bound, relative to bounds_base
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

// dda::reciprocal_and_step: the step is 0 unless 1 / d is finite (d = +-0, subnormal or NaN
// never steps).
fn dda_step(d: f32, inv: f32) -> i32 {
    if (!(abs(inv) <= 3.40282347e38)) {
        return 0;
    }
    return select(-1, 1, d > 0.0);
}

// DdaMajorantIterator: the crossing of the plane ahead along `axis`, (plane - o) * (1 / d). The
// CPU moves the plane by one cell width per step; planes are exact integers, so computing it
// from the cell gives the same value.
fn dda_crossing(it: ptr<function, Dda>, axis: i32) -> f32 {
    let s = (*it).step[axis];
    if (s == 0) {
        return f32_inf();
    }
    let plane_cell = select((*it).cell[axis], (*it).cell[axis] + 1, s == 1);
    let plane = (*it).lo[axis] + f32(plane_cell) * (*it).width[axis];
    return (plane - (*it).o[axis]) * (*it).inv_d[axis];
}

// DdaMajorantIterator::new (MAJORANT_PER_CELL) and ::global (MAJORANT_GLOBAL, and
// MAJORANT_CULLED with its LeafCulling), through `walk`, and AdaptiveMajorantIterator::new
// (MAJORANT_ADAPTIVE: the per-cell entry), for the density grid of the `grid_info` uniform.
// The grid's per-voxel bounds are bound where the table covers its bricks (the host binds
// one only where its walks thin by it).
fn dda_new(o: vec3<f32>, d: vec3<f32>, t0: f32, t1: f32, scale: f32, mode: u32) -> Dda {
    let table = arrayLength(&grid_voxels) * 4u >= grid_info.brick_count * 512u;
    return dda_new_in(grid_info, 0u, table, o, d, t0, t1, scale, mode);
}

// dda_new for grid `g` whose bounds start at `bounds_base` in grid_bounds (one of several
// media sharing the buffers: mixture.wgsl), `voxel_table` where grid_voxels holds its
// per-voxel bounds at its bricks' place.
fn dda_new_in(g: GpuGridInfo, bounds_base: u32, voxel_table: bool, o: vec3<f32>, d: vec3<f32>,
              t0: f32, t1: f32, scale: f32, mode: u32) -> Dda {
    var it: Dda;
    it.bounds_base = bounds_base;
    it.cell_offset = g.cell_offset;
    it.global_index = g.global_bounds_index;
    let global = mode == MAJORANT_GLOBAL || mode == MAJORANT_CULLED;
    it.o = o;
    it.d = d;
    it.inv_d = vec3<f32>(1.0) / d;
    it.scale = scale;
    it.global = global;
    it.adaptive = mode == MAJORANT_ADAPTIVE;
    it.lo = vec3<f32>(g.cell_origin) * CELL_WIDTH;
    let grid_dims = vec3<i32>(g.dims);
    let empty = any(grid_dims <= vec3<i32>(0));
    it.cell_dims = grid_dims;
    // LeafCulling::new: only where the global minimum is exactly 0 (the segment's control
    // then vanishes) and the global maximum positive and finite.
    it.cull = false;
    if (mode == MAJORANT_CULLED && !empty) {
        let gb = grid_bounds[bounds_base + g.global_bounds_index];
        it.cull = gb.min == 0.0 && gb.max > 0.0 && gb.max <= 3.40282347e38;
    }
    // VdbMedium::voxel_culling: the per-leaf DDA and the culled global walk, where the
    // global minimum is 0 and the maximum positive and finite (VoxelCulling::new), for a
    // grid whose table is bound.
    it.voxel = false;
    if ((mode == MAJORANT_PER_CELL || mode == MAJORANT_CULLED) && !empty && voxel_table
        && g.brick_count > 0u && scale > 0.0 && scale <= 3.40282347e38) {
        let gb = grid_bounds[bounds_base + g.global_bounds_index];
        it.voxel = gb.min == 0.0 && gb.max > 0.0 && gb.max <= 3.40282347e38;
    }
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
    // dda::enter_box: the cell box clipped to the walk box, outside which every value is 0.
    let wx = grid_bounds[bounds_base + g.global_bounds_index + 1u];
    let wy = grid_bounds[bounds_base + g.global_bounds_index + 2u];
    let wz = grid_bounds[bounds_base + g.global_bounds_index + 3u];
    let clip_lo = max(it.lo, vec3<f32>(wx.min, wy.min, wz.min));
    let clip_hi = min(hi, vec3<f32>(wx.max, wy.max, wz.max));
    var te = vec2<f32>(0.0);
    if (!aabb_intersect(clip_lo, clip_hi, o, d, t0, t1, &te)) {
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
        it.step[a] = dda_step(d[a], it.inv_d[a]);
        it.next_crossing[a] = dda_crossing(&it, a);
    }
    it.t = te.x;
    it.t_exit = te.y;
    it.done = false;
    return it;
}

// LeafCulling::ratio: max(leaf cell containing the point at t) / global max, in [0, 1]; 1
// exactly where the cell holds the global maximum. The cell as dda::enter_box finds it:
// truncation equals floor after the clamp, NaN -> 0.
fn dda_cull_ratio(it: ptr<function, Dda>, t: f32) -> f32 {
    let p = (*it).o + t * (*it).d;
    var c = vec3<u32>(0u);
    for (var a = 0; a < 3; a++) {
        let g = floor((p[a] - (*it).lo[a]) * (1.0 / CELL_WIDTH));
        c[a] = u32(select(clamp(i32(g), 0, (*it).cell_dims[a] - 1), 0, g != g));
    }
    let n = vec3<u32>((*it).cell_dims);
    let base = (*it).bounds_base;
    let m = grid_bounds[base + c.x + n.x * (c.y + n.y * c.z)].max;
    let gm = grid_bounds[base + (*it).global_index].max;
    if (m >= gm) {
        return 1.0;
    }
    return m / gm;
}

// VoxelCulling::ratio and bound_at: the per-voxel bound at the point at t over `bound`, the
// raw majorant the collision was kept with, in [0, 1]; 1 outside the cell box and in
// constant cells.
fn dda_voxel_ratio(it: ptr<function, Dda>, t: f32, bound: f32) -> f32 {
    let p = (*it).o + t * (*it).d;
    let n = (*it).cell_dims;
    var index = 0u;
    var local = 0u;
    var stride = 1u;
    for (var a = 0; a < 3; a++) {
        // Inside the cell box (NaN fails), whose faces are integers: floor(p) and its cell
        // then lie in it too.
        let lo = (*it).lo[a];
        if (!(p[a] >= lo && p[a] < lo + f32(n[a]) * CELL_WIDTH)) {
            return 1.0;
        }
        let v = i32(floor(p[a]));
        let c = (v >> 3u) - i32(lo / CELL_WIDTH);
        index += u32(c) * stride;
        local += u32(v & 7) << (3u * u32(a));
        stride *= u32(n[a]);
    }
    let entry = grid_cells[(*it).cell_offset + index];
    if ((entry & CONSTANT_BIT) != 0u) {
        return 1.0;
    }
    let k = entry * 512u + local;
    let q = (grid_voxels[k >> 2u] >> (8u * (k & 3u))) & 0xffu;
    let cm = grid_bounds[(*it).bounds_base + index].max;
    let fine = ((f32(q) * (1.0 / 255.0)) * cm) * (*it).scale;
    if (fine < bound) {
        return fine / bound;
    }
    return 1.0;
}

// DdaMajorantIterator::cell_bounds.
fn dda_cell_bounds(it: ptr<function, Dda>) -> CellBounds {
    if ((*it).global) {
        return grid_bounds[(*it).bounds_base + (*it).global_index];
    }
    let c = vec3<u32>((*it).cell);
    let n = vec3<u32>((*it).dims);
    return grid_bounds[(*it).bounds_base + c.x + n.x * (c.y + n.y * c.z)];
}

// A slot of the adaptive hierarchy's table (AdaptiveMajorants::gpu_bounds): an exact integer
// stored as an f32 value, an index relative to the grid's first bounds entry; returned
// absolute.
fn adaptive_table(it: ptr<function, Dda>, slot: u32) -> u32 {
    let base = (*it).bounds_base;
    let b = grid_bounds[base + (*it).global_index + 4u + slot / 2u];
    return base + u32(select(b.min, b.max, (slot & 1u) == 1u));
}

// AdaptiveMajorants::level_of: the level of the merged node holding leaf cell c (4 levels
// per f32 value, 2 values per CellBounds). The walk's dims are the grid's (adaptive walks
// are per cell).
fn adaptive_level(it: ptr<function, Dda>, c: vec3<i32>) -> u32 {
    let n = vec3<u32>((*it).dims);
    let i = u32(c.x) + n.x * (u32(c.y) + n.y * u32(c.z));
    let b = grid_bounds[adaptive_table(it, 14u) + i / 8u];
    let w = u32(select(b.min, b.max, ((i / 4u) & 1u) == 1u));
    return (w >> (4u * (i % 4u))) & 15u;
}

// AdaptiveMajorants::node: bounds of node `node` of level `l` (level dims are the leaf dims
// halved l times, rounded up).
fn adaptive_node(it: ptr<function, Dda>, l: u32, node: vec3<i32>) -> CellBounds {
    let dims = (vec3<u32>((*it).dims) + vec3<u32>((1u << l) - 1u)) >> vec3<u32>(l);
    let i = u32(node.x) + dims.x * (u32(node.y) + dims.y * u32(node.z));
    return grid_bounds[adaptive_table(it, l) + i];
}

// AdaptiveMajorantIterator::crossing.
fn adaptive_crossing(it: ptr<function, Dda>, axis: i32, node: i32, l: u32) -> f32 {
    let s = (*it).step[axis];
    if (s == 0) {
        return f32_inf();
    }
    let plane_node = select(node, node + 1, s == 1);
    let plane = (*it).lo[axis] + f32(plane_node << l) * CELL_WIDTH;
    return (plane - (*it).o[axis]) * (*it).inv_d[axis];
}

// AdaptiveMajorantIterator::next: one segment per merged node, then the leaf cell just across
// the exit plane (other axes: the exit point's cell, kept inside the node just left).
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

// DdaMajorantIterator::next: writes the next segment and returns true, or returns false when
// the walk is over.
fn dda_next(it: ptr<function, Dda>, seg: ptr<function, GpuMajorantSegment>) -> bool {
    if ((*it).adaptive) {
        return adaptive_next(it, seg);
    }
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
