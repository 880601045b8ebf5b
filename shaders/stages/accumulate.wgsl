// Mirrors TileBuffer::add_sample's caller in render_tile (src/integrator/tile.rs) and the end
// of radiance (PathStats::depth): Stage::Accumulate. A finished path writes its radiance and
// lookup count to its camera sample's entry of the batch's sample buffer (the host adds the
// entries to the f64 Film in pixel and sample order, so no float atomics are needed and the
// film's per-pixel variance is that of the individual samples); its slot is then free.

@group(1) @binding(6) var<storage, read_write> samples: array<vec4<f32>>;

// Run on every path slot of its queue (the entry point src/backend/gpu/shader.rs adds).
fn accumulate(slot: u32) {
    let ps = paths[slot];
    samples[ps.sample_id] = vec4<f32>(ps.l, bitcast<f32>(ps.lookups));
    add_wide(WIDE_DEPTH_SUM, ps.depth);
    atomicSub(&counters.live, 1u);
}
