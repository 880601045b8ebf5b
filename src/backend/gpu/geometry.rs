//! The scene's surfaces as the GPU reads them: CWBVH nodes, triangles in BVH primitive order,
//! their texture coordinates and the area lights' selection CDF.
//!
//! A scene whose CPU queries go through the two-level BVH (some primitive placed more than
//! once) keeps instancing on the GPU too: the top-level BVH's nodes, then each stored shape's
//! BVH and local-space triangles once, and a [`GpuPlacement`] per placement
//! (`shaders/common/placements.wgsl`). Other scenes upload the flat world-space triangles.
//! An area light placed more than once gets a copy of its shape per placement, since each
//! placed triangle has its own selection density.
use std::collections::HashMap;

use bytemuck::Zeroable;
use glam::{Mat3, Vec3};

use super::device::byte_size;
use crate::accel::instanced::{InstancedBvh, Placed};
use crate::gpu_types::{
    GpuAreaLight, GpuPlacement, GpuTriangle, GpuTriangleUv, PLACEMENT_EMPTY, PLACEMENT_MIRRORED,
    SURFACE_DIELECTRIC, SURFACE_NULL, SURFACE_OPAQUE,
};
use crate::render::prepare::SurfaceKind;
use crate::render::RenderScene;
use crate::scene::mesh::LocalPrimitive;

/// The scene's surfaces as the GPU reads them: obvhs' CWBVH nodes, the triangles in its
/// primitive order and the area lights' selection CDF (each at least one element: a binding
/// cannot be empty; a zero node has no children, so traversal ends at once).
pub(super) struct Geometry {
    pub(super) nodes: Vec<obvhs::cwbvh::node::CwBvhNode>,
    pub(super) triangles: Vec<GpuTriangle>,
    /// Texture coordinates of `triangles`, same order.
    pub(super) triangle_uvs: Vec<GpuTriangleUv>,
    pub(super) area_lights: Vec<GpuAreaLight>,
    /// The placements in the top-level BVH's primitive order (one zero entry where the
    /// triangles are flat).
    pub(super) placements: Vec<GpuPlacement>,
    /// `GpuWavefrontParams::placement_count`: 0 where the triangles are flat.
    pub(super) placement_count: u32,
}

/// A triangle's corners, shading normals (zero: none) and texture coordinates, in the order
/// its BVH tests them.
struct Corners {
    p: [Vec3; 3],
    n: [Vec3; 3],
    uv: [[f32; 2]; 3],
}

/// The `GpuTriangle` of scene (or local) triangle `triangle` with `material`.
fn gpu_triangle(
    rs: &RenderScene,
    c: &Corners,
    triangle: u32,
    material: u32,
    light_pdf: f32,
) -> GpuTriangle {
    GpuTriangle {
        p0: c.p[0].to_array(),
        triangle,
        p1: c.p[1].to_array(),
        material,
        p2: c.p[2].to_array(),
        light_pdf,
        n0: c.n[0].to_array(),
        kind: match rs.kinds[material as usize] {
            SurfaceKind::Opaque => SURFACE_OPAQUE,
            SurfaceKind::Dielectric => SURFACE_DIELECTRIC,
            SurfaceKind::Null => SURFACE_NULL,
        },
        n1: c.n[1].to_array(),
        interior: rs.scene.materials[material as usize].interior_medium,
        n2: c.n[2].to_array(),
        _pad0: 0,
    }
}

fn gpu_uv(c: &Corners) -> GpuTriangleUv {
    GpuTriangleUv {
        uv0: c.uv[0],
        uv1: c.uv[1],
        uv2: c.uv[2],
    }
}

impl Geometry {
    fn empty() -> Geometry {
        Geometry {
            nodes: vec![bytemuck::Zeroable::zeroed()],
            triangles: vec![GpuTriangle::zeroed()],
            triangle_uvs: vec![GpuTriangleUv::zeroed()],
            area_lights: vec![GpuAreaLight::zeroed()],
            placements: vec![GpuPlacement::zeroed()],
            placement_count: 0,
        }
    }

    /// The scene's surfaces, each buffer checked against the device's `max_binding` bytes
    /// (the error names the buffer and both sizes).
    pub(super) fn new(rs: &RenderScene, max_binding: u64) -> Result<Geometry, String> {
        let g = match &rs.scene.instanced {
            Some(two_level) => Self::placed(rs, two_level)?,
            None => Self::flat(rs)?,
        };
        for (what, bytes) in [
            ("BVH nodes", std::mem::size_of_val(&g.nodes[..])),
            ("triangles", std::mem::size_of_val(&g.triangles[..])),
            (
                "texture coordinates",
                std::mem::size_of_val(&g.triangle_uvs[..]),
            ),
            ("placements", std::mem::size_of_val(&g.placements[..])),
        ] {
            if bytes as u64 > max_binding {
                return Err(format!(
                    "the scene's {what} need {} in one storage binding, more than the \
                     device's {} ({})",
                    byte_size(bytes as u64),
                    byte_size(max_binding),
                    g.describe()
                ));
            }
        }
        Ok(g)
    }

    /// What the GPU holds of the surfaces: bytes, and triangles stored and placed.
    pub(super) fn describe(&self) -> String {
        let bytes = std::mem::size_of_val(&self.nodes[..])
            + std::mem::size_of_val(&self.triangles[..])
            + std::mem::size_of_val(&self.triangle_uvs[..])
            + std::mem::size_of_val(&self.area_lights[..])
            + std::mem::size_of_val(&self.placements[..]);
        let how = if self.placement_count == 0 {
            format!("{} world-space triangles", self.triangles.len())
        } else {
            format!(
                "{} triangles stored under {} placements",
                self.triangles.len(),
                self.placement_count
            )
        };
        format!("{} ({how})", byte_size(bytes as u64))
    }

    /// The world-space triangles under the flat BVH.
    fn flat(rs: &RenderScene) -> Result<Geometry, String> {
        let scene = rs.scene;
        let mut g = Geometry::empty();
        let Some(bvh) = scene.bvh().cwbvh() else {
            return Ok(g);
        };
        // Selection density of each area light, by scene triangle.
        let mut light_pdf = vec![0.0f32; scene.triangle_count()];
        if let Some(area) = &rs.lights.area {
            for (i, &t) in area.triangles.iter().enumerate() {
                light_pdf[t as usize] = area.selection_pdf(i);
            }
        }
        let mut slot_of = vec![crate::scene::NO_INDEX; scene.triangle_count()];
        let mut triangles = Vec::with_capacity(bvh.primitive_indices.len());
        let mut triangle_uvs = Vec::with_capacity(bvh.primitive_indices.len());
        for (slot, &t) in bvh.primitive_indices.iter().enumerate() {
            let t = t as usize;
            if t >= scene.triangle_count() {
                return Err(format!(
                    "the BVH names triangle {t} of {}",
                    scene.triangle_count()
                ));
            }
            slot_of[t] = slot as u32;
            let v = scene.triangle_vertices(t);
            let c = Corners {
                p: v.map(|v| Vec3::from(v.position)),
                n: v.map(|v| Vec3::from(v.normal)),
                uv: v.map(|v| [v.u, v.v]),
            };
            let material = scene.instances[scene.triangle_instance(t) as usize].material;
            triangles.push(gpu_triangle(rs, &c, t as u32, material, light_pdf[t]));
            triangle_uvs.push(gpu_uv(&c));
        }
        if bvh.nodes.is_empty() || triangles.is_empty() {
            return Ok(g);
        }
        g.area_lights = area_lights(rs, |t| slot_of[t as usize])?;
        g.nodes = bvh.nodes.clone();
        g.triangles = triangles;
        g.triangle_uvs = triangle_uvs;
        Ok(g)
    }

    /// Each stored shape once under the top-level BVH over its placements.
    fn placed(rs: &RenderScene, two_level: &InstancedBvh) -> Result<Geometry, String> {
        let scene = rs.scene;
        let mut g = Geometry::empty();
        let Some(top) = two_level.top() else {
            return Ok(g);
        };
        let locals = scene.stored_primitives();
        let placed = two_level.placed();
        let area = rs.lights.area.as_ref();
        // Whether placement `k` holds an area light: its shape is then copied for it alone.
        let lit = |p: &Placed| {
            let n = two_level.shapes()[p.shape as usize].len() as u32;
            area.is_some_and(|a| {
                let from = a.triangles.partition_point(|&t| t < p.first_triangle);
                a.triangles
                    .get(from)
                    .is_some_and(|&t| t < p.first_triangle + n)
            })
        };
        g.nodes = top.nodes.clone();
        g.triangles.clear();
        g.triangle_uvs.clear();
        g.placements.clear();
        // Where each stored shape (or a lit placement's copy) starts: (node_base, prim_base).
        let mut uploaded: HashMap<(u32, Option<usize>), (u32, u32)> = HashMap::new();
        // Scene-wide slot of each placement's first triangle slot, by placement index.
        let mut first_slot_of = vec![0u32; placed.len()];
        let mut next_slot = 0u64;
        for &k in &top.primitive_indices {
            let k = k as usize;
            let p = placed
                .get(k)
                .ok_or_else(|| format!("the top-level BVH names placement {k}"))?;
            let shape = &two_level.shapes()[p.shape as usize];
            let key = (p.shape, lit(p).then_some(k));
            let material = scene.instances[k].material;
            let (node_base, prim_base) = match uploaded.get(&key) {
                Some(&bases) => bases,
                None => {
                    let bases = (g.nodes.len() as u32, g.triangles.len() as u32);
                    if let Some(bvh) = shape.cwbvh() {
                        g.nodes.extend_from_slice(&bvh.nodes);
                        for &t in &bvh.primitive_indices {
                            let c = local_corners(&locals[p.shape as usize], t as usize);
                            let pdf = key.1.map_or(0.0, |_| light_pdf(rs, p.first_triangle + t));
                            g.triangles.push(gpu_triangle(rs, &c, t, material, pdf));
                            g.triangle_uvs.push(gpu_uv(&c));
                        }
                    }
                    uploaded.insert(key, bases);
                    bases
                }
            };
            first_slot_of[k] = next_slot as u32;
            g.placements
                .push(gpu_placement(p, node_base, prim_base, next_slot as u32));
            if shape.cwbvh().is_none() {
                g.placements.last_mut().unwrap().flags |= PLACEMENT_EMPTY;
            }
            next_slot += shape.len() as u64;
            if next_slot > u32::MAX as u64 {
                return Err("the placed triangles overflow 32-bit slots".into());
            }
        }
        g.placement_count = g.placements.len() as u32;
        if g.triangles.is_empty() {
            g.triangles.push(GpuTriangle::zeroed());
            g.triangle_uvs.push(GpuTriangleUv::zeroed());
        }
        // An area light's slot: its placement's first slot and its place in its shape's BVH.
        let mut slot_in_shape: HashMap<u32, Vec<u32>> = HashMap::new();
        g.area_lights = area_lights(rs, |t| {
            let k = placed.partition_point(|p| p.first_triangle <= t) - 1;
            let p = &placed[k];
            let slots = slot_in_shape.entry(p.shape).or_insert_with(|| {
                let bvh = two_level.shapes()[p.shape as usize].cwbvh();
                let order = bvh.map_or(&[][..], |b| &b.primitive_indices[..]);
                let mut slots = vec![0u32; order.len()];
                for (slot, &local) in order.iter().enumerate() {
                    slots[local as usize] = slot as u32;
                }
                slots
            });
            first_slot_of[k] + slots[(t - p.first_triangle) as usize]
        })?;
        Ok(g)
    }
}

/// The selection density of scene triangle `t` as an area light (0: not one).
fn light_pdf(rs: &RenderScene, t: u32) -> f32 {
    rs.lights.area.as_ref().map_or(0.0, |a| {
        a.triangles
            .binary_search(&t)
            .map_or(0.0, |i| a.selection_pdf(i))
    })
}

/// The area lights' CDF with each light's scene-wide slot from `slot_of` (one zero entry
/// without area lights).
fn area_lights(
    rs: &RenderScene,
    mut slot_of: impl FnMut(u32) -> u32,
) -> Result<Vec<GpuAreaLight>, String> {
    let mut out = Vec::new();
    if let Some(area) = &rs.lights.area {
        for (&t, &cdf) in area.triangles.iter().zip(area.cdf()) {
            let prim = slot_of(t);
            if prim == crate::scene::NO_INDEX {
                return Err(format!(
                    "emissive triangle {t} is not in the BVH; the GPU cannot sample it"
                ));
            }
            out.push(GpuAreaLight { cdf, prim });
        }
    }
    if out.is_empty() {
        out.push(GpuAreaLight::zeroed());
    }
    Ok(out)
}

/// Local triangle `t` of `local` in its own corner order (the order its BVH tests).
fn local_corners(local: &LocalPrimitive, t: usize) -> Corners {
    let idx = local.triangles[t].map(|i| i as usize);
    Corners {
        p: idx.map(|i| local.positions[i]),
        n: idx.map(|i| local.normals.as_ref().map_or(Vec3::ZERO, |n| n[i])),
        uv: idx.map(|i| local.uvs.as_ref().map_or([0.0, 0.0], |uv| uv[i])),
    }
}

/// A placement's record: its transforms as the world arrays and the two-level BVH apply them.
fn gpu_placement(p: &Placed, node_base: u32, prim_base: u32, first_slot: u32) -> GpuPlacement {
    let w = p.world_from_local;
    let l = p.local_from_world;
    // world_mesh's `Placement::normal_from_local`, the same expression.
    let n = Mat3::from_mat4(w).inverse().transpose();
    GpuPlacement {
        world_x: w.x_axis.truncate().to_array(),
        node_base,
        world_y: w.y_axis.truncate().to_array(),
        prim_base,
        world_z: w.z_axis.truncate().to_array(),
        first_slot,
        world_w: w.w_axis.truncate().to_array(),
        first_triangle: p.first_triangle,
        local_x: l.matrix3.x_axis.to_array(),
        flags: if p.mirrored { PLACEMENT_MIRRORED } else { 0 },
        local_y: l.matrix3.y_axis.to_array(),
        local_z: l.matrix3.z_axis.to_array(),
        local_w: l.translation.to_array(),
        normal_x: n.x_axis.to_array(),
        normal_y: n.y_axis.to_array(),
        normal_z: n.z_axis.to_array(),
        ..GpuPlacement::zeroed()
    }
}
