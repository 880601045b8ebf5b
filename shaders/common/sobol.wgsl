// Mirrors src/sampling/sobol.rs (`owen_scramble`, `sobol_dim1`, `block_seed`,
// `sobol_point_u32`, `sobol_point`, `bounce_dim`): padded 2D Sobol with Burley's (2020,
// "Practical Hash-based Owen Scrambling") hash-based nested uniform scrambling, in wrapping u32
// arithmetic, so the points equal the CPU's bit for bit (tests/gpu/sobol.rs). Keep the two in
// lockstep. The dimension layout (which block drives which decision) is the table in
// sobol.rs; the per-bounce offsets below are its rows.

const SOBOL_SALT: u32 = 0x5EED50B0u;
const DIM_JITTER: u32 = 0u;
const DIMS_PER_BOUNCE: u32 = 6u;
const DIM_DISTANCE: u32 = 0u; // the first two draws of a bounce's first free flight
const DIM_LIGHT_SELECT: u32 = 1u;
const DIM_LIGHT: u32 = 2u;
const DIM_LOBE: u32 = 3u;
const DIM_SCATTER: u32 = 4u;
const DIM_RR: u32 = 5u;

// The block of decision `offset` at bounce `depth` (the events before the decision).
fn bounce_dim(depth: u32, offset: u32) -> u32 {
    return 1u + depth * DIMS_PER_BOUNCE + offset;
}

// Burley's improved Laine-Karras permutation: adding and multiplying by even constants only
// carry upwards, so each bit depends on the bits below it (a nested scramble of the reversed
// digits).
fn laine_karras(x_in: u32, seed: u32) -> u32 {
    var x = x_in + seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return x;
}

// Nested uniform (Owen) scrambling of a 32-bit fixed-point value.
fn owen_scramble(v: u32, seed: u32) -> u32 {
    return reverseBits(laine_karras(reverseBits(v), seed));
}

// Sobol dimension 1 (polynomial x + 1): XOR of v_k over the set bits of i,
// v_0 = 2^31, v_{k+1} = v_k ^ (v_k >> 1).
fn sobol_dim1(i_in: u32) -> u32 {
    var i = i_in;
    var v = 0x80000000u;
    var r = 0u;
    while (i != 0u) {
        if ((i & 1u) != 0u) {
            r ^= v;
        }
        i = i >> 1u;
        v ^= v >> 1u;
    }
    return r;
}

fn sobol_block_seed(pixel: u32, block: u32, seed: u32) -> u32 {
    return pcg_hash(pcg_hash(pcg_hash(seed ^ SOBOL_SALT) ^ pixel) ^ block);
}

// The scrambled point of (pixel, sample, block): per-block shuffled index, then each Sobol
// dimension scrambled with its own seed.
fn sobol_point_u32(pixel: u32, sample: u32, block: u32, seed: u32) -> vec2<u32> {
    let s = sobol_block_seed(pixel, block, seed);
    let i = owen_scramble(sample, pcg_hash(s));
    return vec2<u32>(owen_scramble(reverseBits(i), pcg_hash(s ^ 1u)),
                     owen_scramble(sobol_dim1(i), pcg_hash(s ^ 2u)));
}

// In [0, 1)^2: the top 24 bits times 2^-24, like rng_uniform.
fn sobol_point(pixel: u32, sample: u32, block: u32, seed: u32) -> vec2<f32> {
    let p = sobol_point_u32(pixel, sample, block, seed);
    return vec2<f32>(f32(p.x >> 8u), f32(p.y >> 8u)) * (1.0 / 16777216.0);
}
