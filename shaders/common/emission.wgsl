// Mirrors the emission of the VDB medium: Emission::radiance (src/render/emission.rs),
// GreyView::on_collision and RgbView::on_collision (src/integrator/views.rs), and
// blackbody_rgb / blackbody_emission (src/render/blackbody.rs). Blender's Principled
// Volume: radiance per metre, NOT multiplied by density, gathered at every tentative
// collision of a free flight with weight
// w / sigma_maj (the collision density of the majorant cancels the 1 / sigma_maj; pbrt-v4's
// VolPathIntegrator adds beta * sigma_a * Le / sigma_maj the same way, Brume's emission
// coefficient already includes the absorption). No random numbers are drawn, so the stream
// order stays the CPU's. Needs grid.wgsl (lookups into the shared grid buffers) and
// tracking.wgsl (Tracker).

@group(0) @binding(5) var<uniform> emission: GpuEmissionParams;
// The emission's tables, as words: the unit-luminance Rec.709 colour table of
// blackbody::table(), 10 K apart (the first BLACKBODY_TABLE_LEN entries, a colour's xyz bits
// each; w unused), then the media lights' table (media_lights.wgsl), four words an entry. One
// binding for both keeps the stages that reach the emission within their storage buffers.
// Read-only storage rather than a uniform: as a third uniform block in group 0 the colour
// table made Mesa 22.3's lavapipe (Debian 12) write into its free heap creating the generic
// sample_medium pipeline (tools/lavapipe_ubo/; MAX_UNIFORM_BLOCKS_PER_GROUP in
// src/backend/gpu/shader.rs).
@group(0) @binding(6) var<storage, read> emission_tables: array<vec4<u32>>;

// #if FEATURE_LIGHT_GROUPS
// The emission of the invocation's flights by light group (each view's `emitted`, which
// Emitted::add hands its medium's group): on_collision sets the collision's weight, every
// medium's radiance there adds its share to its group (emission_radiance_of), and
// sample_medium gathers them into the path's groups (gather_flight_groups). Private memory
// starts at zero, and each invocation runs one sample_medium.
var<private> collision_weight: vec3<f32>;
var<private> flight_groups: array<vec3<f32>, LIGHT_GROUPS>;

fn emit_to_group(group: u32, le: vec3<f32>) {
    if (group < LIGHT_GROUPS) {
        flight_groups[group] += collision_weight * le;
    }
}
// #endif

// blackbody_rgb: linear interpolation in the table, temperatures clamped to its range.
fn blackbody_rgb(t: f32) -> vec3<f32> {
    let x = max((clamp(t, BLACKBODY_T_MIN, BLACKBODY_T_MAX) - BLACKBODY_T_MIN) / BLACKBODY_STEP, 0.0);
    let i = min(u32(x), BLACKBODY_TABLE_LEN - 2u);
    let f = x - f32(i);
    let a = bitcast<vec3<f32>>(emission_tables[i].xyz);
    let b = bitcast<vec3<f32>>(emission_tables[i + 1u].xyz);
    // glam's lerp: a + (b - a) f.
    return a + (b - a) * f;
}

// blackbody_emission: (sigma_SB 1e-6 / pi) ((1 - I) + I T^4) C(T). The CPU forms T^4 in f64;
// here the scale multiplies T^2 before the second T^2, which keeps every product finite up
// to the loader's limit (scene::MAX_TEMPERATURE_K = 1e12 K: 1.8e-14 * 1e24 * 1e24 < 3.4e38).
fn blackbody_emission(t_kelvin: f32, intensity: f32) -> vec3<f32> {
    let t = max(t_kelvin, 0.0);
    let t2 = t * t;
    let scale = STEFAN_BOLTZMANN_SCALE * (1.0 - intensity)
        + ((STEFAN_BOLTZMANN_SCALE * intensity) * t2) * t2;
    return blackbody_rgb(t) * scale;
}

// Emission::radiance at world point p of the medium whose emission is `emission` (the
// uniform of a scene with one VDB medium, or a vdb_media entry's); counts its grid reads in
// the tracker.
fn emission_radiance_of(tr: ptr<function, Tracker>, emission: GpuEmissionParams, p: vec3<f32>) -> vec3<f32> {
    var e = vec3<f32>(0.0);
    // EmissionRegion::contains: nothing is emitted outside the region's box.
    if (emission.has_region != 0u) {
        let w = vec4<f32>(p, 1.0);
        let q = vec3<f32>(dot(emission.region_from_world[0], w), dot(emission.region_from_world[1], w),
            dot(emission.region_from_world[2], w));
        if (any(q < emission.region_min) || any(q >= emission.region_max)) {
            return e;
        }
    }
    if (any(emission.strength_color != vec3<f32>(0.0))) {
        var scale = 1.0;
        if (emission.has_grid != 0u) {
            (*tr).emission_lookups += 1u;
            scale = grid_sample_trilinear_in(emission.grid, grid_index_point(emission.grid, p));
        }
        e += emission.strength_color * scale;
    }
    if (emission.has_blackbody != 0u) {
        (*tr).emission_lookups += 1u;
        let g = emission.temperature;
        let t = emission.temperature_scale * grid_sample_trilinear_in(g, grid_index_point(g, p))
            + emission.temperature_offset;
        e += emission.tint * blackbody_emission(t, emission.intensity);
    }
    return e;
}

// The emission of VDB medium k met by a flight at world point p (index point q, t along the
// ray): its radiance weighed against the media lights (emission_weight, media_lights.wgsl),
// which the light-group variant also adds to the medium's group.
fn emission_met(tr: ptr<function, Tracker>, e: GpuEmissionParams, k: u32, p: vec3<f32>,
                q: vec3<f32>, t: f32) -> vec3<f32> {
    var le = emission_radiance_of(tr, e, p);
    le *= emission_mis_weight(k, q, t, le);
// #if FEATURE_LIGHT_GROUPS
    emit_to_group(e.light_group, le);
// #endif
    return le;
}

// Medium::on_collision of the wavefront's media: the emission at the tentative collision t
// (read at the advected world point where the medium is blurred),
// weighted by the flight's starting throughput and the weight so far over sigma_maj
// (grey: `beta * (w / sigma_maj) * Le`; spectral: `beta * w * Le / sigma_maj`). A mixture
// gathers every member's emission (GreyMix / RgbMix::on_collision: each view's term, with
// the same weight, so their sum).
fn on_collision(tr: ptr<function, Tracker>, t: f32, sigma_maj: f32) {
// #if FEATURE_EMISSION
// #if FEATURE_LIGHT_GROUPS
    // The weight below, set before the media's radiance adds each medium's to its group.
    if ((*tr).params.estimator == ESTIMATOR_SPECTRAL) {
        collision_weight = (*tr).beta * (*tr).w / sigma_maj;
    } else {
        collision_weight = (*tr).beta * ((*tr).w.x / sigma_maj);
    }
// #endif
    var p = (*tr).ow + t * (*tr).dw;
    var le = vec3<f32>(0.0);
// #if FEATURE_MIXTURE
    le = mix_emission(tr, p, t);
// #endif
// #if !FEATURE_MIXTURE
// #if FEATURE_MOTION
    // Blur::world_point: a blurred medium emits what reaches the point at the sample's time.
    p = blur_world_point(wf.blur, p, (*tr).o + t * (*tr).d, (*tr).time);
// #endif
    le = emission_met(tr, emission, 0u, p, (*tr).o + t * (*tr).d, t);
// #endif
    if ((*tr).params.estimator == ESTIMATOR_SPECTRAL) {
        (*tr).emitted += (*tr).beta * (*tr).w * le / sigma_maj;
    } else {
        (*tr).emitted += (*tr).beta * ((*tr).w.x / sigma_maj) * le;
    }
// #endif
}
