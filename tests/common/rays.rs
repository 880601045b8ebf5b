//! Random rays for the accelerator tests: Brume's deterministic generator (SplitMix64), so a
//! failure reproduces from its seed.
use brume::volume::check::SplitMix64;
use glam::Vec3;

/// SplitMix64 state, drawing `f32`s in [0, 1) with 24 bits.
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> f32 {
        let mut s = SplitMix64(self.0);
        let z = s.next_u64();
        self.0 = s.0;
        (z >> 40) as f32 / (1u64 << 24) as f32
    }

    /// A uniform point in the box [lo, hi].
    pub fn in_box(&mut self, lo: Vec3, hi: Vec3) -> Vec3 {
        lo + (hi - lo) * Vec3::new(self.next(), self.next(), self.next())
    }

    /// A uniform point in the cube [lo, hi]^3.
    pub fn vec(&mut self, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(self.next(), self.next(), self.next()) * (hi - lo) + Vec3::splat(lo)
    }

    /// A uniform direction on the sphere.
    pub fn direction(&mut self) -> Vec3 {
        let z = 1.0 - 2.0 * self.next();
        let phi = std::f32::consts::TAU * self.next();
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }
}
