//! Two-level ray queries for meshes placed many times: one [`TriangleBvh`] per stored shape in
//! its own local space, and a top-level BVH over the world boxes of its placements. A mesh
//! placed a thousand times then costs one BVH and a thousand transforms instead of a thousand
//! copies of its triangles and of their BVH leaves.
//!
//! A query carries the world ray into each placement's local space without renormalising the
//! direction, so the ray parameter `t` means the same in both spaces and one running closest
//! `t` prunes every placement. The winning triangle's hit is then recomputed by Brume's
//! triangle test on its world-space corners, the same corners (and corner order) that
//! flattening the placement gives, so `t` and the barycentrics match the flat BVH's bit for bit
//! wherever that test still hits there.
use std::time::Duration;

use glam::{Affine3A, Mat4, Vec3, Vec3A};
use obvhs::cwbvh::{builder::build_cwbvh, CwBvh};
use obvhs::BvhBuildParams;

use super::{intersect_triangle, Hit, TriangleBvh};
use crate::math::Ray;

/// One placement of a stored shape: which shape, where, and where its triangles sit in the
/// caller's flat triangle order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShapePlacement {
    /// Index of the shape (the `shapes` argument of [`InstancedBvh::build`]).
    pub shape: u32,
    /// The placement's transform; its determinant must be non-zero.
    pub world_from_local: Mat4,
    /// Flat index of the placement's first triangle: local triangle `k` is flat triangle
    /// `first_triangle + k`.
    pub first_triangle: u32,
}

/// A placement as queries need it: the inverse transform and whether it mirrors.
#[derive(Clone, Copy, Debug)]
pub struct Placed {
    pub shape: u32,
    pub world_from_local: Mat4,
    pub local_from_world: Affine3A,
    /// A mirroring transform flips the winding; flattening swaps two corners to keep triangles
    /// counter-clockwise, and the world-space retest swaps the same two.
    pub mirrored: bool,
    pub first_triangle: u32,
}

/// Shapes in local space, each with its own BVH, under a BVH of their placements.
pub struct InstancedBvh {
    shapes: Vec<TriangleBvh>,
    placements: Vec<Placed>,
    /// BVH over the placements' world boxes; `None` when nothing is placed.
    top: Option<CwBvh>,
    /// Flat triangles in all (the sum of every placement's shape).
    triangles: usize,
}

impl std::fmt::Debug for InstancedBvh {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "InstancedBvh {{ shapes: {}, placements: {}, triangles: {} }}",
            self.shapes.len(),
            self.placements.len(),
            self.triangles
        )
    }
}

/// The world box of a local box under `m`: the box of its eight transformed corners.
fn world_box(m: &Mat4, lo: Vec3, hi: Vec3) -> (Vec3, Vec3) {
    let mut out = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for k in 0..8 {
        let c = Vec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        );
        let p = m.transform_point3(c);
        out = (out.0.min(p), out.1.max(p));
    }
    out
}

impl InstancedBvh {
    /// Builds a BVH per shape (local-space triangle corners) and one over `placements`.
    /// Errors name a placement whose shape does not exist, whose transform is not invertible
    /// or whose flat triangle range overflows 32 bits.
    pub fn build(
        shapes: Vec<Vec<[Vec3A; 3]>>,
        placements: &[ShapePlacement],
    ) -> Result<Self, String> {
        let shapes: Vec<TriangleBvh> = shapes.into_iter().map(TriangleBvh::build).collect();
        let mut placed = Vec::with_capacity(placements.len());
        let mut boxes = Vec::with_capacity(placements.len());
        let mut triangles = 0usize;
        for (k, p) in placements.iter().enumerate() {
            let Some(shape) = shapes.get(p.shape as usize) else {
                return Err(format!(
                    "placement {k} names shape {} of {}",
                    p.shape,
                    shapes.len()
                ));
            };
            let det = p.world_from_local.determinant();
            if det == 0.0 || !det.is_finite() || !p.world_from_local.is_finite() {
                return Err(format!("placement {k}'s transform is not invertible"));
            }
            let end = p.first_triangle as u64 + shape.len() as u64;
            if end > u32::MAX as u64 {
                return Err(format!("placement {k}'s triangles overflow 32-bit indices"));
            }
            triangles += shape.len();
            let (lo, hi) = shape.cwbvh().map_or((Vec3::ZERO, Vec3::ZERO), |b| {
                (Vec3::from(b.total_aabb.min), Vec3::from(b.total_aabb.max))
            });
            let (lo, hi) = world_box(&p.world_from_local, lo, hi);
            // Empty shapes get a box too, so box k stays placement k; no ray hits their BVH.
            boxes.push(obvhs::aabb::Aabb::new(lo.into(), hi.into()));
            placed.push(Placed {
                shape: p.shape,
                world_from_local: p.world_from_local,
                local_from_world: Affine3A::from_mat4(p.world_from_local.inverse()),
                mirrored: det < 0.0,
                first_triangle: p.first_triangle,
            });
        }
        let top = (!boxes.is_empty()).then(|| {
            let params = BvhBuildParams {
                pre_split: false,
                ..BvhBuildParams::medium_build()
            };
            build_cwbvh(&boxes, params, &mut Duration::default())
        });
        Ok(Self {
            shapes,
            placements: placed,
            top,
            triangles,
        })
    }

    /// Triangles as placed in the world, every placement counted.
    pub fn len(&self) -> usize {
        self.triangles
    }

    pub fn is_empty(&self) -> bool {
        self.triangles == 0
    }

    /// Number of placements.
    pub fn placements(&self) -> usize {
        self.placements.len()
    }

    /// Bytes held: every shape's BVH and corners, the placements and the top-level nodes.
    pub fn memory_bytes(&self) -> usize {
        self.shapes
            .iter()
            .map(TriangleBvh::memory_bytes)
            .sum::<usize>()
            + std::mem::size_of_val(&self.placements[..])
            + self.top.as_ref().map_or(0, |b| {
                std::mem::size_of_val(&b.nodes[..])
                    + std::mem::size_of_val(&b.primitive_indices[..])
            })
    }

    /// World-space corners of local triangle `local` of placement `p`, in the order flattening
    /// gives them (two swapped under a mirroring transform).
    fn world_corners(&self, p: &Placed, local: usize) -> [Vec3A; 3] {
        let c = self.shapes[p.shape as usize].triangles()[local]
            .map(|v| Vec3A::from(p.world_from_local.transform_point3(Vec3::from(v))));
        if p.mirrored {
            [c[0], c[2], c[1]]
        } else {
            c
        }
    }

    /// The nearest hit with `t` in `[t_min, t_max]`, in flat triangle indices. The closest
    /// triangle is found in local space; its `t` and barycentrics come from Brume's triangle
    /// test on its world-space corners, or from the local test where rounding makes the world
    /// test miss that triangle (a ray grazing its edge).
    pub fn closest_hit(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        let top = self.top.as_ref()?;
        if !ray.o.is_finite() || !ray.d.is_finite() {
            return None;
        }
        let mut best: Option<(usize, Hit)> = None;
        let mut hit = obvhs::ray::RayHit::none();
        let r = obvhs::ray::Ray::new(ray.o.into(), ray.d.into(), t_min, t_max);
        top.ray_traverse(r, &mut hit, |r, id| {
            let k = top.primitive_indices[id] as usize;
            let p = &self.placements[k];
            let local = Ray::new(
                p.local_from_world.transform_point3(ray.o),
                p.local_from_world.transform_vector3(ray.d),
            );
            match self.shapes[p.shape as usize].closest_hit(&local, r.tmin, r.tmax) {
                Some(h) => {
                    best = Some((k, h));
                    h.t
                }
                None => f32::INFINITY,
            }
        });
        let (k, h) = best?;
        // The world test runs without the t bounds' pruning margin: the local t decided the
        // order; the world one only restates the same hit in the flat triangle's terms.
        if let Some(hit) = self.restate(ray, k as u32, h.triangle, t_min, t_max) {
            return Some(hit);
        }
        let p = &self.placements[k];
        let triangle = p.first_triangle + h.triangle;
        Some(if p.mirrored {
            Hit {
                triangle,
                // Local corners (0, 1, 2) are world corners (0, 2, 1).
                b1: h.b2,
                b2: h.b1,
                ..h
            }
        } else {
            Hit { triangle, ..h }
        })
    }

    /// The hit of `ray` on local triangle `local` of placement `placement` by Brume's triangle
    /// test on its world-space corners, in flat triangle indices; `None` where that test
    /// misses it or the indices are out of range.
    pub fn restate(
        &self,
        ray: &Ray,
        placement: u32,
        local: u32,
        t_min: f32,
        t_max: f32,
    ) -> Option<Hit> {
        let p = self.placements.get(placement as usize)?;
        if local as usize >= self.shapes[p.shape as usize].len() {
            return None;
        }
        let corners = self.world_corners(p, local as usize);
        let (t, b1, b2) = intersect_triangle(ray, &corners, t_min, t_max)?;
        Some(Hit {
            t,
            triangle: p.first_triangle + local,
            b1,
            b2,
        })
    }

    /// The stored shapes' BVHs over their local-space corners, indexed by
    /// `ShapePlacement::shape`.
    pub fn shapes(&self) -> &[TriangleBvh] {
        &self.shapes
    }

    /// The placements in placement order, with their inverse transforms.
    pub fn placed(&self) -> &[Placed] {
        &self.placements
    }

    /// The BVH over the placements' world boxes (its primitives are placement indices);
    /// `None` when nothing is placed.
    pub fn top(&self) -> Option<&CwBvh> {
        self.top.as_ref()
    }

    /// Each placement's shape and world-from-local transform, in placement order.
    pub fn placement_transforms(&self) -> impl Iterator<Item = (u32, Mat4)> + '_ {
        self.placements
            .iter()
            .map(|p| (p.shape, p.world_from_local))
    }

    /// Checks every shape's BVH and that the top level indexes each placement once.
    pub fn validate(&self) -> Result<(), String> {
        for (k, s) in self.shapes.iter().enumerate() {
            s.validate().map_err(|e| format!("shape {k}: {e}"))?;
        }
        let n = self.placements.len();
        let Some(top) = &self.top else {
            return if n == 0 {
                Ok(())
            } else {
                Err("placements but no top-level BVH".into())
            };
        };
        let mut seen = vec![false; n];
        for &i in &top.primitive_indices {
            let i = i as usize;
            if i >= n || std::mem::replace(&mut seen[i], true) {
                return Err(format!("placement index {i} out of range or repeated"));
            }
        }
        if seen.iter().any(|s| !s) {
            return Err("the top-level BVH leaves a placement out".into());
        }
        Ok(())
    }
}
