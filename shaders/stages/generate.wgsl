// Mirrors the sample loop of render_tile (src/integrator/tile.rs) and generate
// (src/integrator/path.rs): Stage::Generate. For each free slot (the done queue of the
// previous iteration; every slot in the first), take the next camera sample of the batch, open
// its stream Rng::new(pixel, sample, seed), jitter (sampler block DIM_JITTER), draw the
// sample's time under a shutter (block DIM_TIME, after the jitter, as `radiance` does), pose a
// moving camera at it (Pinhole::posed), Camera::generate_ray and Camera::t_min
// (src/scene/camera.rs), and send the path to the intersect and medium stages (or straight to
// the escape stage when the scene has neither media nor surfaces). With the light passes
// (FEATURE_LIGHT_PASSES) the slot's pass accumulators start at zero, as PathState::passes does,
// with the light groups (FEATURE_LIGHT_GROUPS) its group accumulators, as PathState::groups
// does, and with the data passes (FEATURE_DATA_PASSES) its GpuDataPasses, as PathState::data
// does.

// Run on every path slot of its queue (the entry point src/backend/gpu/shader.rs adds).
fn generate(slot: u32) {
    let sample_id = atomicAdd(&counters.next_sample, 1u);
    if (sample_id >= wf.total_samples) {
        // The batch is handed out: the slot stays idle.
        return;
    }
    atomicAdd(&counters.live, 1u);
    let pixel = wf.pixel0 + sample_id / wf.spp_batch;
    let sample = wf.s0 + sample_id % wf.spp_batch;
    var rng = rng_new(pixel, sample, wf.seed);
    // Glows::jitter: towards lamps inside media where their film points are near; the
    // weight it gives is applied by the accumulate stage (glow_weight).
    let j = glow_jitter(pixel % wf.width, pixel / wf.width,
                        sampler_2d(sample_id, DIM_JITTER, &rng)).xy;
    let fx = (f32(pixel % wf.width) + j.x) / f32(wf.width);
    let fy = (f32(pixel / wf.width) + j.y) / f32(wf.height);
    var time = 0.0;
    var c = wf.camera;
    var forward = wf.forward;
// #if FEATURE_MOTION
    if (wf.motion.timed != 0u) {
        // Shutter::time.
        time = wf.motion.open + sampler_1d(sample_id, DIM_TIME, &rng)
            * (wf.motion.close - wf.motion.open);
    }
    if (wf.motion.moves != 0u) {
        // Pinhole::posed: the pose at the sample's time, its view axis -z.
        c = camera_pose(time);
        forward = normalize(vec3<f32>(-c[0].z, -c[1].z, -c[2].z));
    }
// #endif
    // Camera::generate_ray: the pinhole is column 3 of world_from_camera.
    let local = vec3<f32>((2.0 * fx - 1.0) * wf.tan_half * wf.aspect,
                          (1.0 - 2.0 * fy) * wf.tan_half, -1.0);
    let d = normalize(vec3<f32>(dot(c[0].xyz, local), dot(c[1].xyz, local),
                                dot(c[2].xyz, local)));
    var ps: GpuPathState;
    ps.o = vec3<f32>(c[0].w, c[1].w, c[2].w);
    ps.d = d;
    ps.time = time;
    // Camera::t_min: where the near plane cuts the unit ray.
    ps.t0 = wf.znear / max(dot(d, forward), 1e-6);
    ps.prev_pdf = 0.0;
    ps.beta = vec3<f32>(1.0);
    ps.sample_id = sample_id;
    ps.l = vec3<f32>(0.0);
    ps.depth = 0u;
    ps.rng_state = rng.state;
    ps.rng_inc = rng.inc;
    ps.flags = PATH_FLAG_SPECULAR;
    ps.collisions = 0u;
    ps.lookups = 0u;
    ps.medium = wf.camera_medium;
    ps.outer = wf.camera_outer;
    ps.hit_prim = NO_INDEX;
    paths[slot] = ps;
// #if FEATURE_LIGHT_PASSES
    clear_passes(slot);
// #endif
// #if FEATURE_LIGHT_GROUPS
    clear_groups(slot);
// #endif
// #if FEATURE_DATA_PASSES
    clear_data(slot);
// #endif
    if (FEATURE_HETEROGENEOUS || FEATURE_HOMOGENEOUS || FEATURE_SURFACES) {
        queue_push(queue_medium_in(), slot);
    } else {
        queue_push(QUEUE_ESCAPE, slot);
    }
}
