// Mirrors the surface queries of the CPU integrator: TriangleBvh::closest_hit and
// intersect_triangle (src/accel/mod.rs) over obvhs' compressed wide BVH (CwBvh::ray_traverse,
// the `traverse!` macro and CwBvhNode::intersect_ray_basic of obvhs 0.4, after Ylitie et al.
// 2017, "Efficient incoherent ray traversal on GPUs through compressed wide BVHs"), and
// offset, shading_normal (src/integrator/path.rs), emitted and Lights::pdf_area
// (src/render/lights.rs). The nodes are obvhs' 80-byte CwBvhNode as built for the CPU;
// the triangles are uploaded in the BVH's primitive order (GpuTriangle), so a leaf's
// primitive slot indexes them directly. Where the GPU keeps instancing, the shapes' BVHs
// follow the top-level one in bvh_nodes, each searched in its placement's local space
// (InstancedBvh::closest_hit, placements.wgsl). Needs wavefront.wgsl (wf), tracking.wgsl
// (F32_MAX), placements.wgsl and textures.wgsl (emission_at).

@group(1) @binding(8) var<storage, read> bvh_nodes: array<CwBvhNode>;
@group(1) @binding(9) var<storage, read> bvh_triangles: array<GpuTriangle>;
@group(1) @binding(10) var<storage, read> materials: array<Material>;

// obvhs' node::EPSILON: the nearest a child box may start along the ray.
const BVH_EPSILON: f32 = 0.0001;
// obvhs' TRAVERSAL_STACK_SIZE (CwBvh::validate asserts the depth stays below it).
const BVH_STACK_SIZE: u32 = 32u;

// A closest hit: the GpuTriangle slot, the ray parameter and two barycentric weights.
struct Hit {
    prim: u32,   // NO_INDEX: no hit
    t: f32,
    b1: f32,
    b2: f32,
}

// intersect_triangle (Moller-Trumbore), the routine every CPU query uses: t in [t_min, t_max].
fn intersect_triangle(o: vec3<f32>, d: vec3<f32>, v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>,
                      t_min: f32, t_max: f32, out: ptr<function, vec3<f32>>) -> bool {
    let e1 = v1 - v0;
    let e2 = v2 - v0;
    let p = cross(d, e2);
    let det = dot(e1, p);
    if (det == 0.0 || !(abs(det) <= F32_MAX)) {
        return false;
    }
    let inv = 1.0 / det;
    let s = o - v0;
    let b1 = dot(s, p) * inv;
    if (!(b1 >= 0.0 && b1 <= 1.0)) {
        return false;
    }
    let q = cross(s, e1);
    let b2 = dot(d, q) * inv;
    if (b2 < 0.0 || b1 + b2 > 1.0) {
        return false;
    }
    let t = dot(e2, q) * inv;
    *out = vec3<f32>(t, b1, b2);
    return t >= t_min && t <= t_max;
}

// obvhs::ray::safe_inverse.
fn safe_inverse(x: f32) -> f32 {
    if (abs(x) <= 1.1920929e-7) {
        return sign(x) / 1.1920929e-7;
    }
    return 1.0 / x;
}

// Byte `i` (0-7) of an 8-byte node field.
fn node_byte(v: vec2<u32>, i: u32) -> u32 {
    let w = select(v.x, v.y, i >= 4u);
    return (w >> (8u * (i & 3u))) & 0xffu;
}

// CwBvhNode::intersect_ray_basic with get_child_and_index_bits: the hit mask of the node's
// children (internal children in the high byte at their traversal priority, leaves' unary
// primitive counts in the low 24 bits at their primitive offset).
fn bvh_intersect_node(n: CwBvhNode, o: vec3<f32>, d: vec3<f32>, inv_d: vec3<f32>, t_max: f32,
                      oct_inv4: u32) -> u32 {
    let e = vec3<u32>(n.e_imask & 0xffu, (n.e_imask >> 8u) & 0xffu, (n.e_imask >> 16u) & 0xffu);
    let extent = bitcast<vec3<f32>>(e << vec3<u32>(23u));
    let adjusted_dir_inv = extent * inv_d;
    let adjusted_origin = (n.p - o) * inv_d;
    let oct = oct_inv4 & 0xffu;
    var hit_mask = 0u;
    for (var c = 0u; c < 8u; c++) {
        let child_meta_c = node_byte(n.child_meta, c);
        if (child_meta_c == 0u) {
            // An empty slot: its bits are zero, nothing to add.
            continue;
        }
        // Internal children have meta bytes 24..31: bits 3 and 4 both set.
        let inner = ((child_meta_c & (child_meta_c << 1u)) & 0x10u) != 0u;
        let bit_index = (child_meta_c ^ select(0u, oct, inner)) & 0x1fu;
        let child_bits = (child_meta_c >> 5u) & 0x7u;
        let lo = vec3<f32>(f32(node_byte(n.child_min_x, c)), f32(node_byte(n.child_min_y, c)),
                           f32(node_byte(n.child_min_z, c)));
        let hi = vec3<f32>(f32(node_byte(n.child_max_x, c)), f32(node_byte(n.child_max_y, c)),
                           f32(node_byte(n.child_max_z, c)));
        let neg = d < vec3<f32>(0.0);
        let q_min = select(lo, hi, neg);
        let q_max = select(hi, lo, neg);
        let tmin3 = q_min * adjusted_dir_inv + adjusted_origin;
        let tmax3 = q_max * adjusted_dir_inv + adjusted_origin;
        let tmin = max(max(max(tmin3.x, tmin3.y), tmin3.z), BVH_EPSILON);
        let tmax = min(min(min(tmax3.x, tmax3.y), tmax3.z), t_max);
        if (tmin <= tmax) {
            hit_mask |= child_bits << bit_index;
        }
    }
    return hit_mask;
}

// A ray as obvhs' traversal reads it: origin, direction, their safe inverse and the octant.
struct BvhRay {
    o: vec3<f32>,
    d: vec3<f32>,
    inv_d: vec3<f32>,
    oct_inv4: u32,
}

fn bvh_ray(o: vec3<f32>, d: vec3<f32>) -> BvhRay {
    let inv_d = vec3<f32>(safe_inverse(d.x), safe_inverse(d.y), safe_inverse(d.z));
    // ray_get_octant_inv4.
    let oct_inv4 = select(0x04040404u, 0u, d.x < 0.0) | select(0x02020202u, 0u, d.y < 0.0)
        | select(0x01010101u, 0u, d.z < 0.0);
    return BvhRay(o, d, inv_d, oct_inv4);
}

// obvhs' traversal state (the `traverse!` macro): the node group being descended, the
// primitive group being tested, and a stack of node groups, nearest-first by the ray octant.
struct BvhWalk {
    stack: array<vec2<u32>, BVH_STACK_SIZE>,
    sp: u32,
    current: vec2<u32>,
    prims: vec2<u32>,
}

fn bvh_walk_start() -> BvhWalk {
    var w: BvhWalk;
    w.sp = 0u;
    w.current = vec2<u32>(0u, 0x80000000u);
    w.prims = vec2<u32>(0u);
    return w;
}

// The next primitive slot of the current leaf group (relative to the BVH's first primitive),
// NO_INDEX when the group is done.
fn bvh_walk_prim(w: ptr<function, BvhWalk>) -> u32 {
    if ((*w).prims.y == 0u) {
        return NO_INDEX;
    }
    let local = firstLeadingBit((*w).prims.y);
    (*w).prims.y &= ~(1u << local);
    return (*w).prims.x + local;
}

// Descends to the next node group of the BVH whose root is node `node_base`, or pops one;
// false when the traversal is over.
fn bvh_walk_next(w: ptr<function, BvhWalk>, node_base: u32, r: BvhRay, tmax: f32) -> bool {
    (*w).prims = vec2<u32>(0u);
    if (((*w).current.y & 0xff000000u) != 0u) {
        let hits_imask = (*w).current.y;
        let child_index_offset = firstLeadingBit(hits_imask);
        let child_index_base = (*w).current.x;
        (*w).current.y &= ~(1u << child_index_offset);
        if (((*w).current.y & 0xff000000u) != 0u && (*w).sp < BVH_STACK_SIZE) {
            (*w).stack[(*w).sp] = (*w).current;
            (*w).sp += 1u;
        }
        let slot_index = (child_index_offset - 24u) ^ (r.oct_inv4 & 0xffu);
        let relative_index = countOneBits(hits_imask & ~(0xffffffffu << slot_index));
        let node = bvh_nodes[node_base + child_index_base + relative_index];
        let hitmask = bvh_intersect_node(node, r.o, r.d, r.inv_d, tmax, r.oct_inv4);
        (*w).current = vec2<u32>(node.child_base_idx,
                                 (hitmask & 0xff000000u) | (node.e_imask >> 24u));
        (*w).prims = vec2<u32>(node.primitive_base_idx, hitmask & 0x00ffffffu);
    } else {
        (*w).current = vec2<u32>(0u);
    }
    if ((*w).prims.y == 0u && ((*w).current.y & 0xff000000u) == 0u) {
        if ((*w).sp == 0u) {
            return false;
        }
        (*w).sp -= 1u;
        (*w).current = (*w).stack[(*w).sp];
    }
    return true;
}

// TriangleBvh::closest_hit over one BVH whose root is node `node_base` and whose triangles
// start at `prim_base`: the nearest triangle with t in [t_min, t_max]; `prim` is its slot
// relative to `prim_base`.
fn bvh_closest_in(node_base: u32, prim_base: u32, o: vec3<f32>, d: vec3<f32>, t_min: f32,
                  t_max: f32) -> Hit {
    var best = Hit(NO_INDEX, 0.0, 0.0, 0.0);
    let r = bvh_ray(o, d);
    var w = bvh_walk_start();
    var tmax = t_max;
    loop {
        for (var s = bvh_walk_prim(&w); s != NO_INDEX; s = bvh_walk_prim(&w)) {
            let tri = bvh_triangles[prim_base + s];
            var h = vec3<f32>(0.0);
            if (intersect_triangle(o, d, tri.p0, tri.p1, tri.p2, t_min, tmax, &h)) {
                best = Hit(s, h.x, h.y, h.z);
                tmax = h.x;
            }
        }
        if (!bvh_walk_next(&w, node_base, r, tmax)) {
            break;
        }
    }
    return best;
}

// InstancedBvh::closest_hit: the top-level BVH (from node 0) over the placements; each one
// the ray reaches is searched in its shape's local space with the running closest t, and the
// winning triangle's hit is restated by the triangle test on its world corners (the local
// hit, its barycentrics in world corner order, where rounding makes that test miss).
fn bvh_closest_placed(o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32) -> Hit {
    var best = Hit(NO_INDEX, 0.0, 0.0, 0.0);
    var best_k = 0u;
    let r = bvh_ray(o, d);
    var w = bvh_walk_start();
    var tmax = t_max;
    loop {
        for (var k = bvh_walk_prim(&w); k != NO_INDEX; k = bvh_walk_prim(&w)) {
            let pl = bvh_placements[k];
            if ((pl.flags & PLACEMENT_EMPTY) != 0u) {
                continue;
            }
            let h = bvh_closest_in(pl.node_base, pl.prim_base, local_point(pl, o),
                                   local_vector(pl, d), t_min, tmax);
            if (h.prim != NO_INDEX) {
                best = h;
                best_k = k;
                tmax = h.t;
            }
        }
        if (!bvh_walk_next(&w, 0u, r, tmax)) {
            break;
        }
    }
    if (best.prim == NO_INDEX) {
        return best;
    }
    let pl = bvh_placements[best_k];
    let prim = pl.first_slot + best.prim;
    let tri = place_triangle(pl, bvh_triangles[pl.prim_base + best.prim]);
    var h = vec3<f32>(0.0);
    if (intersect_triangle(o, d, tri.p0, tri.p1, tri.p2, t_min, t_max, &h)) {
        return Hit(prim, h.x, h.y, h.z);
    }
    if ((pl.flags & PLACEMENT_MIRRORED) != 0u) {
        return Hit(prim, best.t, best.b2, best.b1);
    }
    return Hit(prim, best.t, best.b1, best.b2);
}

// Scene::closest_hit over the static triangles: the nearest with t in [t_min, t_max], its
// `prim` a scene-wide slot (placements.wgsl).
fn bvh_closest_hit(o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32) -> Hit {
    var best = Hit(NO_INDEX, 0.0, 0.0, 0.0);
// #if FEATURE_SURFACES
    if (!(all(abs(o) <= vec3<f32>(F32_MAX)) && all(abs(d) <= vec3<f32>(F32_MAX)))) {
        return best;
    }
    if (wf.placement_count == 0u) {
        best = bvh_closest_in(0u, 0u, o, d, t_min, t_max);
    } else {
        best = bvh_closest_placed(o, d, t_min, t_max);
    }
// #endif
    return best;
}

// glam's normalize_or_zero.
fn normalize_or_zero(v: vec3<f32>) -> vec3<f32> {
    let r = inverseSqrt(dot(v, v));
    if (r > 0.0 && r <= F32_MAX) {
        return v * r;
    }
    return vec3<f32>(0.0);
}

// The unnormalised geometric normal (b - a) x (c - a) (front: counter-clockwise).
fn triangle_cross(t: GpuTriangle) -> vec3<f32> {
    return cross(t.p1 - t.p0, t.p2 - t.p0);
}

// offset: moves a new ray's origin off the surface it leaves.
fn offset_origin(p: vec3<f32>, n: vec3<f32>, towards: vec3<f32>) -> vec3<f32> {
    let a = abs(p);
    let eps = 1e-4 * (1.0 + max(max(a.x, a.y), a.z));
    if (dot(n, towards) >= 0.0) {
        return p + n * eps;
    }
    return p - n * eps;
}

// shading_normal: the interpolated vertex normal on side's hemisphere; side itself when the
// file gave none.
fn shading_normal(t: GpuTriangle, b1: f32, b2: f32, side: vec3<f32>) -> vec3<f32> {
    let ns = normalize_or_zero(t.n0 * (1.0 - b1 - b2) + t.n1 * b1 + t.n2 * b2);
    if (all(ns == vec3<f32>(0.0))) {
        return side;
    }
    if (dot(ns, side) < 0.0) {
        return -ns;
    }
    return ns;
}

// emitted: glTF materials emit from the front face, both faces when double-sided; uv is the
// hit's texture coordinate (textures.wgsl).
fn emitted(m: Material, uv: vec2<f32>, cos_l: f32) -> vec3<f32> {
    let double_sided = (m.flags & MATERIAL_DOUBLE_SIDED) != 0u;
    if (cos_l > 0.0 || (double_sided && cos_l < 0.0)) {
        return emission_at(m, uv);
    }
    return vec3<f32>(0.0);
}

// Lights::pdf_area: selection-weighted solid-angle density of reaching emissive triangle
// `t` at distance `dist` with cosine `cos_l` (for MIS of paths that hit an emitter).
fn pdf_area(t: GpuTriangle, dist: f32, cos_l: f32) -> f32 {
    if (wf.area_count == 0u || t.light_pdf == 0.0) {
        return 0.0;
    }
    return light_pmf() * t.light_pdf * dist * dist / max(abs(cos_l), 1e-8);
}
