// Mirrors MediaLights (src/render/media_lights.rs): the emitting media's leaf cells as one
// light, read from the table src/backend/gpu/media_lights.rs packs (its layout is described
// there), and the MIS weight of the flights' emission against it (emission_weight,
// src/integrator/views.rs). wf.media_light_cells is 0 where no medium is sampled as a light.
// The table follows the blackbody colours in emission.wgsl's emission_tables.

// Word i of the media lights' table.
fn media_light_word(i: u32) -> u32 {
    return emission_tables[BLACKBODY_TABLE_LEN + i / 4u][i % 4u];
}

// Header words of a medium record (MEDIA_LIGHT_RECORD_WORDS in all).
const ML_VDB: u32 = 0u;
const ML_DIMS: u32 = 1u;
const ML_ORIGIN: u32 = 4u;
const ML_WEIGHTS: u32 = 7u;
const ML_MAJORANTS: u32 = 8u;
const ML_WORLD_FROM_INDEX: u32 = 12u;

// EmissionMis of the invocation's flight: whether its emission is weighed against the media
// lights (after a scattering event, where some medium is sampled) and the density of the
// direction its ray left that event by. Set by sample_medium before the flight; private
// memory starts false, so no other stage weighs anything.
var<private> emission_mis_on: bool;
var<private> emission_mis_pdf: f32;

// EmitterSample: a point drawn on the emitting media.
struct MediaLightSample {
    vdb: u32,        // the medium's index in RenderScene::vdb
    y: vec3<f32>,    // world position
    pdf_volume: f32, // p_V(y), per cubic metre
    sigma_maj: f32,  // sigma_maj,c of its cell
    weight: f32,     // e_c of its cell
}

fn media_light_f32(i: u32) -> f32 {
    return bitcast<f32>(media_light_word(i));
}

// cell_lo: the index-space corner of cell c of the record at `rec`.
fn media_light_cell_lo(rec: u32, c: u32) -> vec3<f32> {
    let nx = media_light_word(rec + ML_DIMS);
    let ny = media_light_word(rec + ML_DIMS + 1u);
    let cell = vec3<i32>(vec3<u32>(c % nx, c / nx % ny, c / (nx * ny)));
    let origin = vec3<i32>(bitcast<i32>(media_light_word(rec + ML_ORIGIN)),
        bitcast<i32>(media_light_word(rec + ML_ORIGIN + 1u)),
        bitcast<i32>(media_light_word(rec + ML_ORIGIN + 2u)));
    return vec3<f32>(origin + cell) * CELL_WIDTH;
}

// MediaLights::sample: the cell drawn by u_select (the first whose cumulative weight exceeds
// it, as partition_point finds it), the point by u uniformly inside it.
fn media_light_sample(u_select: f32, u: vec3<f32>) -> MediaLightSample {
    let n = wf.media_light_cells;
    var lo = 0u;
    var hi = n;
    while (lo < hi) {
        let mid = (lo + hi) / 2u;
        if (media_light_f32(MAX_MIX + mid) <= u_select) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    let i = MAX_MIX + n + 2u * min(lo, n - 1u);
    let rec = media_light_word(i);
    let c = media_light_word(i + 1u);
    let q = media_light_cell_lo(rec, c) + u * CELL_WIDTH;
    var y = vec3<f32>(0.0);
    for (var r = 0u; r < 3u; r++) {
        let m = rec + ML_WORLD_FROM_INDEX + 4u * r;
        y[r] = media_light_f32(m) * q.x + media_light_f32(m + 1u) * q.y
            + media_light_f32(m + 2u) * q.z + media_light_f32(m + 3u);
    }
    let w = media_light_f32(media_light_word(rec + ML_WEIGHTS) + c);
    let s = media_light_f32(media_light_word(rec + ML_MAJORANTS) + c);
    return MediaLightSample(media_light_word(rec + ML_VDB), y, w / wf.media_light_total, s, w);
}

// emission_weight and MediaLights::collision_weight: the weight of emission `le` met at
// index-space point q of VDB medium k, a distance t from the event the flight's ray left;
// 1 without MIS, where k is not sampled or q lies in no cell that can be drawn.
fn emission_mis_weight(k: u32, q: vec3<f32>, t: f32, le: vec3<f32>) -> f32 {
    if (!emission_mis_on || k >= MAX_MIX || all(le == vec3<f32>(0.0))) {
        return 1.0;
    }
    let rec = media_light_word(k);
    if (rec == NO_INDEX) {
        return 1.0;
    }
    // EmitterMedium::cell.
    var index = 0u;
    var stride = 1u;
    for (var a = 0u; a < 3u; a++) {
        let dim = media_light_word(rec + ML_DIMS + a);
        let c = i32(floor(q[a] / CELL_WIDTH)) - bitcast<i32>(media_light_word(rec + ML_ORIGIN + a));
        if (c < 0 || c >= i32(dim)) {
            return 1.0;
        }
        index += u32(c) * stride;
        stride *= dim;
    }
    let e = media_light_f32(media_light_word(rec + ML_WEIGHTS) + index);
    let s = media_light_f32(media_light_word(rec + ML_MAJORANTS) + index);
    if (!(e > 0.0 && s > 0.0)) {
        return 1.0;
    }
    return power_heuristic(emission_mis_pdf * s, e / wf.media_light_total * t * t);
}
