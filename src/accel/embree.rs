//! Intel Embree 3 as the CPU's closest-hit accelerator for the scene's static triangles
//! (`--accel embree`), the one Brume module that uses `brume_ffi::embree`.
//!
//! Embree only chooses the triangle: the hit's `t` and barycentrics are then recomputed by
//! [`super::intersect_triangle`], the test the BVH and shading use, so a hit through Embree
//! is the BVH's hit bit for bit whenever both pick the same triangle. Where Embree's
//! watertight test accepts a triangle that Brume's rejects (a ray grazing an edge), the query
//! falls back to the BVH. Moving meshes stay on the BVH (`Scene::closest_hit`).
use std::time::Instant;

use brume_ffi::embree::{EmbreeDevice, EmbreeScene};

use super::{intersect_triangle, Hit, TriangleBvh};
use crate::math::Ray;

/// An Embree scene over one triangle list, with its own device.
pub struct EmbreeTriangles {
    scene: EmbreeScene,
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
        let device = EmbreeDevice::new().map_err(|e| e.to_string())?;
        let before = device.memory_bytes();
        let start = Instant::now();
        let scene = device
            .triangle_scene(vertices, indices)
            .map_err(|e| e.to_string())?;
        Ok(Self {
            scene,
            memory_bytes: device.memory_bytes() - before,
            build_seconds: start.elapsed().as_secs_f64(),
            triangles: indices.len(),
            _device: device,
        })
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
