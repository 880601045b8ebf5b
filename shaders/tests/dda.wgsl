// Test kernel for DdaMajorantIterator::new / ::global (src/volume/dda/mod.rs) and
// AdaptiveMajorantIterator (src/volume/adaptive/walk.rs): all segments of each
// ray (up to MAX_SEGMENTS stored, all counted); tests/gpu/dda.rs compares with the CPU.

@group(1) @binding(0) var<storage, read> rays: array<GpuRay>;
@group(1) @binding(1) var<storage, read_write> segments: array<GpuMajorantSegment>;
@group(1) @binding(2) var<storage, read_write> counts: array<u32>;

// The items: the generated entry point `dda_segments` runs test_dda on each (`Dispatch::Items`).
fn test_dda_count() -> u32 {
    return arrayLength(&rays);
}

fn test_dda(i: u32) {
    let r = rays[i];
    var it = dda_new(r.o, r.d, r.t_min, r.t_max, DDA_SCALE, DDA_MODE);
    var seg: GpuMajorantSegment;
    var n = 0u;
    while (dda_next(&it, &seg)) {
        if (n < MAX_SEGMENTS) {
            segments[i * MAX_SEGMENTS + n] = seg;
        }
        n += 1u;
    }
    counts[i] = n;
}
