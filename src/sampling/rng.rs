//! Random number streams that the WGSL integrator reproduces bit for bit.
//!
//! WGSL has no 64-bit integers, so the generator uses only wrapping `u32` arithmetic:
//! PCG-RXS-M-XS-32 (O'Neill 2014), the 32-bit PCG variant that Jarzynski & Olano (2020,
//! "Hash Functions for GPU Rendering", JCGT 9(3)) recommend both as a hash and as a generator.
//!
//! Construction (mirrored by `shaders/common/rng.wgsl`; keep the two in lockstep):
//!
//! ```text
//! pcg_hash(x):  s = x * 747796405 + 2891336453
//!               w = ((s >> ((s >> 28) + 4)) ^ s) * 277803737
//!               return (w >> 22) ^ w
//! Rng::new(pixel, sample, seed):
//!     h     = pcg_hash(pcg_hash(pcg_hash(seed) ^ pixel) ^ sample)
//!     state = h
//!     inc   = (pcg_hash(h ^ 0x9E3779B9) << 1) | 1      // odd: selects one of 2^31 LCG streams
//!     next_u32()                                      // discard one output
//! next_u32():   old = state; state = old * 747796405 + inc; return rxs_m_xs(old)
//! uniform_f32(): (next_u32() >> 8) as f32 * 2^-24     // in [0, 1), exact, never 1
//! ```
//!
//! Each (pixel, sample, seed) starts at a hashed position AND on a hashed LCG increment, so two
//! streams are different sequences rather than offsets along one cycle. The hash chain is a
//! bijection in its last argument, so for a fixed (seed, pixel) distinct samples never share a
//! start state. Each stream has period 2^32, far beyond the few hundred draws of one path.
//! All arithmetic is wrapping `u32`, exactly WGSL's `u32` semantics.

/// Multiplier of the 32-bit PCG LCG (O'Neill 2014, table of good 32-bit multipliers).
pub const PCG_MULT: u32 = 747_796_405;
/// Default increment of the 32-bit PCG LCG, used by [`pcg_hash`].
pub const PCG_INC: u32 = 2_891_336_453;
/// Multiplier of the RXS-M-XS output permutation.
pub const RXS_M_XS_MULT: u32 = 277_803_737;
/// Golden-ratio constant decorrelating the increment hash from the state hash.
pub const INC_SALT: u32 = 0x9E37_79B9;

/// The RXS-M-XS output permutation of PCG: a bijection on `u32`.
#[inline]
fn rxs_m_xs(s: u32) -> u32 {
    let w = ((s >> ((s >> 28) + 4)) ^ s).wrapping_mul(RXS_M_XS_MULT);
    (w >> 22) ^ w
}

/// `pcg_hash` of Jarzynski & Olano (2020): one LCG step followed by RXS-M-XS. A bijection.
#[inline]
pub fn pcg_hash(x: u32) -> u32 {
    rxs_m_xs(x.wrapping_mul(PCG_MULT).wrapping_add(PCG_INC))
}

/// A PCG-RXS-M-XS-32 stream; see the module docs for the construction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rng {
    state: u32,
    /// Odd LCG increment: which of the 2^31 streams this generator walks.
    inc: u32,
    /// Uniforms handed out by the next `uniform_f32` calls before the stream resumes (24-bit
    /// numerators, `queued[2 - n_queued]` first): how a sampler's stratified point reaches
    /// the first draws of a free flight without every tracker taking a sampler.
    queued: [u32; 2],
    n_queued: u32,
}

impl Rng {
    /// The stream for one (pixel, sample, seed) triple.
    pub fn new(pixel_index: u32, sample_index: u32, seed: u32) -> Self {
        let h = pcg_hash(pcg_hash(pcg_hash(seed) ^ pixel_index) ^ sample_index);
        let mut rng = Rng {
            state: h,
            inc: (pcg_hash(h ^ INC_SALT) << 1) | 1,
            queued: [0; 2],
            n_queued: 0,
        };
        // The first output is a function of `h` alone; discarding it makes the first value
        // used depend on the increment too.
        rng.next_u32();
        rng
    }

    /// The raw state `(state, inc)`, for tests that pin the WGSL mirror.
    pub fn raw(&self) -> (u32, u32) {
        (self.state, self.inc)
    }

    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(PCG_MULT).wrapping_add(self.inc);
        rxs_m_xs(old)
    }

    /// Uniform in `[0, 1)`: the top 24 bits scaled by 2^-24, so every value is exactly
    /// representable in f32 and 1.0 is never returned (`1 - u` is never 0, `ln(1 - u)` finite).
    #[inline]
    pub fn uniform_f32(&mut self) -> f32 {
        let v = if self.n_queued > 0 {
            self.n_queued -= 1;
            self.queued[1 - self.n_queued as usize]
        } else {
            self.next_u32() >> 8
        };
        v as f32 * (1.0 / 16_777_216.0)
    }

    /// The next two `uniform_f32` calls return `a` then `b` (32-bit values, of which the top
    /// 24 bits are kept, as for the stream's own outputs); the stream does not advance for
    /// them. See [`Rng::clear_queue`].
    #[inline]
    pub fn queue_uniforms(&mut self, a: u32, b: u32) {
        self.queued = [a >> 8, b >> 8];
        self.n_queued = 2;
    }

    /// Makes `x` (in `[0, 1)`, kept to its top 24 bits) the next `uniform_f32`, ahead of a
    /// value still queued: how a thinning decision hands its uniform on
    /// (`volume::tracking::thin`). Nothing is pushed when two values are queued already.
    #[inline]
    pub fn push_front(&mut self, x: f32) {
        if self.n_queued < 2 {
            // With `n` queued, `uniform_f32` reads `queued[1 - n]` first once there are `n + 1`.
            self.queued[1 - self.n_queued as usize] = ((x * 16_777_216.0) as u32).min(0x00FF_FFFF);
            self.n_queued += 1;
        }
    }

    /// Whether the next `uniform_f32` is a queued value (a sampler's point, or one handed on)
    /// rather than the stream's own.
    #[inline]
    pub fn has_queued(&self) -> bool {
        self.n_queued > 0
    }

    /// Drops queued values that were not drawn (so they never reach an unrelated decision).
    #[inline]
    pub fn clear_queue(&mut self) {
        self.n_queued = 0;
    }

    /// Two uniforms, drawn in order `x` then `y`.
    #[inline]
    pub fn uniform_vec2(&mut self) -> glam::Vec2 {
        let x = self.uniform_f32();
        let y = self.uniform_f32();
        glam::Vec2::new(x, y)
    }
}
