//! The small-mesh closest hit eight triangles at a time, with AVX (x86-64, detected at run
//! time): the same Moller-Trumbore lanes as the four-wide batches of [`super::small`], in
//! half as many batches. On the example scenes' 12-14-triangle meshes (a box around the
//! medium and a floor) the four-wide test is the largest single cost of a sample after the
//! medium (15-22 % of the Cornell smoke's and the smoke tank's instructions, callgrind).
//!
//! Bit for bit the scalar test's: every lane runs the products and sums of
//! [`super::intersect_triangle`] in the same order (AVX's `vmulps`, `vaddps`, `vsubps` and
//! `vdivps` round as SSE's do, and nothing here fuses a multiply-add), each comparison has the
//! truth table of the four-wide one (ordered `>=`, `<=` and `<`, unordered `!=`), and hits are
//! taken in increasing triangle order, so ties go to the lowest index.
use std::arch::x86_64::*;

use glam::Vec3A;

use super::Hit;
use crate::math::Ray;

/// Three coordinates of eight triangles' first corners and edges, one lane a triangle;
/// aligned for 256-bit loads. Padding lanes are all zero (a zero determinant: no hit).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(super) struct Batch8 {
    v0: [[f32; 8]; 3],
    e1: [[f32; 8]; 3],
    e2: [[f32; 8]; 3],
}

/// Whether this CPU runs [`closest_hit`].
pub(super) fn available() -> bool {
    is_x86_feature_detected!("avx")
}

/// The triangles eight to a batch.
pub(super) fn batches(triangles: &[[Vec3A; 3]]) -> Vec<Batch8> {
    super::lanes::lane_rows::<8>(triangles)
        .into_iter()
        .map(|[v0, e1, e2]| Batch8 { v0, e1, e2 })
        .collect()
}

// The helpers carry the feature themselves (no closures: a closure does not inherit it), so
// that they and the intrinsics inline into `closest_hit`.

/// `p q - r s`, lane-wise.
#[target_feature(enable = "avx")]
#[inline]
unsafe fn sub_mul(p: __m256, q: __m256, r: __m256, s: __m256) -> __m256 {
    _mm256_sub_ps(_mm256_mul_ps(p, q), _mm256_mul_ps(r, s))
}

/// Lane-wise `a x b` as glam's `Vec3A::cross`: x = a.y b.z - b.y a.z, and so on.
#[target_feature(enable = "avx")]
#[inline]
unsafe fn cross(a: [__m256; 3], b: [__m256; 3]) -> [__m256; 3] {
    [
        sub_mul(a[1], b[2], b[1], a[2]),
        sub_mul(a[2], b[0], b[2], a[0]),
        sub_mul(a[0], b[1], b[0], a[1]),
    ]
}

/// Lane-wise `a . b` as glam's `Vec3A::dot`: (x x' + y y') + z z'.
#[target_feature(enable = "avx")]
#[inline]
unsafe fn dot(a: [__m256; 3], b: [__m256; 3]) -> __m256 {
    _mm256_add_ps(
        _mm256_add_ps(_mm256_mul_ps(a[0], b[0]), _mm256_mul_ps(a[1], b[1])),
        _mm256_mul_ps(a[2], b[2]),
    )
}

/// Three rows of eight lanes.
#[target_feature(enable = "avx")]
#[inline]
unsafe fn load(a: &[[f32; 8]; 3]) -> [__m256; 3] {
    [
        _mm256_load_ps(a[0].as_ptr()),
        _mm256_load_ps(a[1].as_ptr()),
        _mm256_load_ps(a[2].as_ptr()),
    ]
}

/// Three coordinates, each in every lane.
#[target_feature(enable = "avx")]
#[inline]
unsafe fn splat(v: crate::math::Vec3) -> [__m256; 3] {
    [
        _mm256_set1_ps(v.x),
        _mm256_set1_ps(v.y),
        _mm256_set1_ps(v.z),
    ]
}

/// Lane-wise AND of two masks.
#[target_feature(enable = "avx")]
#[inline]
unsafe fn and(x: __m256, y: __m256) -> __m256 {
    _mm256_and_ps(x, y)
}

/// The nearest hit with `t` in `[t_min, t_max]` among `batches`, ties to the lowest triangle
/// index (as `TriangleBatches::closest_hit`).
///
/// # Safety
/// The CPU must support AVX ([`available`]).
#[target_feature(enable = "avx")]
pub(super) unsafe fn closest_hit(
    batches: &[Batch8],
    ray: &Ray,
    t_min: f32,
    t_max: f32,
) -> Option<Hit> {
    let (o, d) = (splat(ray.o), splat(ray.d));
    let (t_lo, t_hi) = (_mm256_set1_ps(t_min), _mm256_set1_ps(t_max));
    let zero = _mm256_setzero_ps();
    let one = _mm256_set1_ps(1.0);
    let inf = _mm256_set1_ps(f32::INFINITY);
    let abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fff_ffff));
    let mut best: Option<Hit> = None;
    for (k, b) in batches.iter().enumerate() {
        let (v0, e1, e2) = (load(&b.v0), load(&b.e1), load(&b.e2));
        // Moller-Trumbore as in intersect_triangle, with every comparison computed.
        let p = cross(d, e2);
        let det = dot(e1, p);
        let inv = _mm256_div_ps(one, det);
        let s = [
            _mm256_sub_ps(o[0], v0[0]),
            _mm256_sub_ps(o[1], v0[1]),
            _mm256_sub_ps(o[2], v0[2]),
        ];
        let b1 = _mm256_mul_ps(dot(s, p), inv);
        let q = cross(s, e1);
        let b2 = _mm256_mul_ps(dot(d, q), inv);
        let t = _mm256_mul_ps(dot(e2, q), inv);
        let mut hit = _mm256_cmp_ps::<_CMP_NEQ_UQ>(det, zero);
        hit = and(hit, _mm256_cmp_ps::<_CMP_LT_OQ>(and(det, abs_mask), inf));
        hit = and(hit, _mm256_cmp_ps::<_CMP_GE_OQ>(b1, zero));
        hit = and(hit, _mm256_cmp_ps::<_CMP_LE_OQ>(b1, one));
        hit = and(hit, _mm256_cmp_ps::<_CMP_GE_OQ>(b2, zero));
        hit = and(hit, _mm256_cmp_ps::<_CMP_LE_OQ>(_mm256_add_ps(b1, b2), one));
        hit = and(hit, _mm256_cmp_ps::<_CMP_GE_OQ>(t, t_lo));
        hit = and(hit, _mm256_cmp_ps::<_CMP_LE_OQ>(t, t_hi));
        let lanes = _mm256_movemask_ps(hit) as u32;
        if lanes == 0 {
            continue;
        }
        let mut lane_hits = [[0.0f32; 8]; 3];
        _mm256_storeu_ps(lane_hits[0].as_mut_ptr(), t);
        _mm256_storeu_ps(lane_hits[1].as_mut_ptr(), b1);
        _mm256_storeu_ps(lane_hits[2].as_mut_ptr(), b2);
        super::lanes::take_hits(&mut best, lanes, 8 * k, &lane_hits);
    }
    best
}
