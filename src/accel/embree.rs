//! Intel Embree 3 as the CPU's closest-hit accelerator for the scene's static triangles
//! (`--accel embree`), the one Brume module that uses `brume_ffi::embree`.
//!
//! Embree only chooses the triangle: the hit's `t` and barycentrics are then recomputed by
//! [`super::intersect_triangle`], the test the BVH and shading use, so a hit through Embree
//! is the BVH's hit bit for bit whenever both pick the same triangle. Where Embree's
//! watertight test accepts a triangle that Brume's rejects (a ray grazing an edge), the query
//! falls back to the BVH. Moving meshes stay on the BVH (`Scene::closest_hit`).
//!
//! Where the scene places a primitive more than once, Embree holds each primitive once under
//! its placements ([`EmbreeTriangles::build_instanced`]), as the two-level BVH does, and a
//! hit is restated on the placed corners the two-level BVH's own hits use.
use std::time::Instant;

use brume_ffi::embree::{EmbreeDevice, EmbreeInstance, EmbreeMesh, EmbreeScene};

use super::instanced::InstancedBvh;
use super::{intersect_triangle, Hit, TriangleBvh};
use crate::math::Ray;

/// A stored primitive for Embree: local-space vertices and triangles of three indices.
pub type LocalTriangles<'a> = (&'a [[f32; 3]], &'a [[u32; 3]]);

/// What Embree's scene is built over: the flat world-space triangles, or each stored primitive
/// once under the placements of a two-level BVH (primitive `k` is the BVH's shape `k`).
#[derive(Clone, Copy)]
pub enum EmbreeGeometry<'a> {
    Flat(LocalTriangles<'a>),
    Instanced {
        meshes: &'a [LocalTriangles<'a>],
        two_level: &'a InstancedBvh,
    },
}

/// An Embree scene over one triangle list or over instances of several, with its own device.
pub struct EmbreeTriangles {
    scene: EmbreeScene,
    /// Whether the scene is two-level: hits then name a placement of the two-level BVH.
    instanced: bool,
    /// Bytes Embree allocated for the scene (its memory-monitor callback).
    memory_bytes: i64,
    /// Seconds the build and commit took (device creation excluded).
    build_seconds: f64,
    triangles: usize,
    /// Dropped after `scene` (field order); the scene holds its own reference anyway.
    _device: EmbreeDevice,
}

impl std::fmt::Debug for EmbreeTriangles {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "EmbreeTriangles {{ triangles: {}, memory_bytes: {} }}",
            self.triangles, self.memory_bytes
        )
    }
}

impl EmbreeTriangles {
    /// Builds over world-space `vertices` and triangles of three vertex `indices`, in the
    /// order of the BVH's triangles. The error names what failed (creating the device,
    /// building the scene) and why.
    pub fn build(vertices: &[[f32; 3]], indices: &[[u32; 3]]) -> Result<Self, String> {
        Self::build_geometry(EmbreeGeometry::Flat((vertices, indices)))
    }

    /// Builds over each of `meshes` once, placed as `two_level` places its shapes: placement
    /// `k` is Embree's instance `k`.
    pub fn build_instanced(
        meshes: &[LocalTriangles<'_>],
        two_level: &InstancedBvh,
    ) -> Result<Self, String> {
        Self::build_geometry(EmbreeGeometry::Instanced { meshes, two_level })
    }

    /// Builds over `geometry`, flat or instanced.
    pub fn build_geometry(geometry: EmbreeGeometry<'_>) -> Result<Self, String> {
        let device = EmbreeDevice::new().map_err(|e| e.to_string())?;
        let before = device.memory_bytes();
        let start = Instant::now();
        let (scene, triangles) = match geometry {
            EmbreeGeometry::Flat((vertices, indices)) => {
                (device.triangle_scene(vertices, indices), indices.len())
            }
            EmbreeGeometry::Instanced { meshes, two_level } => {
                let meshes: Vec<EmbreeMesh<'_>> = meshes
                    .iter()
                    .map(|&(vertices, indices)| EmbreeMesh { vertices, indices })
                    .collect();
                let instances: Vec<EmbreeInstance> = two_level
                    .placement_transforms()
                    .map(|(mesh, m)| {
                        let c = m.to_cols_array();
                        EmbreeInstance {
                            mesh,
                            world_from_local: [
                                c[0], c[1], c[2], c[4], c[5], c[6], c[8], c[9], c[10], c[12],
                                c[13], c[14],
                            ],
                        }
                    })
                    .collect();
                (device.instanced_scene(&meshes, &instances), two_level.len())
            }
        };
        Ok(Self {
            scene: scene.map_err(|e| e.to_string())?,
            instanced: matches!(geometry, EmbreeGeometry::Instanced { .. }),
            memory_bytes: device.memory_bytes() - before,
            build_seconds: start.elapsed().as_secs_f64(),
            triangles,
            _device: device,
        })
    }

    /// Whether this is a two-level scene, whose hits [`EmbreeTriangles::closest_hit_instanced`]
    /// restates.
    pub fn is_instanced(&self) -> bool {
        self.instanced
    }

    /// Builds over a BVH's triangles, three vertices each (for tests and benchmarks that
    /// have no shared vertex list).
    pub fn of_bvh(bvh: &TriangleBvh) -> Result<Self, String> {
        let vertices: Vec<[f32; 3]> = bvh
            .triangles()
            .iter()
            .flat_map(|t| t.map(|v| v.to_array()))
            .collect();
        let indices: Vec<[u32; 3]> = (0..bvh.len() as u32)
            .map(|k| [3 * k, 3 * k + 1, 3 * k + 2])
            .collect();
        Self::build(&vertices, &indices)
    }

    /// Bytes Embree allocated for this scene.
    pub fn memory_bytes(&self) -> i64 {
        self.memory_bytes
    }

    /// Seconds the build took.
    pub fn build_seconds(&self) -> f64 {
        self.build_seconds
    }

    /// The triangle Embree's own test finds nearest with `t` in `[t_min, t_max]`.
    #[inline]
    pub fn embree_triangle(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<u32> {
        if !ray.o.is_finite() || !ray.d.is_finite() {
            return None;
        }
        self.scene
            .closest_hit(ray.o.to_array(), ray.d.to_array(), t_min, t_max)
            .map(|h| h.prim)
    }

    /// The nearest hit with `t` in `[t_min, t_max]`: Embree's triangle, with `t` and
    /// barycentrics from Brume's triangle test on `bvh`'s corners (the triangles this was
    /// built over); the BVH's answer where that test rejects Embree's triangle.
    #[inline]
    pub fn closest_hit(&self, bvh: &TriangleBvh, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        let triangle = self.embree_triangle(ray, t_min, t_max)?;
        match intersect_triangle(ray, &bvh.triangles()[triangle as usize], t_min, t_max) {
            Some((t, b1, b2)) => Some(Hit {
                t,
                triangle,
                b1,
                b2,
            }),
            None => bvh.closest_hit(ray, t_min, t_max),
        }
    }

    /// The nearest hit with `t` in `[t_min, t_max]` through a two-level scene built over
    /// `two_level`'s placements: Embree's placement and triangle, with `t` and barycentrics
    /// from Brume's test on that triangle's placed corners (as `two_level` restates its own
    /// hits); `two_level`'s answer where that test rejects Embree's triangle.
    #[inline]
    pub fn closest_hit_instanced(
        &self,
        two_level: &InstancedBvh,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
    ) -> Option<Hit> {
        if !ray.o.is_finite() || !ray.d.is_finite() {
            return None;
        }
        let h = self
            .scene
            .closest_hit(ray.o.to_array(), ray.d.to_array(), t_min, t_max)?;
        h.inst
            .and_then(|k| two_level.restate(ray, k, h.prim, t_min, t_max))
            .or_else(|| two_level.closest_hit(ray, t_min, t_max))
    }

    /// Whether Embree finds any triangle with `t` in `[t_min, t_max]` (its own test).
    #[inline]
    pub fn occluded(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        ray.o.is_finite()
            && ray.d.is_finite()
            && self
                .scene
                .occluded(ray.o.to_array(), ray.d.to_array(), t_min, t_max)
    }
}
