// Mirrors MediaLights (src/render/media_lights.rs) and its CellTree (src/render/cell_tree.rs):
// the emitting media's leaf cells as one light, chosen by a light tree, read from the table src/backend/gpu/media_lights.rs packs (its layout is described
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
const ML_ITEMS: u32 = 9u;
const ML_VOLUME: u32 = 10u;
const ML_WORLD_FROM_INDEX: u32 = 12u;

// EmissionMis of the invocation's flight: whether its emission is weighed against the media
// lights (after a scattering event, where some medium is sampled), the density of the
// direction its ray left that event by, and the event's point. Set by sample_medium before
// the flight; private memory starts false, so no other stage weighs anything.
var<private> emission_mis_on: bool;
var<private> emission_mis_pdf: f32;
var<private> emission_mis_origin: vec3<f32>;

// EmitterSample: a point drawn on the emitting media.
struct MediaLightSample {
    vdb: u32,        // the medium's index in RenderScene::vdb
    y: vec3<f32>,    // world position
    pdf_volume: f32, // p_V(y | x), per cubic metre
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

// cell_tree::distance2: D of the node at word `at` from point x.
fn cell_tree_distance2(at: u32, x: vec3<f32>) -> f32 {
    let c = vec3<f32>(media_light_f32(at), media_light_f32(at + 1u), media_light_f32(at + 2u));
    let d = x - c;
    return max(dot(d, d), media_light_f32(at + 4u));
}

// cell_tree::left_probability of the nodes at words l and r from x; negative where neither
// has any importance a float can hold.
fn cell_tree_left_probability(l: u32, r: u32, x: vec3<f32>) -> f32 {
    let a = media_light_f32(l + 3u) * cell_tree_distance2(r, x);
    let b = media_light_f32(r + 3u) * cell_tree_distance2(l, x);
    let sum = a + b;
    if (!(sum > 0.0 && sum <= F32_MAX)) {
        return -1.0;
    }
    return a / sum;
}

// The word of tree node k.
fn cell_tree_node(k: u32) -> u32 {
    return wf.media_light_nodes + 6u * k;
}

// CellTree::sample: the item drawn for point x by u, and its probability (item NO_INDEX where
// no item has any importance from x).
fn cell_tree_sample(x: vec3<f32>, u_in: f32) -> vec2<u32> {
    var u = u_in;
    var at = 0u;
    var pmf = 1.0;
    loop {
        let link = media_light_word(cell_tree_node(at) + 5u);
        if ((link & CELL_TREE_LEAF) != 0u) {
            return vec2<u32>(link & ~CELL_TREE_LEAF, bitcast<u32>(pmf));
        }
        let left = at + 1u;
        let right = link;
        let p_l = cell_tree_left_probability(cell_tree_node(left), cell_tree_node(right), x);
        if (p_l < 0.0) {
            return vec2<u32>(NO_INDEX, 0u);
        }
        if (u < p_l) {
            u = min(u / p_l, CELL_TREE_ONE_MINUS_EPSILON);
            pmf *= p_l;
            at = left;
        } else {
            let p_r = 1.0 - p_l;
            u = min((u - p_l) / p_r, CELL_TREE_ONE_MINUS_EPSILON);
            pmf *= p_r;
            at = right;
        }
    }
    return vec2<u32>(NO_INDEX, 0u);
}

// CellTree::pmf: the probability that cell_tree_sample draws `item` for point x.
fn cell_tree_pmf(x: vec3<f32>, item: u32) -> f32 {
    let trail = media_light_word(MAX_MIX + item);
    var at = 0u;
    var pmf = 1.0;
    var depth = 0u;
    loop {
        let link = media_light_word(cell_tree_node(at) + 5u);
        if ((link & CELL_TREE_LEAF) != 0u) {
            return pmf;
        }
        let left = at + 1u;
        let right = link;
        let p_l = cell_tree_left_probability(cell_tree_node(left), cell_tree_node(right), x);
        if (p_l < 0.0) {
            return 0.0;
        }
        if (((trail >> depth) & 1u) == 0u) {
            pmf *= p_l;
            at = left;
        } else {
            pmf *= 1.0 - p_l;
            at = right;
        }
        depth += 1u;
    }
    return 0.0;
}

const CELL_TREE_LEAF: u32 = 0x80000000u;
const CELL_TREE_ONE_MINUS_EPSILON: f32 = 0.99999994;

// MediaLights::sample: the cell the light tree draws for shading point x by u_select, the
// point by u uniformly inside it. A pdf_volume of 0 where nothing could be drawn.
fn media_light_sample(x: vec3<f32>, u_select: f32, u: vec3<f32>) -> MediaLightSample {
    let n = wf.media_light_cells;
    let drawn = cell_tree_sample(x, u_select);
    if (drawn.x == NO_INDEX) {
        return MediaLightSample(0u, x, 0.0, 0.0, 0.0);
    }
    let i = MAX_MIX + n + 2u * drawn.x;
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
    let pdf = bitcast<f32>(drawn.y) / media_light_f32(rec + ML_VOLUME);
    return MediaLightSample(media_light_word(rec + ML_VDB), y, pdf, s, w);
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
    let item = media_light_word(media_light_word(rec + ML_ITEMS) + index);
    let s = media_light_f32(media_light_word(rec + ML_MAJORANTS) + index);
    if (item == NO_INDEX || !(s > 0.0)) {
        return 1.0;
    }
    let p_v = cell_tree_pmf(emission_mis_origin, item) / media_light_f32(rec + ML_VOLUME);
    return power_heuristic(emission_mis_pdf * s, p_v * t * t);
}
