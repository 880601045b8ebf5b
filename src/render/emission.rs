//! Volume emission of VDB media (Blender's Principled Volume): a constant or grid-scaled
//! emission colour and a blackbody term from a temperature grid, inside the region Cycles
//! emits in. Re-exported by `integrator::media`, whose media carry it.
use std::cell::Cell;
use std::sync::Arc;

use glam::{Affine3A, DVec3, Vec3};

use super::blackbody::blackbody_emission;
use crate::math::Aabb;
use crate::volume::LoadedGrid;

/// A grid placed in the world: trilinear lookups at world points.
#[derive(Clone)]
pub struct GridField {
    pub grid: Arc<LoadedGrid>,
    pub index_from_world: Affine3A,
}

impl GridField {
    #[inline]
    pub fn at_index(&self, p: Vec3) -> f32 {
        self.grid
            .grid
            .sample_trilinear(DVec3::new(p.x as f64, p.y as f64, p.z as f64))
    }

    #[inline]
    pub fn at_world(&self, p: Vec3) -> f32 {
        self.at_index(self.index_from_world.transform_point3(p))
    }

    /// The trilinear blend of `f` of the voxels around world point `p`
    /// (`SparseGrid::sample_trilinear_of`).
    #[inline]
    pub fn of_voxels_at_world(&self, p: Vec3, f: impl Fn(f32) -> Vec3) -> Vec3 {
        let q = self.index_from_world.transform_point3(p);
        let q = DVec3::new(q.x as f64, q.y as f64, q.z as f64);
        self.grid.grid.sample_trilinear_of(q, f)
    }
}

/// Blender Principled Volume emission (radiance per metre, not multiplied by density).
#[derive(Clone)]
pub struct Emission {
    /// `emissionStrength * emissionColor`.
    pub strength_color: Vec3,
    /// Multiplies `strength_color` when present (e.g. a `flame` grid).
    pub grid: Option<GridField>,
    pub blackbody: Option<Blackbody>,
    /// Where it emits at all ([`EmissionRegion`]); `None`: everywhere the walks go.
    pub region: Option<EmissionRegion>,
}

/// Where a medium emits: Cycles 5 (null scattering) emits inside the volume mesh it builds
/// around the medium, which is the box of its grids' active voxels dilated by one voxel
/// (`pad_size` 1 for linear interpolation) and taken from the lowest voxel's corner to one
/// past the highest (`VolumeMeshBuilder`: `evalActiveVoxelBoundingBox`, `max + 1`), so
/// `[min - 1, max + 2]` in index coordinates. Density and the emission grids are 0 beyond
/// that box anyway; a constant emission (`emissionStrength` without a grid, a temperature
/// offset, a blackbody intensity below 1) is not, and without the box it glowed in the whole
/// cell box (the leaves' box and a one-cell pad): three times Cycles' light on the sunlit
/// plume with a constant emission (`docs/comparing.md`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmissionRegion {
    /// The density grid's `index_from_world`: the box is in its index space.
    pub index_from_world: Affine3A,
    /// The union of every grid's box, mapped into the density's index space.
    pub bounds: Aabb,
}

impl EmissionRegion {
    /// Whether world point `p` lies inside (half-open: `min <= q < max` on every axis).
    #[inline]
    pub fn contains(&self, p: Vec3) -> bool {
        let q = self.index_from_world.transform_point3(p);
        q.cmpge(self.bounds.min).all() && q.cmplt(self.bounds.max).all()
    }
}

#[derive(Clone)]
pub struct Blackbody {
    pub temperature: GridField,
    /// Kelvin = scale * grid value + offset.
    pub scale: f32,
    pub offset: f32,
    pub intensity: f32,
    pub tint: Vec3,
    /// The blackbody of each voxel's temperature, blended trilinearly (Cycles' model), instead
    /// of the blackbody of the blended temperature (`BlackbodyModel`).
    pub of_voxels: bool,
}

impl Emission {
    /// Emitted radiance per metre at world point `p`; `lookups` counts grid reads.
    #[inline]
    pub fn radiance(&self, p: Vec3, lookups: &Cell<u64>) -> Vec3 {
        let mut e = Vec3::ZERO;
        if self.region.is_some_and(|r| !r.contains(p)) {
            return e;
        }
        if self.strength_color != Vec3::ZERO {
            let scale = match &self.grid {
                Some(g) => {
                    lookups.set(lookups.get() + 1);
                    g.at_world(p)
                }
                None => 1.0,
            };
            e += self.strength_color * scale;
        }
        if let Some(bb) = &self.blackbody {
            lookups.set(lookups.get() + 1);
            let of = |v: f32| blackbody_emission(bb.scale * v + bb.offset, bb.intensity);
            e += bb.tint
                * match bb.of_voxels {
                    false => of(bb.temperature.at_world(p)),
                    true => bb.temperature.of_voxels_at_world(p, of),
                };
        }
        e
    }
}
