// Mirrors the placements of the two-level BVH (src/accel/instanced.rs) as
// src/backend/gpu/geometry.rs uploads them: each stored shape once, in its local space, and
// each of its placements with its transforms. A hit names a scene-wide slot: slot s of a
// placement's shape is first_slot + s, so every stage keeps one u32 per hit. Where
// wf.placement_count is 0 the triangles are flat, in world space, and a slot indexes
// bvh_triangles directly. Needs wavefront.wgsl (wf) and surfaces.wgsl (bvh_triangles,
// normalize_or_zero).

@group(1) @binding(23) var<storage, read> bvh_placements: array<GpuPlacement>;

// The placement holding scene-wide slot `prim`: the last one starting at or before it (an
// empty shape's placement shares its successor's start and comes first).
fn placement_of(prim: u32) -> u32 {
    var lo = 0u;
    var hi = wf.placement_count;
    while (lo < hi) {
        let mid = (lo + hi) / 2u;
        if (bvh_placements[mid].first_slot <= prim) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return max(lo, 1u) - 1u;
}

// The bvh_triangles (and triangle_uvs) index of scene-wide slot `prim` in x, and in y whether
// its placement mirrors (world corners 1 and 2 swapped).
fn placed_slot(prim: u32) -> vec2<u32> {
    if (wf.placement_count == 0u) {
        return vec2<u32>(prim, 0u);
    }
    let pl = bvh_placements[placement_of(prim)];
    return vec2<u32>(pl.prim_base + prim - pl.first_slot, pl.flags & PLACEMENT_MIRRORED);
}

// world_from_local.transform_point3 (glam's order of operations).
fn place_point(pl: GpuPlacement, p: vec3<f32>) -> vec3<f32> {
    return pl.world_x * p.x + pl.world_y * p.y + pl.world_z * p.z + pl.world_w;
}

// local_from_world.transform_point3 (Affine3A).
fn local_point(pl: GpuPlacement, p: vec3<f32>) -> vec3<f32> {
    return pl.local_x * p.x + pl.local_y * p.y + pl.local_z * p.z + pl.local_w;
}

// local_from_world.transform_vector3: the direction is not renormalised, so t means the same
// in both spaces.
fn local_vector(pl: GpuPlacement, v: vec3<f32>) -> vec3<f32> {
    return pl.local_x * v.x + pl.local_y * v.y + pl.local_z * v.z;
}

// A local vertex normal in world space (world_mesh's Placement::vertex): the inverse
// transpose, then normalize_or_zero.
fn place_normal(pl: GpuPlacement, n: vec3<f32>) -> vec3<f32> {
    return normalize_or_zero(pl.normal_x * n.x + pl.normal_y * n.y + pl.normal_z * n.z);
}

// A local-space triangle of `pl`'s shape as flattening places it: world corners and normals
// in world corner order, its index in Scene::triangles.
fn place_triangle(pl: GpuPlacement, t: GpuTriangle) -> GpuTriangle {
    var w = t;
    w.triangle = pl.first_triangle + t.triangle;
    w.p0 = place_point(pl, t.p0);
    w.n0 = place_normal(pl, t.n0);
    let p1 = place_point(pl, t.p1);
    let p2 = place_point(pl, t.p2);
    let n1 = place_normal(pl, t.n1);
    let n2 = place_normal(pl, t.n2);
    let mirrored = (pl.flags & PLACEMENT_MIRRORED) != 0u;
    w.p1 = select(p1, p2, mirrored);
    w.p2 = select(p2, p1, mirrored);
    w.n1 = select(n1, n2, mirrored);
    w.n2 = select(n2, n1, mirrored);
    return w;
}

// The world-space triangle at scene-wide slot `prim` (Scene::triangle_vertices): what every
// stage shades, samples and offsets from.
fn scene_triangle(prim: u32) -> GpuTriangle {
    if (wf.placement_count == 0u) {
        return bvh_triangles[prim];
    }
    let pl = bvh_placements[placement_of(prim)];
    return place_triangle(pl, bvh_triangles[pl.prim_base + prim - pl.first_slot]);
}
