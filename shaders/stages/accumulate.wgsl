// Mirrors TileBuffer::add_sample's caller in render_tile (src/integrator/tile.rs) and the end
// of radiance (PathStats::depth, CameraSample): Stage::Accumulate. A finished path writes its
// radiance, coverage and lookup count to its camera sample's entry of the batch's sample
// buffer (the host adds the entries to the f64 Film in pixel and sample order, so no float
// atomics are needed and the film's per-pixel variance is that of the individual samples),
// and with the light passes its CameraSample::passes to the entries beside it, with the light
// groups its CameraSample::groups to the entries after those, with the data passes its
// CameraSample::data to the entry beside it; its slot is then free.

@group(1) @binding(6) var<storage, read_write> samples: array<GpuSample>;
// CameraSample::passes and CameraSample::groups: the path's LIGHT_ENTRIES light accumulators
// (path_passes) beside its sample entry, from sample_id * LIGHT_ENTRIES (read back with the
// batch's samples); bound only by the variants that keep either.
@group(1) @binding(20) var<storage, read_write> sample_passes: array<vec4<f32>>;
// #if FEATURE_DATA_PASSES
// CameraSample::data: the path's data passes beside its sample entry (read back with the
// batch's samples).
@group(1) @binding(22) var<storage, read_write> sample_data: array<GpuDataPasses>;
// #endif

// Run on every path slot of its queue (the entry point src/backend/gpu/shader.rs adds).
fn accumulate(slot: u32) {
    let ps = paths[slot];
    // escape's `background`: the throughput of a camera ray that escaped unscattered.
    var background = 0.0;
    if ((ps.flags & PATH_FLAG_ESCAPED) != 0u && ps.depth == 0u) {
        background = (ps.beta.x + ps.beta.y + ps.beta.z) / 3.0;
    }
    // CameraSample::scale: every channel times the glow sampling weight.
    let w = glow_weight(ps.sample_id);
    samples[ps.sample_id] = GpuSample(ps.l * w, ps.lookups, (1.0 - background) * w, 0u, 0u, 0u);
// #if FEATURE_LIGHT_PASSES
    for (var k = 0u; k < LIGHT_PASSES; k++) {
        sample_passes[ps.sample_id * LIGHT_ENTRIES + k] =
            path_passes[slot * LIGHT_ENTRIES + k] * w;
    }
// #endif
// #if FEATURE_LIGHT_GROUPS
    for (var k = PASS_ENTRIES; k < LIGHT_ENTRIES; k++) {
        sample_passes[ps.sample_id * LIGHT_ENTRIES + k] =
            path_passes[slot * LIGHT_ENTRIES + k] * w;
    }
// #endif
// #if FEATURE_DATA_PASSES
    var data = path_data[slot];
    data.albedo *= w;
    data.depth *= w;
    data.normal *= w;
    sample_data[ps.sample_id] = data;
// #endif
    add_wide(WIDE_DEPTH_SUM, ps.depth);
    atomicSub(&counters.live, 1u);
}
