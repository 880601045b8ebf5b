// Mirrors intersect (src/integrator/path.rs, `scene.bvh.closest_hit(&ray, t0, inf)`):
// Stage::Intersect. Each path waiting in the medium
// queue records the first surface its ray meets (GpuPathState::hit_*); the medium stage that
// reads the same queue next tracks the media up to that hit. No random numbers are drawn.

// Run on every path slot of its queue (the entry point src/backend/gpu/shader.rs adds).
fn intersect(slot: u32) {
    var ps = paths[slot];
    let h = bvh_closest_hit(ps.o, ps.d, ps.t0, f32_inf());
    ps.hit_prim = h.prim;
    ps.hit_t = h.t;
    ps.hit_b1 = h.b1;
    ps.hit_b2 = h.b2;
    paths[slot] = ps;
}
