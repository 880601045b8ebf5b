//! Transformation motion blur of meshes: the instances an animation moves during the shutter
//! keep their triangles where the frame places them, each in a BVH of its own, and a query at
//! time offset `dt` carries its ray to the frame's pose of each (as Embree and Cycles intersect
//! motion-blurred instances). Still triangles share one BVH.
use glam::{Affine3A, Vec3, Vec3A};

use super::mesh::{Instance, Triangle, Vertex};
use super::motion::FrameMotion;
use super::nodes::PlacedNode;
use super::velocity::Shutter;
use super::world_mesh::WorldMesh;
use crate::accel::{Hit, TriangleBvh};
use crate::math::{Aabb, Ray};

/// A mesh instance moving during the shutter.
#[derive(Debug)]
pub struct MovingMesh {
    /// Index into `Scene::instances`.
    pub instance: u32,
    pub motion: FrameMotion,
    /// The instance's first triangle in `Scene::triangles` (the BVH's triangle 0).
    first_triangle: u32,
    /// The instance's triangles as the frame places them.
    bvh: TriangleBvh,
}

/// The scene's triangles split into still ones and moving instances.
#[derive(Debug)]
pub struct MovingMeshes {
    pub meshes: Vec<MovingMesh>,
    /// The still triangles, `still_triangles[k]` being the scene index of the BVH's `k`.
    still: TriangleBvh,
    still_triangles: Vec<u32>,
    /// Per instance, its index into `meshes` or `NO_INDEX`.
    by_instance: Vec<u32>,
}

fn corners(vertices: &[Vertex], t: &Triangle) -> [Vec3A; 3] {
    t.vertices
        .map(|i| Vec3A::from(vertices[i as usize].position))
}

fn carried(ray: &Ray, f: &Affine3A) -> Ray {
    Ray::new(f.transform_point3(ray.o), f.transform_vector3(ray.d))
}

impl MovingMeshes {
    /// Splits the triangles: `motion[k]` is instance `k`'s motion, `None` where it stands
    /// still. `None` where no instance moves.
    pub fn build(
        vertices: &[Vertex],
        triangles: &[Triangle],
        instances: &[Instance],
        motion: Vec<Option<FrameMotion>>,
    ) -> Option<MovingMeshes> {
        if motion.iter().all(Option::is_none) {
            return None;
        }
        let mut by_instance = vec![super::NO_INDEX; instances.len()];
        let mut meshes = Vec::new();
        for (k, m) in motion.into_iter().enumerate() {
            let Some(m) = m else { continue };
            let inst = &instances[k];
            let range =
                inst.first_triangle as usize..(inst.first_triangle + inst.triangle_count) as usize;
            by_instance[k] = meshes.len() as u32;
            meshes.push(MovingMesh {
                instance: k as u32,
                motion: m,
                first_triangle: inst.first_triangle,
                bvh: TriangleBvh::build(
                    triangles[range]
                        .iter()
                        .map(|t| corners(vertices, t))
                        .collect(),
                ),
            });
        }
        let still_triangles: Vec<u32> = (0..triangles.len() as u32)
            .filter(|&t| by_instance[triangles[t as usize].instance as usize] == super::NO_INDEX)
            .collect();
        let still = TriangleBvh::build(
            still_triangles
                .iter()
                .map(|&t| corners(vertices, &triangles[t as usize]))
                .collect(),
        );
        Some(MovingMeshes {
            meshes,
            still,
            still_triangles,
            by_instance,
        })
    }

    /// The `instances` of `world` that move across the shutter's `steps` (`motion::placements`;
    /// `nodes`: the placements at the frame), `None` where none does.
    pub fn of_steps(
        steps: &[Vec<PlacedNode>],
        nodes: &[PlacedNode],
        world: &WorldMesh,
        instances: &[Instance],
        shutter: Shutter,
    ) -> Option<MovingMeshes> {
        let motion: Vec<_> = instances
            .iter()
            .map(|inst| {
                let placement = nodes.iter().position(|p| p.node == inst.node as usize)?;
                Some(FrameMotion {
                    node: super::motion::placement_motion(steps, placement, shutter)?,
                    frame_world_from_node: nodes[placement].world_from_node,
                })
            })
            .collect();
        // The world arrays only where something moves: a still scene may trace its placements
        // through the two-level BVH without them.
        if motion.iter().all(Option::is_none) {
            return None;
        }
        let a = world.arrays();
        Self::build(&a.vertices, &a.triangles, instances, motion)
    }

    /// The motion of instance `k`, `None` where it stands still.
    #[inline]
    pub fn of_instance(&self, k: u32) -> Option<&FrameMotion> {
        let i = *self.by_instance.get(k as usize)?;
        (i != super::NO_INDEX).then(|| &self.meshes[i as usize].motion)
    }

    /// The nearest hit with `t` in `[t_min, t_max]` at time offset `dt`, in scene triangle
    /// indices. The ray parameter is the world ray's: an affine map keeps it.
    pub fn closest_hit(&self, ray: &Ray, t_min: f32, t_max: f32, dt: f32) -> Option<Hit> {
        let mut best = self.still.closest_hit(ray, t_min, t_max).map(|h| Hit {
            triangle: self.still_triangles[h.triangle as usize],
            ..h
        });
        for m in &self.meshes {
            let t_max = best.map_or(t_max, |h| h.t);
            let local = carried(ray, &m.motion.rest_from_world(dt));
            if let Some(h) = m.bvh.closest_hit(&local, t_min, t_max) {
                best = Some(Hit {
                    triangle: h.triangle + m.first_triangle,
                    ..h
                });
            }
        }
        best
    }

    /// The world box every moving instance sweeps over the shutter.
    pub fn swept_bounds(&self) -> Aabb {
        self.meshes.iter().fold(Aabb::EMPTY, |b, m| {
            let rest = m.bvh.cwbvh().map_or(Aabb::EMPTY, |bvh| {
                Aabb::new(
                    Vec3::from(bvh.total_aabb.min),
                    Vec3::from(bvh.total_aabb.max),
                )
            });
            b.union(&m.motion.swept_bounds(rest))
        })
    }
}
