// Mirrors the queue bookkeeping of Wavefront::iterations (src/backend/gpu/dispatch.rs): at the
// start of an iteration the queues it fills are emptied (`queue_reset`); before each stage the
// indirect dispatch arguments of every queue are derived from its length (`queue_args`), so
// the host never reads a queue length to dispatch.

@group(1) @binding(7) var<storage, read_write> dispatch_args: array<u32>;

@compute @workgroup_size(1)
fn queue_reset() {
    atomicStore(&counters.queue_count[queue_medium_out()], 0u);
    atomicStore(&counters.queue_count[queue_done_out()], 0u);
    atomicStore(&counters.queue_count[QUEUE_SCATTER], 0u);
    atomicStore(&counters.queue_count[QUEUE_SHADOW], 0u);
    atomicStore(&counters.queue_count[QUEUE_PHASE], 0u);
    atomicStore(&counters.queue_count[QUEUE_ESCAPE], 0u);
    atomicStore(&counters.queue_count[QUEUE_SURFACE], 0u);
}

@compute @workgroup_size(16)
fn queue_args(@builtin(local_invocation_index) q: u32) {
    if (q >= QUEUE_COUNT) {
        return;
    }
    let n = atomicLoad(&counters.queue_count[q]);
    dispatch_args[3u * q] = (n + WORKGROUP - 1u) / WORKGROUP;
    dispatch_args[3u * q + 1u] = 1u;
    dispatch_args[3u * q + 2u] = 1u;
}
