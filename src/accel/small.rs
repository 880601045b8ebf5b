//! Closest hits on small meshes: every triangle tested, four at a time (eight with AVX:
//! [`super::small_avx`]).
//!
//! Most volume scenes have a handful of triangles: a box around the medium (a null interface
//! or glass), a ground plane, a backdrop. There the CWBVH costs more than the triangles: one
//! node's eight quantised child boxes, a traversal stack cleared per ray and a bit loop per hit
//! leaf, 55-110 ns a closest hit for rays from inside a closed 12-triangle mesh, where testing
//! every triangle four at a time takes 20-40 ns. [`SMALL_MESH_TRIANGLES`] says where the BVH
//! starts to pay.
//!
//! Each lane computes exactly what [`super::intersect_triangle`] computes (the same products
//! and sums in the same order; glam's SSE2 `cross` and `dot` round as written here, with no
//! fused multiply-add), so a hit's `t`, `b1` and `b2` are those of the scalar test bit for bit,
//! and ties go to the lowest triangle index, as in a brute-force loop.
use glam::{Vec3A, Vec4};

use super::lanes::{lane_rows, take_hits};
use super::Hit;
use crate::math::Ray;

/// Meshes of at most this many triangles are hit by testing them all. On random rays from
/// inside closed spheres of 12-256 triangles, four-lane all-triangle testing is 2.0-2.7x
/// faster than the CWBVH up to 24 triangles, 1.35x at 36, 1.1x at 64, and slower from 96.
pub const SMALL_MESH_TRIANGLES: usize = 32;

/// Three coordinates of four triangles' corners and edges, one lane a triangle.
#[derive(Clone, Copy, Debug)]
pub(super) struct Batch {
    v0: [Vec4; 3],
    e1: [Vec4; 3],
    e2: [Vec4; 3],
}

/// How many triangles a small mesh's closest-hit test takes at a time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SmallMeshLanes {
    /// SSE (every x86-64 CPU) or glam's portable `Vec4` elsewhere.
    Four,
    /// AVX, where the CPU has it (detected at run time).
    Eight,
}

impl SmallMeshLanes {
    /// Whether this CPU runs `self`.
    pub fn available(self) -> bool {
        match self {
            SmallMeshLanes::Four => true,
            #[cfg(target_arch = "x86_64")]
            SmallMeshLanes::Eight => super::small_avx::available(),
            #[cfg(not(target_arch = "x86_64"))]
            SmallMeshLanes::Eight => false,
        }
    }

    /// The widest this CPU runs for a mesh of `n` triangles: eight lanes pay only where they
    /// halve the batches (more than four triangles).
    pub fn best(n: usize) -> Self {
        if n > 4 && SmallMeshLanes::Eight.available() {
            SmallMeshLanes::Eight
        } else {
            SmallMeshLanes::Four
        }
    }
}

/// A small mesh laid out for four- or eight-wide tests. Padding lanes are degenerate (zero
/// edges, so a zero determinant), which the test rejects.
#[derive(Clone, Debug)]
pub(super) enum TriangleBatches {
    Four(Vec<Batch>),
    /// Built only where [`SmallMeshLanes::Eight`] is available.
    #[cfg(target_arch = "x86_64")]
    Eight(Vec<super::small_avx::Batch8>),
}

#[inline(always)]
fn cross(a: [Vec4; 3], b: [Vec4; 3]) -> [Vec4; 3] {
    // glam's Vec3A::cross, lane-wise: x = a.y b.z - b.y a.z, and so on.
    [
        a[1] * b[2] - b[1] * a[2],
        a[2] * b[0] - b[2] * a[0],
        a[0] * b[1] - b[0] * a[1],
    ]
}

#[inline(always)]
fn dot(a: [Vec4; 3], b: [Vec4; 3]) -> Vec4 {
    // glam's Vec3A::dot, lane-wise: (x x' + y y') + z z'.
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

impl TriangleBatches {
    /// `lanes` wide where this CPU runs it, else four wide.
    pub(super) fn new(triangles: &[[Vec3A; 3]], lanes: SmallMeshLanes) -> Self {
        #[cfg(target_arch = "x86_64")]
        if lanes == SmallMeshLanes::Eight && lanes.available() {
            return TriangleBatches::Eight(super::small_avx::batches(triangles));
        }
        let _ = lanes; // Read only on x86-64: four lanes are all there is elsewhere.
        let batches = lane_rows::<4>(triangles)
            .into_iter()
            .map(|[v0, e1, e2]| Batch {
                v0: v0.map(Vec4::from_array),
                e1: e1.map(Vec4::from_array),
                e2: e2.map(Vec4::from_array),
            })
            .collect();
        TriangleBatches::Four(batches)
    }

    /// The lanes these batches are tested with.
    pub(super) fn lanes(&self) -> SmallMeshLanes {
        match self {
            TriangleBatches::Four(_) => SmallMeshLanes::Four,
            #[cfg(target_arch = "x86_64")]
            TriangleBatches::Eight(_) => SmallMeshLanes::Eight,
        }
    }

    /// The nearest hit with `t` in `[t_min, t_max]`, ties to the lowest triangle index.
    #[inline]
    pub(super) fn closest_hit(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        match self {
            TriangleBatches::Four(batches) => closest_hit4(batches, ray, t_min, t_max),
            // SAFETY: `Eight` is built only where the CPU has AVX (`new`).
            #[cfg(target_arch = "x86_64")]
            TriangleBatches::Eight(batches) => unsafe {
                super::small_avx::closest_hit(batches, ray, t_min, t_max)
            },
        }
    }
}

/// The four-wide test: the nearest hit with `t` in `[t_min, t_max]`, ties to the lowest
/// triangle index.
#[inline]
fn closest_hit4(batches: &[Batch], ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
    // Written out: `[0, 1, 2].map(..)` here was left as a call to `try_map` (46 instructions a
    // sample on the fire, callgrind).
    let splat = |v: crate::math::Vec3| [Vec4::splat(v.x), Vec4::splat(v.y), Vec4::splat(v.z)];
    let (o, d) = (splat(ray.o), splat(ray.d));
    let (t_lo, t_hi) = (Vec4::splat(t_min), Vec4::splat(t_max));
    let mut best: Option<Hit> = None;
    for (k, b) in batches.iter().enumerate() {
        // Moller-Trumbore as in intersect_triangle, with every comparison computed.
        let p = cross(d, b.e2);
        let det = dot(b.e1, p);
        let inv = Vec4::ONE / det;
        let s = [o[0] - b.v0[0], o[1] - b.v0[1], o[2] - b.v0[2]];
        let b1 = dot(s, p) * inv;
        let q = cross(s, b.e1);
        let b2 = dot(d, q) * inv;
        let t = dot(b.e2, q) * inv;
        let hit = det.cmpne(Vec4::ZERO)
            & det.is_finite_mask()
            & b1.cmpge(Vec4::ZERO)
            & b1.cmple(Vec4::ONE)
            & b2.cmpge(Vec4::ZERO)
            & (b1 + b2).cmple(Vec4::ONE)
            & t.cmpge(t_lo)
            & t.cmple(t_hi);
        let lanes = hit.bitmask();
        if lanes != 0 {
            let lane_hits = [t.to_array(), b1.to_array(), b2.to_array()];
            take_hits(&mut best, lanes, 4 * k, &lane_hits);
        }
    }
    best
}
