//! Small geometric types shared by every module. glam does the linear algebra.
pub use glam::{Affine3A, DAffine3, DMat4, DVec3, Mat4, Vec3, Vec3A};

/// A ray `o + t * d`. `d` is not necessarily normalised: transforms keep the parameter `t`
/// meaningful across spaces (world and medium index space share `t`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub o: Vec3,
    pub d: Vec3,
}

impl Ray {
    pub fn new(o: Vec3, d: Vec3) -> Self {
        Self { o, d }
    }

    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.o + t * self.d
    }
}

/// Axis-aligned box, `min <= max` componentwise unless empty.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    pub fn new(min: Vec3, max: Vec3) -> Self {
        Self { min, max }
    }

    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    pub fn union_point(&self, p: Vec3) -> Aabb {
        Aabb {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// Slab test: the parameter interval of `ray` inside the box, clipped to `[t0, t1]`.
    /// Axis-parallel rays (including `-0.0` components) are handled by the IEEE infinities of
    /// `1/d`; a NaN from `0 * inf` (origin on a slab plane) is ignored by `max`/`min` ordering.
    pub fn intersect(&self, ray: &Ray, t0: f32, t1: f32) -> Option<(f32, f32)> {
        let inv_d = [0, 1, 2].map(|a| 1.0 / ray.d[a]);
        self.intersect_inv(ray.o, inv_d, t0, t1)
    }

    /// [`intersect`](Self::intersect) with `1 / d` precomputed (bit for bit the same).
    #[inline]
    pub fn intersect_inv(&self, o: Vec3, inv_d: [f32; 3], t0: f32, t1: f32) -> Option<(f32, f32)> {
        let mut t_near = t0;
        let mut t_far = t1;
        for (axis, inv) in inv_d.into_iter().enumerate() {
            let mut ta = (self.min[axis] - o[axis]) * inv;
            let mut tb = (self.max[axis] - o[axis]) * inv;
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
            }
            // `x > NaN` is false, so a NaN bound never shrinks the interval.
            if ta > t_near {
                t_near = ta;
            }
            if tb < t_far {
                t_far = tb;
            }
            if t_near > t_far {
                return None;
            }
        }
        Some((t_near, t_far))
    }
}

/// `floor(x)` as an integer for `x` already known to be finite and well inside `i64`.
/// Baseline x86-64 has no rounding instruction, so `f64::floor` is a libm call; truncation
/// with a correction for negative non-integers is a few instructions.
#[inline(always)]
pub fn floor_i64(x: f64) -> i64 {
    let t = x as i64;
    t - ((t as f64) > x) as i64
}

/// `floor(x)` as an `i32` for `x` not NaN, saturating as `as i32` does outside its range.
/// Baseline x86-64 has no rounding instruction, so `f32::floor` is a libm call (some fifteen
/// instructions and a call); truncation corrected for negative non-integers is four. Exact:
/// below 2^24 in magnitude `t as f32` is exact, and above it every float is an integer, so
/// `t == x` wherever the cast does not saturate.
#[inline(always)]
pub fn floor_i32(x: f32) -> i32 {
    debug_assert!(!x.is_nan());
    let t = x as i32;
    // Saturating: below -2^31 the cast gives i32::MIN, which is above `x`.
    t.saturating_sub(((t as f32) > x) as i32)
}

/// `v` truncated lane by lane, as floats and (x, y, z) as integers, for lanes in `0..2^24`
/// or NaN (which gives 0): clamped cell coordinates and counts. On x86-64 a `cvttps2dq` and a
/// `cvtdq2ps`: `as i32` lane by lane adds six instructions of saturation handling to each.
#[inline(always)]
pub fn trunc_xyz(v: glam::Vec4) -> (glam::Vec4, [i32; 3]) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{__m128, _mm_cvtepi32_ps, _mm_cvttps_epi32};
        // SAFETY: SSE2 is part of the x86-64 baseline, so every x86-64 CPU has it.
        let (f, i) = unsafe {
            let i = _mm_cvttps_epi32(__m128::from(v));
            (_mm_cvtepi32_ps(i), i)
        };
        let t: [i32; 4] = bytemuck::cast(i);
        (glam::Vec4::from(f), [t[0], t[1], t[2]])
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        // NaN to 0, as the saturating cast (and SSE's `max(NaN, 0)` before it) gives.
        let t = v.trunc();
        let t = glam::Vec4::select(t.cmpeq(t), t, glam::Vec4::ZERO);
        (t, [t.x as i32, t.y as i32, t.z as i32])
    }
}

/// Rec. 709 luminance of linear RGB (the weights of sRGB primaries).
#[inline]
pub fn luminance(c: glam::Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// `num / den` per channel, 0 where `den` is not positive.
#[inline]
pub fn per_channel_ratio(num: Vec3, den: Vec3) -> Vec3 {
    Vec3::select(den.cmpgt(Vec3::ZERO), num / den, Vec3::ZERO)
}

#[cfg(test)]
mod tests {
    use super::{floor_i32, floor_i64};

    /// Values where a truncating floor goes wrong if it goes wrong anywhere (each also
    /// negated): zeros, halves, integers, values a hair off an integer, the smallest
    /// subnormal, and values around 2^24 and 2^31.
    const FLOOR_EDGES: [f32; 12] = [
        0.0,
        0.5,
        1.0,
        7.999_999,
        8.0,
        8.000_001,
        1e-30,
        1.4e-45,
        16_777_215.5,
        16_777_217.0,
        2_147_483_520.0,
        2_147_483_648.0,
    ];

    #[test]
    fn floor_i64_matches_f64_floor() {
        let xs = FLOOR_EDGES.map(f64::from).into_iter().chain([1e15 + 0.5]);
        for x in xs.flat_map(|x| [x, -x]) {
            assert_eq!(floor_i64(x), x.floor() as i64, "floor({x})");
        }
    }

    #[test]
    fn floor_i32_matches_f32_floor() {
        // The last edge is 2^31 itself: only its negation is inside `i32`.
        let mut xs: Vec<f32> = FLOOR_EDGES[..11].iter().flat_map(|&x| [x, -x]).collect();
        xs.push(-2_147_483_648.0);
        // Bit patterns spread over every finite magnitude below 2^31, both signs.
        let mut bits = 0u32;
        for _ in 0..1 << 20 {
            let x = f32::from_bits(bits & 0x4eff_ffff);
            xs.extend([x, -x]);
            bits = bits.wrapping_add(0x9E37_79B9);
        }
        for x in xs {
            assert_eq!(floor_i32(x), x.floor() as i32, "floor({x:e})");
        }
        // Saturating outside i32, as `as i32`.
        assert_eq!(floor_i32(3e9), i32::MAX);
        assert_eq!(floor_i32(-3e9), i32::MIN);
        assert_eq!(floor_i32(f32::INFINITY), i32::MAX);
        assert_eq!(floor_i32(f32::NEG_INFINITY), i32::MIN);
    }
}
