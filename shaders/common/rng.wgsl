// Mirrors src/sampling/rng.rs (`pcg_hash`, `Rng::new`, `Rng::next_u32`, `Rng::uniform_f32`,
// `Rng::uniform_vec2`, `Rng::queue_uniforms`, `Rng::push_front`):
// PCG-RXS-M-XS-32 with u32-only wrapping arithmetic, which is exactly WGSL's u32 semantics, so
// the streams equal the CPU's bit for bit (tests/gpu/rng.rs). Keep the two in lockstep.

const PCG_MULT: u32 = 747796405u;
const PCG_INC: u32 = 2891336453u;
const RXS_M_XS_MULT: u32 = 277803737u;
const INC_SALT: u32 = 0x9E3779B9u;

struct Rng {
    state: u32,
    inc: u32, // odd: which of the 2^31 LCG streams
    queued: vec2<u32>, // 24-bit uniforms handed out before the stream resumes (x first)
    n_queued: u32,
}

// The RXS-M-XS output permutation.
fn rxs_m_xs(s: u32) -> u32 {
    let w = ((s >> ((s >> 28u) + 4u)) ^ s) * RXS_M_XS_MULT;
    return (w >> 22u) ^ w;
}

// Jarzynski & Olano (2020): one LCG step and RXS-M-XS.
fn pcg_hash(x: u32) -> u32 {
    return rxs_m_xs(x * PCG_MULT + PCG_INC);
}

fn rng_next_u32(rng: ptr<function, Rng>) -> u32 {
    let old = (*rng).state;
    (*rng).state = old * PCG_MULT + (*rng).inc;
    return rxs_m_xs(old);
}

// Rng::new: hashed start AND hashed increment; the first output is discarded.
fn rng_new(pixel_index: u32, sample_index: u32, seed: u32) -> Rng {
    let h = pcg_hash(pcg_hash(pcg_hash(seed) ^ pixel_index) ^ sample_index);
    var rng = Rng(h, (pcg_hash(h ^ INC_SALT) << 1u) | 1u, vec2<u32>(0u), 0u);
    rng_next_u32(&rng);
    return rng;
}

// Uniform in [0, 1): the top 24 bits times 2^-24, exact in f32 and never 1.
fn rng_uniform(rng: ptr<function, Rng>) -> f32 {
    var v = 0u;
    if ((*rng).n_queued > 0u) {
        (*rng).n_queued -= 1u;
        v = (*rng).queued[1u - (*rng).n_queued];
    } else {
        v = rng_next_u32(rng) >> 8u;
    }
    return f32(v) * (1.0 / 16777216.0);
}

// Rng::uniform_vec2: two uniforms, x first.
fn rng_uniform_vec2(rng: ptr<function, Rng>) -> vec2<f32> {
    let x = rng_uniform(rng);
    let y = rng_uniform(rng);
    return vec2<f32>(x, y);
}

// Rng::queue_uniforms: the next two rng_uniform calls return a then b (top 24 bits).
fn rng_queue_uniforms(rng: ptr<function, Rng>, a: u32, b: u32) {
    (*rng).queued = vec2<u32>(a >> 8u, b >> 8u);
    (*rng).n_queued = 2u;
}

// Rng::push_front: x (in [0, 1), its top 24 bits) is the next rng_uniform, ahead of a value
// still queued; nothing is pushed when two are queued. WGSL's u32(f32) truncates and
// saturates as Rust's `as u32` does.
fn rng_push_front(rng: ptr<function, Rng>, x: f32) {
    if ((*rng).n_queued < 2u) {
        (*rng).queued[1u - (*rng).n_queued] = min(u32(x * 16777216.0), 0x00FFFFFFu);
        (*rng).n_queued += 1u;
    }
}
