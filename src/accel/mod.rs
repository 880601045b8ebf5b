//! Ray queries against the scene's triangles: an 8-wide compressed BVH from `obvhs`
//! (Ylitie et al. 2017, "Efficient incoherent ray traversal on GPUs through compressed wide
//! BVHs"), built once and traversed on the CPU; its 80-byte nodes are ready for GPU upload.
//! Meshes of at most [`SMALL_MESH_TRIANGLES`] triangles answer closest hits on the CPU by
//! testing every triangle, four or eight at a time (`small`), which is faster there; the GPU
//! traverses the CWBVH whatever the size. [`embree`] answers the same closest hits through
//! Intel Embree instead ([`Accel::Embree`]).
use std::time::Duration;

use glam::Vec3A;
use obvhs::cwbvh::{builder::build_cwbvh, CwBvh};
use obvhs::BvhBuildParams;

use crate::math::Ray;

pub mod embree;
pub mod instanced;
mod lanes;
mod small;
#[cfg(target_arch = "x86_64")]
mod small_avx;
use small::TriangleBatches;
pub use small::{SmallMeshLanes, SMALL_MESH_TRIANGLES};

/// Static triangles from which [`Accel::Auto`] takes Embree: from about this size on, random
/// triangle soups trace camera, shadow and bounce rays faster through Embree than through the
/// BVH, and the gap grows with the size (`brume bench accel --sweep`); below it the BVH, with
/// its all-triangle tests of the smallest meshes, is as fast or faster.
pub const EMBREE_FROM_TRIANGLES: usize = 300;

/// The CPU's closest-hit accelerator for static triangles. The GPU always traverses the
/// CWBVH.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Accel {
    /// Embree from [`EMBREE_FROM_TRIANGLES`] static triangles on, else the BVH; the BVH also
    /// where Embree cannot be built.
    #[default]
    Auto,
    /// The obvhs CWBVH (all-triangle tests on small meshes).
    Bvh,
    /// Intel Embree 3 chooses the triangle; Brume's triangle test gives the hit.
    Embree,
}

impl Accel {
    pub fn name(self) -> &'static str {
        match self {
            Accel::Auto => "auto",
            Accel::Bvh => "bvh",
            Accel::Embree => "embree",
        }
    }

    /// The accelerator this choice means for `triangles` static triangles: [`Accel::Auto`]
    /// resolved by [`EMBREE_FROM_TRIANGLES`], the others as they are.
    pub fn for_triangles(self, triangles: usize) -> Accel {
        match self {
            Accel::Auto if triangles >= EMBREE_FROM_TRIANGLES => Accel::Embree,
            Accel::Auto => Accel::Bvh,
            other => other,
        }
    }
}

/// A closest-hit record.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit (in units of the ray's `d`).
    pub t: f32,
    /// Index of the triangle hit, in the caller's triangle order.
    pub triangle: u32,
    /// Barycentric weight of the triangle's second vertex.
    pub b1: f32,
    /// Barycentric weight of the triangle's third vertex.
    pub b2: f32,
}

/// Ray-triangle intersection (Moller-Trumbore), the single routine every query uses, so the
/// BVH and brute force agree exactly. Returns `(t, b1, b2)` for `t` in `[t_min, t_max]`.
#[inline]
pub fn intersect_triangle(
    ray: &Ray,
    v: &[Vec3A; 3],
    t_min: f32,
    t_max: f32,
) -> Option<(f32, f32, f32)> {
    let o = Vec3A::from(ray.o);
    let d = Vec3A::from(ray.d);
    let e1 = v[1] - v[0];
    let e2 = v[2] - v[0];
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - v[0];
    let b1 = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&b1) {
        return None;
    }
    let q = s.cross(e1);
    let b2 = d.dot(q) * inv;
    if b2 < 0.0 || b1 + b2 > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    (t >= t_min && t <= t_max).then_some((t, b1, b2))
}

/// Slack on every side of each triangle's box, relative to the largest coordinate magnitude.
/// obvhs's slab test gives a node flat along an axis (a flat or axis-aligned mesh) a slab of
/// no thickness, where one rounding in its other slabs misses a hit on a child box's edge;
/// boxes grown by about a hundred ulps of the largest coordinate keep such hits inside.
const BOX_SLACK: f32 = 1e-5;

/// The triangles' boxes, each grown by [`BOX_SLACK`] so that none is flat.
fn padded_boxes(triangles: &[[Vec3A; 3]]) -> Vec<obvhs::aabb::Aabb> {
    let scale = triangles
        .iter()
        .flatten()
        .flat_map(|v| v.abs().to_array())
        .filter(|x| x.is_finite())
        .fold(0.0f32, f32::max);
    let pad = Vec3A::splat(BOX_SLACK * scale.max(1e-30));
    triangles
        .iter()
        .map(|t| {
            let (lo, hi) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
            obvhs::aabb::Aabb::new(lo - pad, hi + pad)
        })
        .collect()
}

/// A BVH over world-space triangles.
pub struct TriangleBvh {
    /// `None` when there are no triangles (every query misses).
    bvh: Option<CwBvh>,
    /// Triangle corners in the caller's order.
    triangles: Vec<[Vec3A; 3]>,
    /// The triangles four to a batch, for closest hits on small meshes (`None` above
    /// [`SMALL_MESH_TRIANGLES`]).
    small: Option<TriangleBatches>,
}

impl std::fmt::Debug for TriangleBvh {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let nodes = self.bvh.as_ref().map_or(0, |b| b.nodes.len());
        write!(
            f,
            "TriangleBvh {{ triangles: {}, nodes: {nodes} }}",
            self.triangles.len()
        )
    }
}

impl TriangleBvh {
    /// Builds over `triangles` (corner positions). Degenerate triangles are allowed; they
    /// are never hit. A small mesh is tested as wide as this CPU allows
    /// ([`SmallMeshLanes::best`]).
    pub fn build(triangles: Vec<[Vec3A; 3]>) -> Self {
        let lanes = SmallMeshLanes::best(triangles.len());
        Self::build_with(triangles, lanes)
    }

    /// [`Self::build`] with a small mesh tested `lanes` wide where this CPU runs that, else four
    /// wide (for tests of both widths; [`Self::small_lanes`] says which).
    pub fn build_with(triangles: Vec<[Vec3A; 3]>, lanes: SmallMeshLanes) -> Self {
        if triangles.is_empty() {
            return Self {
                bvh: None,
                triangles,
                small: None,
            };
        }
        // No spatial splits: every triangle then sits in exactly one leaf, which keeps
        // `primitive_indices` a permutation (simpler GPU layout and validation).
        let params = BvhBuildParams {
            pre_split: false,
            ..BvhBuildParams::medium_build()
        };
        let bvh = build_cwbvh(&padded_boxes(&triangles), params, &mut Duration::default());
        let small = (triangles.len() <= SMALL_MESH_TRIANGLES)
            .then(|| TriangleBatches::new(&triangles, lanes));
        Self {
            bvh: Some(bvh),
            triangles,
            small,
        }
    }

    /// How this small mesh's closest hits test its triangles, `None` above
    /// [`SMALL_MESH_TRIANGLES`] (the BVH answers) or with no triangles.
    pub fn small_lanes(&self) -> Option<SmallMeshLanes> {
        self.small.as_ref().map(TriangleBatches::lanes)
    }

    /// Triangle corners in the caller's order.
    pub fn triangles(&self) -> &[[Vec3A; 3]] {
        &self.triangles
    }

    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.triangles.len()
    }

    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// Bytes held: the nodes, the primitive indices and the triangle corners (the small-mesh
    /// batches, at most [`SMALL_MESH_TRIANGLES`] triangles, left out).
    pub fn memory_bytes(&self) -> usize {
        self.bvh.as_ref().map_or(0, |b| {
            std::mem::size_of_val(&b.nodes[..]) + std::mem::size_of_val(&b.primitive_indices[..])
        }) + std::mem::size_of_val(&self.triangles[..])
    }

    /// The obvhs BVH (nodes and primitive order) for GPU upload, `None` when empty.
    pub fn cwbvh(&self) -> Option<&CwBvh> {
        self.bvh.as_ref()
    }

    fn obvhs_ray(ray: &Ray, t_min: f32, t_max: f32) -> obvhs::ray::Ray {
        obvhs::ray::Ray::new(ray.o.into(), ray.d.into(), t_min, t_max)
    }

    /// The nearest hit with `t` in `[t_min, t_max]`. On a small mesh, ties go to the lowest
    /// triangle index; through the BVH, to the first leaf reached.
    pub fn closest_hit(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        let bvh = self.bvh.as_ref()?;
        if !ray.o.is_finite() || !ray.d.is_finite() {
            return None;
        }
        if let Some(small) = &self.small {
            return small.closest_hit(ray, t_min, t_max);
        }
        let mut best: Option<Hit> = None;
        let mut hit = obvhs::ray::RayHit::none();
        bvh.ray_traverse(Self::obvhs_ray(ray, t_min, t_max), &mut hit, |r, id| {
            let tri = bvh.primitive_indices[id] as usize;
            match intersect_triangle(ray, &self.triangles[tri], r.tmin, r.tmax) {
                Some((t, b1, b2)) => {
                    best = Some(Hit {
                        t,
                        triangle: tri as u32,
                        b1,
                        b2,
                    });
                    t
                }
                None => f32::INFINITY,
            }
        });
        best
    }

    /// Whether any triangle is hit with `t` in `[t_min, t_max]` (shadow rays).
    pub fn any_hit(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        let Some(bvh) = self.bvh.as_ref() else {
            return false;
        };
        if !ray.o.is_finite() || !ray.d.is_finite() {
            return false;
        }
        !bvh.ray_traverse_miss(Self::obvhs_ray(ray, t_min, t_max), |_, id| {
            let tri = bvh.primitive_indices[id] as usize;
            intersect_triangle(ray, &self.triangles[tri], t_min, t_max)
                .map_or(f32::INFINITY, |h| h.0)
        })
    }

    /// Every hit with `t` in `[t_min, t_max]`, unordered: `(t, triangle)`.
    pub fn all_hits(&self, ray: &Ray, t_min: f32, t_max: f32) -> Vec<(f32, u32)> {
        let mut out = Vec::new();
        let Some(bvh) = self.bvh.as_ref() else {
            return out;
        };
        if !ray.o.is_finite() || !ray.d.is_finite() {
            return out;
        }
        bvh.ray_traverse_anyhit(Self::obvhs_ray(ray, t_min, t_max), |_, id| {
            let tri = bvh.primitive_indices[id];
            if let Some((t, _, _)) =
                intersect_triangle(ray, &self.triangles[tri as usize], t_min, t_max)
            {
                out.push((t, tri));
            }
        });
        out
    }

    /// Checks the built structure: `primitive_indices` is a permutation of the triangles and
    /// the root bounds contain every triangle.
    pub fn validate(&self) -> Result<(), String> {
        let Some(bvh) = &self.bvh else {
            return if self.triangles.is_empty() {
                Ok(())
            } else {
                Err("triangles but no BVH".into())
            };
        };
        let n = self.triangles.len();
        if bvh.primitive_indices.len() != n {
            return Err(format!(
                "BVH indexes {} primitives for {n} triangles",
                bvh.primitive_indices.len()
            ));
        }
        let mut seen = vec![false; n];
        for &i in &bvh.primitive_indices {
            let i = i as usize;
            if i >= n || std::mem::replace(&mut seen[i], true) {
                return Err(format!("primitive index {i} out of range or repeated"));
            }
        }
        let root = bvh.total_aabb;
        // Quantised child boxes are conservative; allow a relative slack for f32 rounding.
        let slack = 1e-4 * (root.max - root.min).max_element().max(1.0);
        for (k, t) in self.triangles.iter().enumerate() {
            for v in t {
                if v.cmplt(root.min - slack).any() || v.cmpgt(root.max + slack).any() {
                    return Err(format!("triangle {k} lies outside the root bounds"));
                }
            }
        }
        Ok(())
    }
}
