//! The lane layout shared by the four-wide ([`super::small`]) and eight-wide
//! ([`super::small_avx`]) small-mesh tests: triangles as rows of lanes, and the fold of a
//! batch's hit lanes into the closest hit.
use glam::Vec3A;

use super::Hit;

/// Each triangle's first corner and two edges by coordinate and lane, `N` triangles to a
/// batch (`[v0, e1, e2][axis][lane]`): the same subtractions as `intersect_triangle`'s, and
/// all-zero padding lanes (a zero determinant: never hit).
pub(super) fn lane_rows<const N: usize>(triangles: &[[Vec3A; 3]]) -> Vec<[[[f32; N]; 3]; 3]> {
    triangles
        .chunks(N)
        .map(|chunk| {
            let mut rows = [[[0.0; N]; 3]; 3];
            for (lane, v) in chunk.iter().enumerate() {
                let e1 = v[1] - v[0];
                let e2 = v[2] - v[0];
                for a in 0..3 {
                    rows[0][a][lane] = v[0][a];
                    rows[1][a][lane] = e1[a];
                    rows[2][a][lane] = e2[a];
                }
            }
            rows
        })
        .collect()
}

/// Folds the hit lanes of one batch (bits of `lanes`; `[t, b1, b2]` by lane) into `best`, the
/// batch's first triangle being `first`: lowest lane first and only a strictly nearer hit
/// replaces the best, so ties go to the lowest triangle index.
#[inline(always)]
pub(super) fn take_hits<const N: usize>(
    best: &mut Option<Hit>,
    mut lanes: u32,
    first: usize,
    [t, b1, b2]: &[[f32; N]; 3],
) {
    while lanes != 0 {
        let lane = lanes.trailing_zeros() as usize;
        lanes &= lanes - 1;
        if best.map_or(true, |h| t[lane] < h.t) {
            *best = Some(Hit {
                t: t[lane],
                triangle: (first + lane) as u32,
                b1: b1[lane],
                b2: b2[lane],
            });
        }
    }
}
