//! Owen-scrambled Sobol points for the fixed-layout decisions of a path, reproduced bit for bit
//! by `shaders/common/sobol.wgsl`.
//!
//! Construction: padded 2D Sobol with hash-based nested uniform (Owen) scrambling, after
//! Burley (2020, "Practical Hash-based Owen Scrambling", JCGT 9(4)), section 4 ("shuffled
//! scrambled Sobol") and section 5 (padding). Every *dimension block* `b` of a path is an
//! independent 2D point set:
//!
//! ```text
//! seed_b      = pcg_hash(pcg_hash(pcg_hash(seed ^ SOBOL_SALT) ^ pixel) ^ b)
//! i'          = owen(sample_index, pcg_hash(seed_b ^ 0))     // per-pixel, per-block shuffle
//! x           = owen(reverse_bits(i'), pcg_hash(seed_b ^ 1)) // Sobol dimension 0
//! y           = owen(sobol_1(i'),      pcg_hash(seed_b ^ 2)) // Sobol dimension 1
//! u           = (x >> 8, y >> 8) * 2^-24                     // in [0, 1), like Rng::uniform_f32
//!
//! owen(v, s)  = reverse_bits(lk(reverse_bits(v), s))         // Burley's nested_uniform_scramble
//! lk(x, s)    = x += s; x ^= x*0x6c50b47c; x ^= x*0xb82f1e52; x ^= x*0xc7afe638; x ^= x*0x8d22f6e6
//! sobol_1(i)  = XOR of v_k over the set bits k of i, v_0 = 2^31, v_{k+1} = v_k ^ (v_k >> 1)
//! ```
//!
//! Why it works: in `lk` every step (adding, multiplying by an even constant) changes bit `k`
//! only by a function of bits below `k`, so between the bit reversals each output bit depends
//! only on the more significant input bits: a nested uniform scramble of the binary digits.
//! Such a scramble keeps Sobol's (0,2)-sequence property: the first `2^k` points of a block (and
//! any aligned run of `2^k` sample indices) put exactly one point in every elementary interval
//! `[a 2^-j, (a+1) 2^-j) x [c 2^-(k-j), (c+1) 2^-(k-j))`. The index shuffle is itself an Owen
//! scramble of the index, so it maps every aligned run of `2^k` indices onto an aligned run of
//! `2^k` Sobol indices: the stratification survives the shuffle, while different blocks see
//! their points in unrelated orders (padding without correlation between blocks, Burley sec. 5).
//! Hashing the pixel into every seed decorrelates neighbouring pixels (white-noise across the
//! image, as pbrt-v4's `PaddedSobolSampler`; the blue-noise Morton ordering of `ZSobolSampler`,
//! Ahmed and Wonka 2020, is not used).
//!
//! The sample index is the pixel's global sample index, so progressive passes continue the same
//! sequence (64 spp in passes equals 64 spp at once) and nothing depends on threads or tiles.
//! All arithmetic is wrapping `u32`: WGSL has no 64-bit integers.
//!
//! # Dimension layout
//!
//! Blocks are 2D; a 1D decision uses the block's first coordinate. The bounce index `d` is the
//! number of scattering events before the decision (0 for the first vertex after the camera).
//!
//! ```text
//! block            coords   decision
//! 0                2D       pixel jitter (x, y)
//! 1 + 6d + 0       2D       free flight: first exponential depth, first event choice
//! 1 + 6d + 1       1D       light selection (next-event estimation)
//! 1 + 6d + 2       2D       light sample (point on the light / environment direction)
//! 1 + 6d + 3       1D       lobe choice: BSDF lobe, or dielectric Fresnel reflect/refract
//! 1 + 6d + 4       2D       phase / BSDF direction sample
//! 1 + 6d + 5       1D       Russian roulette
//! 2^32 - 1         1D       the camera sample's time in the shutter (motion blur only)
//! ```
//!
//! The free-flight loops (delta, ratio and decomposition tracking) draw an unbounded number of
//! uniforms per ray, so they draw from the PCG [`Rng`] of the same (pixel, sample, seed), as
//! pbrt-v4 seeds an RNG for majorant sampling; but the FIRST two draws of the first free
//! flight after each scattering event (the first tentative collision's exponential depth and
//! its event choice, which decide most single scattering in thin media) are block `1 + 6d + 0`,
//! queued on the stream ([`Sampler::queue_on_stream`]); a flight continued past a null
//! interface draws from the stream alone, so no point serves two decisions.
//!
//! [`SamplerKind::Independent`] reproduces the pre-Sobol renders exactly: every decision then
//! draws from the path's [`Rng`] in call order, as before.
use std::fmt;
use std::str::FromStr;

use glam::Vec2;

use super::rng::{pcg_hash, Rng};

/// Salt separating the Sobol seeds from the RNG stream seeds of the same (pixel, seed).
pub const SOBOL_SALT: u32 = 0x5EED_50B0;

/// Dimension block of the pixel jitter.
pub const DIM_JITTER: u32 = 0;
/// Dimension block of the camera sample's time: the last block, which no bounce reaches
/// (padded blocks are independent, so its place costs nothing).
pub const DIM_TIME: u32 = u32::MAX;
/// Blocks per bounce (see the layout table in the module docs).
pub const DIMS_PER_BOUNCE: u32 = 6;
/// Offsets of the per-bounce blocks.
pub const DIM_DISTANCE: u32 = 0;
pub const DIM_LIGHT_SELECT: u32 = 1;
pub const DIM_LIGHT: u32 = 2;
pub const DIM_LOBE: u32 = 3;
pub const DIM_SCATTER: u32 = 4;
pub const DIM_RR: u32 = 5;

/// The block of decision `offset` (one of the `DIM_*` offsets) at bounce `depth`.
#[inline]
pub fn bounce_dim(depth: u32, offset: u32) -> u32 {
    1u32.wrapping_add(depth.wrapping_mul(DIMS_PER_BOUNCE))
        .wrapping_add(offset)
}

/// Burley's (2020) improved Laine-Karras permutation: a nested uniform scramble of the
/// *reversed* bits (each output bit depends only on the input bits below it).
#[inline]
fn laine_karras(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// Hash-based nested uniform (Owen) scrambling of a 32-bit fixed-point value (Burley 2020).
#[inline]
pub fn owen_scramble(v: u32, seed: u32) -> u32 {
    laine_karras(v.reverse_bits(), seed).reverse_bits()
}

/// Sobol dimension 1 (primitive polynomial `x + 1`, all `m_k = 1`) as 32-bit fixed point,
/// bit by bit: `XOR of v_k over the set bits k of i`.
pub const fn sobol_dim1_bitwise(mut i: u32) -> u32 {
    let mut v = 1u32 << 31;
    let mut r = 0u32;
    while i != 0 {
        if i & 1 != 0 {
            r ^= v;
        }
        i >>= 1;
        v ^= v >> 1;
    }
    r
}

/// [`sobol_dim1_bitwise`] of every byte value in each of the 4 byte positions: the map is
/// linear over GF(2) in the bits of `i`, so `sobol_dim1(i)` is the XOR of 4 table entries
/// (the scrambled indices have ~16 set bits of 32, and a 32-step loop with an unpredictable
/// branch per bit cost more than the rest of a point).
const DIM1_BYTES: [[u32; 256]; 4] = dim1_byte_tables(false);

/// The per-byte tables of [`sobol_dim1_bitwise`], or with `reversed` of
/// `reverse_bits(sobol_dim1_bitwise(reverse_bits(j)))` (reversal permutes bits, so that map is
/// linear over GF(2) too).
const fn dim1_byte_tables(reversed: bool) -> [[u32; 256]; 4] {
    let mut t = [[0u32; 256]; 4];
    let mut k = 0;
    while k < 4 {
        let mut b = 0;
        while b < 256 {
            let i = (b as u32) << (8 * k);
            t[k][b] = if reversed {
                sobol_dim1_bitwise(i.reverse_bits()).reverse_bits()
            } else {
                sobol_dim1_bitwise(i)
            };
            b += 1;
        }
        k += 1;
    }
    t
}

/// The XOR of `tables`' entries for the 4 bytes of `i`.
#[inline]
fn xor_bytes(tables: &[[u32; 256]; 4], i: u32) -> u32 {
    tables[0][(i & 0xff) as usize]
        ^ tables[1][(i >> 8 & 0xff) as usize]
        ^ tables[2][(i >> 16 & 0xff) as usize]
        ^ tables[3][(i >> 24) as usize]
}

/// Sobol dimension 1 as 32-bit fixed point (equal to [`sobol_dim1_bitwise`], by table).
#[inline]
pub fn sobol_dim1(i: u32) -> u32 {
    xor_bytes(&DIM1_BYTES, i)
}

/// The unscrambled 2D Sobol point `i` (dimensions 0 and 1) as 32-bit fixed point.
#[inline]
pub fn sobol_2d(i: u32) -> (u32, u32) {
    (i.reverse_bits(), sobol_dim1(i))
}

/// Seed of one dimension block of one pixel.
#[inline]
pub fn block_seed(pixel: u32, block: u32, seed: u32) -> u32 {
    pcg_hash(pixel_seed(pixel, seed) ^ block)
}

/// The part of [`block_seed`] shared by every block of a pixel (a sampler keeps it).
#[inline]
pub fn pixel_seed(pixel: u32, seed: u32) -> u32 {
    pcg_hash(pcg_hash(seed ^ SOBOL_SALT) ^ pixel)
}

/// The scrambled 2D point of `(pixel, sample, block)` as 32-bit fixed point: the bits the
/// WGSL mirror must reproduce.
#[inline]
pub fn sobol_point_u32(pixel: u32, sample: u32, block: u32, seed: u32) -> (u32, u32) {
    point_from_pixel_seed(pixel_seed(pixel, seed), sample, block)
}

/// [`sobol_point_u32`] from the pixel's [`pixel_seed`].
#[inline]
fn point_from_pixel_seed(pixel_seed: u32, sample: u32, block: u32) -> (u32, u32) {
    let s = pcg_hash(pixel_seed ^ block);
    let i = owen_scramble(sample, pcg_hash(s));
    let (x, y) = sobol_2d(i);
    (
        owen_scramble(x, pcg_hash(s ^ 1)),
        owen_scramble(y, pcg_hash(s ^ 2)),
    )
}

/// The first coordinate of [`point_from_pixel_seed`] alone (a 1D decision needs no `y`).
#[cfg(test)]
fn x_from_pixel_seed(pixel_seed: u32, sample: u32, block: u32) -> u32 {
    x_from_seeds(
        block_scramble_seeds(pixel_seed, block),
        sample.reverse_bits(),
    )
}

/// The three scramble seeds of a block of a pixel: the index shuffle's, dimension 0's and
/// dimension 1's. They depend on the pixel and the block only, so a [`Sampler`] computes them
/// once per pixel instead of hashing four times for every point.
#[inline]
fn block_scramble_seeds(pixel_seed: u32, block: u32) -> [u32; 3] {
    let s = pcg_hash(pixel_seed ^ block);
    [pcg_hash(s), pcg_hash(s ^ 1), pcg_hash(s ^ 2)]
}

/// [`DIM1_BYTES`] in the reversed-bit domain: `reverse_bits(sobol_dim1(reverse_bits(j)))` is
/// the XOR of entry `[k][byte k of j]`.
const DIM1_REV_BYTES: [[u32; 256]; 4] = dim1_byte_tables(true);

/// `reverse_bits(sobol_dim1(reverse_bits(j)))` by table.
#[inline]
fn sobol_dim1_reversed(j: u32) -> u32 {
    xor_bytes(&DIM1_REV_BYTES, j)
}

/// [`point_from_pixel_seed`] from the block's [`block_scramble_seeds`] and the reversed sample
/// index, with the bit reversals that cancel left out: `owen(v, s) = rev(lk(rev(v), s))`, so
/// the shuffled index `i'` is kept reversed (`j = lk(rev(sample), s0) = rev(i')`), and
/// `x = owen(rev(i'), s1) = rev(lk(i', s1))`, `y = rev(lk(rev(sobol_1(i')), s2))`, where
/// `rev(sobol_1(i'))` is [`sobol_dim1_reversed`] of `j`. Equal bit for bit (tested).
#[inline]
fn point_from_seeds(seeds: [u32; 3], sample_rev: u32) -> (u32, u32) {
    let j = laine_karras(sample_rev, seeds[0]);
    (
        laine_karras(j.reverse_bits(), seeds[1]).reverse_bits(),
        laine_karras(sobol_dim1_reversed(j), seeds[2]).reverse_bits(),
    )
}

/// The first coordinate of [`point_from_seeds`] alone.
#[inline]
fn x_from_seeds(seeds: [u32; 3], sample_rev: u32) -> u32 {
    let j = laine_karras(sample_rev, seeds[0]);
    laine_karras(j.reverse_bits(), seeds[1]).reverse_bits()
}

/// [`sobol_point_u32`] in `[0, 1)^2`: the top 24 bits, exact in f32, never 1.
#[inline]
pub fn sobol_point(pixel: u32, sample: u32, block: u32, seed: u32) -> Vec2 {
    let (x, y) = sobol_point_u32(pixel, sample, block, seed);
    Vec2::new(to_unit(x), to_unit(y))
}

#[inline]
fn to_unit(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// Which numbers drive the fixed-layout decisions of a path.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SamplerKind {
    /// Owen-scrambled padded 2D Sobol (this module).
    #[default]
    Sobol,
    /// The path's PCG stream in call order (the renderer before Sobol).
    Independent,
}

impl SamplerKind {
    pub fn name(self) -> &'static str {
        match self {
            SamplerKind::Sobol => "sobol",
            SamplerKind::Independent => "independent",
        }
    }

    /// The value written to the GPU params (0 = sobol, 1 = independent).
    pub fn gpu_code(self) -> u32 {
        match self {
            SamplerKind::Sobol => 0,
            SamplerKind::Independent => 1,
        }
    }
}

impl FromStr for SamplerKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "sobol" => Ok(SamplerKind::Sobol),
            "independent" => Ok(SamplerKind::Independent),
            _ => Err(format!(
                "unknown sampler '{s}' (expected one of: sobol, independent)"
            )),
        }
    }
}

impl fmt::Display for SamplerKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Blocks whose scramble seeds a [`Sampler`] keeps: the camera's and 10 bounces' (later ones
/// are hashed at each use).
const CACHED_BLOCKS: usize = 64;

/// The random numbers of one path: the PCG stream for the free-flight loops (`rng`) and the
/// fixed-layout decisions (`get1d` / `get2d`, by dimension block).
///
/// One sampler serves every sample of a pixel in turn ([`Sampler::start`]): the blocks'
/// scramble seeds depend on the pixel alone, so it keeps them (filled on first use) and a
/// point costs three scrambles instead of three scrambles and four hashes.
#[derive(Clone, Debug)]
pub struct Sampler {
    /// The (pixel, sample, seed) stream: free flights and transmittance always draw from it.
    pub rng: Rng,
    kind: SamplerKind,
    pixel: u32,
    seed: u32,
    /// [`pixel_seed`] of the pixel and render seed (shared by every block of the path).
    pixel_seed: u32,
    /// The sample index with its bits reversed (what the index shuffle scrambles).
    sample_rev: u32,
    /// [`block_scramble_seeds`] of blocks `0..CACHED_BLOCKS`, valid where `cached` has the bit.
    block_seeds: [[u32; 3]; CACHED_BLOCKS],
    cached: u64,
}

impl Sampler {
    pub fn new(kind: SamplerKind, pixel: u32, sample: u32, seed: u32) -> Self {
        let mut sampler = Sampler::for_pixel(kind, pixel, seed);
        sampler.start(sample);
        sampler
    }

    /// A sampler for the samples of `pixel`, at sample 0 until [`Sampler::start`].
    pub fn for_pixel(kind: SamplerKind, pixel: u32, seed: u32) -> Self {
        Sampler {
            rng: Rng::new(pixel, 0, seed),
            kind,
            pixel,
            seed,
            pixel_seed: pixel_seed(pixel, seed),
            sample_rev: 0,
            block_seeds: [[0; 3]; CACHED_BLOCKS],
            cached: 0,
        }
    }

    /// Moves the sampler to the samples of `pixel`; [`Sampler::start`] must follow before it
    /// draws (until then its stream is still the last sample's). Then it draws exactly as
    /// `Sampler::new(kind, pixel, sample, seed)`. Only the kept block seeds' mask is cleared,
    /// where a fresh sampler zeroed all of them (a 768-byte `memset` a pixel and pass, about
    /// 20 instructions a sample at 16 spp in callgrind); and the stream is built once, by
    /// `start`, not also for sample 0 here.
    #[inline]
    pub fn set_pixel(&mut self, pixel: u32) {
        self.pixel = pixel;
        self.pixel_seed = pixel_seed(pixel, self.seed);
        self.cached = 0;
    }

    /// Starts sample `sample` of the pixel: its own stream and points, exactly as
    /// `Sampler::new(kind, pixel, sample, seed)` (the kept block seeds are the pixel's).
    #[inline]
    pub fn start(&mut self, sample: u32) {
        self.rng = Rng::new(self.pixel, sample, self.seed);
        self.sample_rev = sample.reverse_bits();
    }

    pub fn kind(&self) -> SamplerKind {
        self.kind
    }

    /// The scramble seeds of block `block` (kept for the first [`CACHED_BLOCKS`]).
    #[inline]
    fn seeds(&mut self, block: u32) -> [u32; 3] {
        let b = block as usize;
        if b >= CACHED_BLOCKS {
            return block_scramble_seeds(self.pixel_seed, block);
        }
        if self.cached & (1 << b) == 0 {
            self.block_seeds[b] = block_scramble_seeds(self.pixel_seed, block);
            self.cached |= 1 << b;
        }
        self.block_seeds[b]
    }

    /// The 2D point of dimension block `block`.
    #[inline]
    pub fn get2d(&mut self, block: u32) -> Vec2 {
        match self.kind {
            SamplerKind::Sobol => {
                let (x, y) = point_from_seeds(self.seeds(block), self.sample_rev);
                Vec2::new(to_unit(x), to_unit(y))
            }
            SamplerKind::Independent => self.rng.uniform_vec2(),
        }
    }

    /// Queues block `block`'s 2D point as the next two uniforms of the path's stream, for the
    /// first draws of a free flight (its first exponential depth and first event choice);
    /// nothing for the independent sampler, whose stream draws them itself.
    #[inline]
    pub fn queue_on_stream(&mut self, block: u32) {
        if self.kind == SamplerKind::Sobol {
            let (x, y) = point_from_seeds(self.seeds(block), self.sample_rev);
            self.rng.queue_uniforms(x, y);
        }
    }

    /// A 1D value: the first coordinate of block `block`.
    #[inline]
    pub fn get1d(&mut self, block: u32) -> f32 {
        match self.kind {
            SamplerKind::Sobol => to_unit(x_from_seeds(self.seeds(block), self.sample_rev)),
            SamplerKind::Independent => self.rng.uniform_f32(),
        }
    }
}

/// One 1D decision of a [`Sampler`], bound to its block and drawn only when asked for, so the
/// independent sampler consumes its stream exactly where the decision is really taken (e.g.
/// Russian roulette draws nothing before `rr_depth`).
pub struct Decision<'a> {
    sampler: &'a mut Sampler,
    block: u32,
}

impl<'a> Decision<'a> {
    pub fn new(sampler: &'a mut Sampler, block: u32) -> Self {
        Decision { sampler, block }
    }

    /// The decision's uniform in `[0, 1)` (named like [`Rng::uniform_f32`] on purpose: code
    /// written against the RNG reads the same).
    #[inline]
    pub fn uniform_f32(&mut self) -> f32 {
        self.sampler.get1d(self.block)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::{chi2_test, sidak, SphereHistogram};
    use crate::sampling::warp::uniform_sphere;

    /// Every elementary interval of area `2^-k` holds exactly one of the `2^k` points.
    fn assert_net(points: &[(u32, u32)], k: u32, what: &str) {
        assert_eq!(points.len(), 1 << k);
        for j in 0..=k {
            // 2^j columns by 2^(k-j) rows; the cell of a point is its top j and k-j bits.
            let mut seen = vec![false; 1 << k];
            for &(x, y) in points {
                let cx = if j == 0 { 0 } else { x >> (32 - j) };
                let cy = if k - j == 0 { 0 } else { y >> (32 - (k - j)) };
                let cell = ((cx << (k - j)) | cy) as usize;
                assert!(
                    !seen[cell],
                    "{what}: k={k}, intervals 2^-{j} x 2^-{}: two points in cell {cell}",
                    k - j
                );
                seen[cell] = true;
            }
        }
    }

    #[test]
    fn unscrambled_sobol_matches_known_values() {
        // Sobol dimension 1 in index order (not Gray-code order): direction numbers 1/2, 3/4,
        // 5/8, so points 4..7 are 5/8, 5/8^1/2 = 1/8, 5/8^3/4 = 3/8, 5/8^1/4 = 7/8.
        let want = [0.0, 0.5, 0.75, 0.25, 0.625, 0.125, 0.375, 0.875];
        for (i, w) in want.iter().enumerate() {
            assert_eq!(sobol_dim1(i as u32) as f64 / 2f64.powi(32), *w, "i={i}");
        }
        assert_eq!(sobol_2d(1).0, 1 << 31);
    }

    #[test]
    fn owen_scramble_is_nested() {
        // Two values sharing their top n bits still share them after scrambling.
        let mut rng = Rng::new(1, 2, 3);
        for _ in 0..2000 {
            let (a, b, s) = (rng.next_u32(), rng.next_u32(), rng.next_u32());
            let n = (a ^ b).leading_zeros();
            let (sa, sb) = (owen_scramble(a, s), owen_scramble(b, s));
            assert!((sa ^ sb).leading_zeros() >= n.min(32));
            if n < 32 {
                // ... and the first differing bit still differs (a bijection per level).
                assert_eq!((sa ^ sb).leading_zeros(), n);
            }
        }
    }

    /// The first 2^k points, and aligned later runs of 2^k points (what a progressive pass
    /// continues with), are (0, k, 2)-nets after scrambling and shuffling, for k up to 10.
    #[test]
    fn scrambled_points_are_stratified() {
        for (pixel, block, seed) in [(0, 0, 0), (7, 1, 0), (12345, 13, 9), (99, 400, 1 << 31)] {
            for k in 0..=10u32 {
                for run in [0u32, 1, 5] {
                    let start = run << k;
                    let pts: Vec<_> = (start..start + (1 << k))
                        .map(|s| sobol_point_u32(pixel, s, block, seed))
                        .collect();
                    assert_net(&pts, k, &format!("pixel {pixel} block {block} run {run}"));
                }
            }
        }
    }

    /// Progressive passes (1, 2, 4, ... samples) read the same points as one pass.
    #[test]
    fn progressive_equals_all_at_once() {
        let all: Vec<_> = (0..64u32)
            .map(|s| Sampler::new(SamplerKind::Sobol, 42, s, 7).get2d(bounce_dim(2, DIM_SCATTER)))
            .collect();
        let mut passes = Vec::new();
        let mut s0 = 0u32;
        for n in [1u32, 2, 4, 8, 16, 16, 17] {
            for s in s0..(s0 + n).min(64) {
                passes.push(
                    Sampler::new(SamplerKind::Sobol, 42, s, 7).get2d(bounce_dim(2, DIM_SCATTER)),
                );
            }
            s0 += n;
        }
        assert_eq!(all, passes);
    }

    #[test]
    fn independent_is_the_rng_stream() {
        let mut s = Sampler::new(SamplerKind::Independent, 5, 6, 7);
        let mut r = Rng::new(5, 6, 7);
        assert_eq!(s.get2d(0), r.uniform_vec2());
        assert_eq!(s.get1d(3), r.uniform_f32());
        assert_eq!(s.rng.next_u32(), r.next_u32());
    }

    /// Blocks and pixels are decorrelated: the 1D values of two blocks of the same samples,
    /// and of two neighbouring pixels, have sample correlation within a few standard errors.
    #[test]
    fn blocks_and_pixels_are_decorrelated() {
        let n = 4096u32;
        let corr = |a: &dyn Fn(u32) -> f64, b: &dyn Fn(u32) -> f64| {
            let (mut sa, mut sb, mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for i in 0..n {
                let (x, y) = (a(i), b(i));
                sa += x;
                sb += y;
                sab += x * y;
                saa += x * x;
                sbb += y * y;
            }
            let nf = n as f64;
            let cov = sab / nf - sa * sb / nf / nf;
            cov / ((saa / nf - (sa / nf).powi(2)) * (sbb / nf - (sb / nf).powi(2))).sqrt()
        };
        // Under independence the correlation has standard error 1/sqrt(n) ~ 0.016; 5 sigma.
        let bound = 5.0 / (n as f64).sqrt();
        for (b0, b1) in [(1u32, 2u32), (2, 8), (0, 5)] {
            let c = corr(&|s| sobol_point(3, s, b0, 0).x as f64, &|s| {
                sobol_point(3, s, b1, 0).x as f64
            });
            assert!(c.abs() < bound, "blocks {b0},{b1}: correlation {c}");
        }
        let c = corr(&|s| sobol_point(3, s, 4, 0).x as f64, &|s| {
            sobol_point(4, s, 4, 0).x as f64
        });
        assert!(c.abs() < bound, "pixels 3,4: correlation {c}");
    }

    /// Chi-square of directions warped from the sampler's points to the uniform sphere over
    /// many pixels (independent scrambles) with 16 samples each (HG phase sampling from the
    /// same points: `tests/physics/sampling_phase.rs`). Stratification
    /// makes the counts *more* even than multinomial, so the test can only fail on a wrong
    /// distribution (a bias or a broken scramble), which is what it is for.
    #[test]
    fn warped_samples_pass_chi_square() {
        // One of a family of two with the HG test in tests/physics/sampling_phase.rs.
        let alpha = sidak(0.01, 2);
        let (pixels, spp) = (8192u32, 16u32);
        let n = (pixels * spp) as f64;

        let mut h = SphereHistogram::new(16, 32);
        for p in 0..pixels {
            for s in 0..spp {
                let u = Sampler::new(SamplerKind::Sobol, p, s, 3).get2d(bounce_dim(1, DIM_SCATTER));
                h.add(uniform_sphere(u));
            }
        }
        let expected = h.expected(n, &|_, _| 1.0 / (4.0 * std::f64::consts::PI), 1e-9);
        let out = chi2_test(&h.counts, &expected, 5.0);
        assert!(out.p_value >= alpha, "uniform sphere: {out:?}");
    }
}

#[cfg(test)]
mod fast_path_tests {
    use super::*;

    #[test]
    fn the_byte_tables_and_the_1d_path_equal_the_definitions() {
        let mut x = 0x1234_5678u32;
        for _ in 0..100_000 {
            x = pcg_hash(x);
            assert_eq!(sobol_dim1(x), sobol_dim1_bitwise(x));
            let (pixel, sample, block, seed) = (x % 4099, x >> 20, x % 61, x ^ 0x55);
            let p = sobol_point_u32(pixel, sample, block, seed);
            assert_eq!(
                x_from_pixel_seed(pixel_seed(pixel, seed), sample, block),
                p.0
            );
            let seeds = block_scramble_seeds(pixel_seed(pixel, seed), block);
            assert_eq!(point_from_seeds(seeds, sample.reverse_bits()), p);
        }
    }

    /// A sampler reused across a pixel's samples (its block seeds kept, past the cached
    /// blocks too), and moved on to other pixels ([`Sampler::set_pixel`], its kept seeds the
    /// last pixel's), draws exactly what a fresh sampler per sample draws, on both kinds.
    #[test]
    fn a_pixel_sampler_equals_fresh_samplers() {
        for kind in [SamplerKind::Sobol, SamplerKind::Independent] {
            let seed = 17;
            let mut reused = Sampler::for_pixel(kind, 4321, seed);
            for (pixel, sample) in [4321, 4321, 4321, 4321, 4321, 4321, 0, 0, 4322, 4321]
                .into_iter()
                .zip([0u32, 1, 2, 7, 1000, 3, 0, 5, 5, 2])
            {
                if pixel != reused.pixel {
                    reused.set_pixel(pixel);
                }
                reused.start(sample);
                let mut fresh = Sampler::new(kind, pixel, sample, seed);
                for block in [0u32, 5, 63, 64, 200, 5, 0] {
                    assert_eq!(reused.get2d(block), fresh.get2d(block));
                    assert_eq!(reused.get1d(block + 1), fresh.get1d(block + 1));
                    reused.queue_on_stream(block);
                    fresh.queue_on_stream(block);
                    assert_eq!(reused.rng.next_u32(), fresh.rng.next_u32());
                }
                let p = sobol_point_u32(pixel, sample, 9, seed);
                if kind == SamplerKind::Sobol {
                    assert_eq!(reused.get2d(9), Vec2::new(to_unit(p.0), to_unit(p.1)));
                }
            }
        }
    }
}
