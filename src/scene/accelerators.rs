//! The CPU's closest-hit accelerators of a scene and the choice among them: the flat BVH over
//! the world-space triangles; the two-level BVH where some primitive is placed more than once,
//! which stores each primitive's triangles once; and Embree, over the flat triangles or, where
//! the two-level BVH is kept, over each primitive once under the same placements.
//!
//! A scene with a two-level BVH builds its flat BVH and its world arrays only when something
//! asks for them (the GPU's upload, Embree, comparisons in tests), so a CPU render of a scene
//! of many placements never holds a copy of every placed triangle.
use std::sync::OnceLock;

use glam::Vec3A;

use super::mesh::{repeats_a_shape, LocalPrimitive, Triangle, Vertex};
use super::world_mesh::WorldMesh;
use super::{ctx_invalid, AccelUsed, Scene, SceneError};
use crate::accel::embree::{EmbreeGeometry, EmbreeTriangles, LocalTriangles};
use crate::accel::instanced::{InstancedBvh, ShapePlacement};
use crate::accel::{Accel, Hit, TriangleBvh};
use crate::math::Ray;

/// The BVH over the world-space `triangles`, in their order.
fn world_bvh(vertices: &[Vertex], triangles: &[Triangle]) -> TriangleBvh {
    let corners = triangles
        .iter()
        .map(|t| {
            t.vertices
                .map(|i| Vec3A::from(vertices[i as usize].position))
        })
        .collect();
    TriangleBvh::build(corners)
}

/// The accelerators a scene starts with: the two-level BVH over `world`'s stored primitives
/// where `placements` place some primitive more than once and no mesh moves (the flat BVH and
/// `world`'s arrays then wait for first use), else the flat BVH over `world`'s arrays, which
/// alone are kept.
pub(super) fn build(
    placements: &[ShapePlacement],
    world: &mut WorldMesh,
    moving: bool,
) -> Result<(OnceLock<TriangleBvh>, Option<InstancedBvh>), String> {
    let flat = OnceLock::new();
    if moving || !repeats_a_shape(placements) {
        world.keep_arrays_only();
        let a = world.arrays();
        let _ = flat.set(world_bvh(&a.vertices, &a.triangles));
        return Ok((flat, None));
    }
    let shapes = world.locals().iter().map(LocalPrimitive::corners).collect();
    let instanced = InstancedBvh::build(shapes, placements)?;
    Ok((flat, Some(instanced)))
}

impl Scene {
    /// The BVH over the world-space triangles (same order as `triangles`), built here on first
    /// use where the scene answers its closest hits through the two-level BVH.
    pub fn bvh(&self) -> &TriangleBvh {
        self.flat_bvh
            .get_or_init(|| world_bvh(self.vertices(), self.triangles()))
    }

    /// The flat BVH where it has been built, `None` where only the two-level BVH has been
    /// needed so far (what the geometry holds now).
    pub fn built_flat_bvh(&self) -> Option<&TriangleBvh> {
        self.flat_bvh.get()
    }

    /// The nearest surface hit with `t` in `[t_min, t_max]` by a ray at time offset `dt`
    /// (frames): moving meshes where they are then.
    #[inline]
    pub fn closest_hit(&self, ray: &Ray, t_min: f32, t_max: f32, dt: f32) -> Option<Hit> {
        match (&self.moving_meshes, &self.embree, &self.instanced) {
            (Some(m), _, _) => m.closest_hit(ray, t_min, t_max, dt),
            (None, Some(e), Some(i)) if e.is_instanced() => {
                e.closest_hit_instanced(i, ray, t_min, t_max)
            }
            (None, Some(e), _) => e.closest_hit(self.bvh(), ray, t_min, t_max),
            (None, None, Some(i)) => i.closest_hit(ray, t_min, t_max),
            (None, None, None) => self.bvh().closest_hit(ray, t_min, t_max),
        }
    }

    /// Chooses the CPU's closest-hit accelerator for the static triangles, building Embree's
    /// scene where asked or where [`Accel::Auto`] picks it for the scene's size. A scene with
    /// moving meshes keeps the BVH (Embree holds static triangles only). A scene with a
    /// two-level BVH gives Embree each primitive once under the same placements, and keeps
    /// the two-level BVH to restate Embree's hits. The error names the scene file; only an
    /// explicit [`Accel::Embree`] fails, `Auto` falls back to the BVH.
    pub fn use_accel(&mut self, accel: Accel) -> Result<AccelUsed, SceneError> {
        self.use_accel_with(accel, EmbreeTriangles::build_geometry)
    }

    /// [`Scene::use_accel`] with Embree's scene built by `build` (tests make it fail).
    pub fn use_accel_with(
        &mut self,
        accel: Accel,
        build: impl FnOnce(EmbreeGeometry<'_>) -> Result<EmbreeTriangles, String>,
    ) -> Result<AccelUsed, SceneError> {
        self.embree = None;
        let bvh = |fallback| AccelUsed {
            asked: accel,
            accel: Accel::Bvh,
            fallback,
        };
        if self.moving_meshes.is_some() || accel.for_triangles(self.triangle_count()) == Accel::Bvh
        {
            return Ok(bvh(None));
        }
        let built = match &self.instanced {
            Some(two_level) => {
                let locals = self.world.locals();
                let vertices: Vec<Vec<[f32; 3]>> = locals
                    .iter()
                    .map(|l| l.positions.iter().map(|p| p.to_array()).collect())
                    .collect();
                let meshes: Vec<LocalTriangles<'_>> = locals
                    .iter()
                    .zip(&vertices)
                    .map(|(l, v)| (&v[..], &l.triangles[..]))
                    .collect();
                build(EmbreeGeometry::Instanced {
                    meshes: &meshes,
                    two_level,
                })
            }
            None => {
                // Embree's hits are restated by Brume's test on the flat BVH's corners: build
                // it now, before Embree holds its memory, rather than inside the first render
                // thread's query.
                self.bvh();
                let vertices: Vec<[f32; 3]> = self.vertices().iter().map(|v| v.position).collect();
                let indices: Vec<[u32; 3]> = self.triangles().iter().map(|t| t.vertices).collect();
                build(EmbreeGeometry::Flat((&vertices, &indices)))
            }
        };
        match built {
            Ok(embree) => self.embree = Some(embree),
            Err(e) if accel == Accel::Auto => return Ok(bvh(Some(e))),
            Err(e) => return Err(ctx_invalid(&self.source, e)),
        }
        Ok(AccelUsed {
            asked: accel,
            accel: Accel::Embree,
            fallback: None,
        })
    }

    /// Checks the accelerators built so far: each covers every triangle and is sound.
    pub(super) fn validate_accelerators(&self) -> Result<(), String> {
        if let Some(i) = &self.instanced {
            if i.len() != self.triangle_count() {
                return Err("two-level BVH and triangle counts differ".into());
            }
            i.validate()?;
        }
        if let Some(b) = self.flat_bvh.get() {
            if b.len() != self.triangle_count() {
                return Err("BVH and triangle counts differ".into());
            }
            b.validate()?;
        }
        Ok(())
    }
}
