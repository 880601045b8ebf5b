// Mirrors intersect (src/integrator/path.rs, `scene.bvh.closest_hit(&ray, t0, inf)`):
// Stage::Intersect. Each path waiting in the medium
// queue records the first surface its ray meets (GpuPathState::hit_*); the medium stage that
// reads the same queue next tracks the media up to that hit. No random numbers are drawn.

@compute @workgroup_size(64)
fn intersect(@builtin(global_invocation_id) id: vec3<u32>) {
    var slot = 0u;
    if (!queue_item(queue_medium_in(), id.x, &slot)) {
        return;
    }
    var ps = paths[slot];
    let h = bvh_closest_hit(ps.o, ps.d, ps.t0, f32_inf());
    ps.hit_prim = h.prim;
    ps.hit_t = h.t;
    ps.hit_b1 = h.b1;
    ps.hit_b2 = h.b2;
    paths[slot] = ps;
}
