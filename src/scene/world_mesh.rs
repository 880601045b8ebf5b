//! The meshes as the frame places them: the world-space vertex and triangle arrays the GPU,
//! Embree and the exporters read, and single triangles placed on demand for the CPU's shading.
//!
//! Where a two-level BVH answers the CPU's ray queries, the scene keeps each stored primitive
//! once in its local space and builds the world arrays only when something asks for them whole
//! (the GPU's upload, Embree, an exporter): a render on the CPU then never holds a copy of
//! every placed triangle. A single triangle is placed by the same arithmetic that builds the
//! arrays, so its corners, normals and texture coordinates are the arrays' bit for bit.
use std::sync::OnceLock;

use glam::{Mat3, Mat4, Vec3};

use super::mesh::{LocalPrimitive, Triangle, Vertex};
use crate::accel::instanced::ShapePlacement;

/// One instance as its triangles are placed: its primitive, its transforms, and where its
/// triangles and vertices start in the world arrays.
#[derive(Clone, Copy, Debug)]
struct Placement {
    shape: u32,
    world_from_local: Mat4,
    /// Normals map by the inverse transpose.
    normal_from_local: Mat3,
    /// A mirroring transform flips the winding; two corners swap to keep triangles
    /// counter-clockwise, as the glTF specification asks.
    mirrored: bool,
    first_triangle: u32,
    first_vertex: u32,
}

impl Placement {
    fn new(p: &ShapePlacement, first_vertex: u32) -> Self {
        let world = p.world_from_local;
        Self {
            shape: p.shape,
            world_from_local: world,
            normal_from_local: Mat3::from_mat4(world).inverse().transpose(),
            mirrored: world.determinant() < 0.0,
            first_triangle: p.first_triangle,
            first_vertex,
        }
    }

    /// World-space vertex `k` of `local`.
    fn vertex(&self, local: &LocalPrimitive, k: usize) -> Vertex {
        let n = local.normals.as_ref().map_or(Vec3::ZERO, |ns| {
            (self.normal_from_local * ns[k]).normalize_or_zero()
        });
        let [u, v] = local.uvs.as_ref().map_or([0.0, 0.0], |uv| uv[k]);
        Vertex {
            position: self
                .world_from_local
                .transform_point3(local.positions[k])
                .to_array(),
            u,
            normal: n.to_array(),
            v,
        }
    }

    /// A local triangle's vertex indices in world corner order.
    fn corner_order(&self, t: [u32; 3]) -> [u32; 3] {
        if self.mirrored {
            [t[0], t[2], t[1]]
        } else {
            t
        }
    }
}

/// The world-space arrays: every placement's vertices and triangles, in instance order.
#[derive(Clone, Debug, Default)]
pub struct WorldArrays {
    pub vertices: Vec<Vertex>,
    pub triangles: Vec<Triangle>,
}

/// The scene's meshes in world space: the arrays where built, else the stored primitives and
/// their placements they are built from.
#[derive(Debug, Default)]
pub struct WorldMesh {
    /// Each stored primitive in its local space (`ShapePlacement::shape` indexes it); empty
    /// once the arrays alone are kept ([`WorldMesh::keep_arrays_only`]).
    locals: Vec<LocalPrimitive>,
    /// Per instance, in the scene's instance order.
    placements: Vec<Placement>,
    arrays: OnceLock<WorldArrays>,
    triangles: usize,
    vertices: usize,
}

impl WorldMesh {
    /// The meshes of `locals` placed by `placements` (one per instance, in instance order,
    /// their triangles consecutive from 0). Builds nothing yet.
    pub fn new(locals: Vec<LocalPrimitive>, placements: &[ShapePlacement]) -> Self {
        let mut vertices = 0usize;
        let mut triangles = 0usize;
        let placements = placements
            .iter()
            .map(|p| {
                let local = &locals[p.shape as usize];
                let placed = Placement::new(p, vertices as u32);
                vertices += local.positions.len();
                triangles += local.triangles.len();
                placed
            })
            .collect();
        Self {
            locals,
            placements,
            arrays: OnceLock::new(),
            triangles,
            vertices,
        }
    }

    /// Builds the world arrays and drops the stored primitives: what a scene traced through
    /// the flat BVH keeps.
    pub fn keep_arrays_only(&mut self) {
        self.arrays();
        self.locals = Vec::new();
    }

    /// The world arrays, built on first use.
    pub fn arrays(&self) -> &WorldArrays {
        self.arrays.get_or_init(|| self.build())
    }

    /// The world arrays where they have been built.
    pub fn built(&self) -> Option<&WorldArrays> {
        self.arrays.get()
    }

    fn build(&self) -> WorldArrays {
        let mut out = WorldArrays {
            vertices: Vec::with_capacity(self.vertices),
            triangles: Vec::with_capacity(self.triangles),
        };
        for (instance, p) in self.placements.iter().enumerate() {
            let local = &self.locals[p.shape as usize];
            out.vertices
                .extend((0..local.positions.len()).map(|k| p.vertex(local, k)));
            out.triangles
                .extend(local.triangles.iter().map(|t| Triangle {
                    vertices: p.corner_order(*t).map(|i| p.first_vertex + i),
                    instance: instance as u32,
                }));
        }
        out
    }

    /// Triangles placed in the world, every placement counted.
    pub fn triangle_count(&self) -> usize {
        self.triangles
    }

    /// Vertices placed in the world, every placement counted.
    pub fn vertex_count(&self) -> usize {
        self.vertices
    }

    /// The stored primitives, local space, indexed by `ShapePlacement::shape`; empty once the
    /// arrays alone are kept.
    pub fn locals(&self) -> &[LocalPrimitive] {
        &self.locals
    }

    /// Bytes of the stored primitives kept to place triangles from (none once the arrays
    /// alone are kept).
    pub fn stored_bytes(&self) -> usize {
        self.locals
            .iter()
            .map(|l| {
                std::mem::size_of_val(&l.positions[..])
                    + l.normals
                        .as_ref()
                        .map_or(0, |n| std::mem::size_of_val(&n[..]))
                    + l.uvs.as_ref().map_or(0, |u| std::mem::size_of_val(&u[..]))
                    + std::mem::size_of_val(&l.triangles[..])
            })
            .sum::<usize>()
            + std::mem::size_of_val(&self.placements[..])
    }

    /// The instance of world triangle `t`.
    #[inline]
    pub fn instance_of(&self, t: usize) -> u32 {
        match self.arrays.get() {
            Some(a) => a.triangles[t].instance,
            None => self.placement_of(t) as u32,
        }
    }

    fn placement_of(&self, t: usize) -> usize {
        // Instances without triangles share their successor's start; the last instance
        // starting at or before `t` is the one holding it.
        self.placements
            .partition_point(|p| p.first_triangle as usize <= t)
            - 1
    }

    /// The three world-space vertices of triangle `t`, in its corner order.
    #[inline]
    pub fn corners(&self, t: usize) -> [Vertex; 3] {
        if let Some(a) = self.arrays.get() {
            return a.triangles[t].vertices.map(|i| a.vertices[i as usize]);
        }
        let (p, local, tri) = self.placed_triangle(t);
        tri.map(|i| p.vertex(local, i as usize))
    }

    /// The three world-space corner positions of triangle `t`, in its corner order: what
    /// [`WorldMesh::corners`] gives, without placing normals and texture coordinates.
    #[inline]
    pub fn corner_positions(&self, t: usize) -> [Vec3; 3] {
        if let Some(a) = self.arrays.get() {
            return a.triangles[t]
                .vertices
                .map(|i| Vec3::from(a.vertices[i as usize].position));
        }
        let (p, local, tri) = self.placed_triangle(t);
        tri.map(|i| {
            p.world_from_local
                .transform_point3(local.positions[i as usize])
        })
    }

    /// Triangle `t`'s placement, stored primitive and local vertex indices in world corner
    /// order, where the arrays are not built.
    fn placed_triangle(&self, t: usize) -> (&Placement, &LocalPrimitive, [u32; 3]) {
        let p = &self.placements[self.placement_of(t)];
        let local = &self.locals[p.shape as usize];
        (
            p,
            local,
            p.corner_order(local.triangles[t - p.first_triangle as usize]),
        )
    }

    /// Calls `f` with every placed vertex's world position, without building the arrays.
    pub fn for_each_position(&self, mut f: impl FnMut(Vec3)) {
        if let Some(a) = self.arrays.get() {
            a.vertices.iter().for_each(|v| f(Vec3::from(v.position)));
            return;
        }
        for p in &self.placements {
            let local = &self.locals[p.shape as usize];
            for &q in &local.positions {
                f(p.world_from_local.transform_point3(q));
            }
        }
    }

    /// Checks what placing triangles relies on: the arrays' indices where built, else each
    /// stored primitive's indices and finite data and each placement's primitive.
    pub fn validate(&self) -> Result<(), String> {
        let finite = |xs: &[f32]| xs.iter().all(|x| x.is_finite());
        if let Some(a) = self.arrays.get() {
            for (k, v) in a.vertices.iter().enumerate() {
                if !finite(&v.position)
                    || !finite(&v.normal)
                    || !v.u.is_finite()
                    || !v.v.is_finite()
                {
                    return Err(format!("vertex {k} is not finite"));
                }
            }
            for (k, t) in a.triangles.iter().enumerate() {
                if t.vertices.iter().any(|&i| i as usize >= a.vertices.len())
                    || t.instance as usize >= self.placements.len()
                {
                    return Err(format!("triangle {k} indexes out of range"));
                }
            }
            return Ok(());
        }
        for (k, l) in self.locals.iter().enumerate() {
            let n = l.positions.len();
            if l.positions.iter().any(|p| !p.is_finite())
                || l.normals
                    .as_ref()
                    .is_some_and(|ns| ns.len() != n || ns.iter().any(|v| !v.is_finite()))
                || l.uvs
                    .as_ref()
                    .is_some_and(|uv| uv.len() != n || uv.iter().any(|c| !finite(c)))
                || l.triangles.iter().flatten().any(|&i| i as usize >= n)
            {
                return Err(format!("stored primitive {k} is inconsistent"));
            }
        }
        if self
            .placements
            .iter()
            .any(|p| p.shape as usize >= self.locals.len())
        {
            return Err("a placement names a primitive that is not stored".into());
        }
        Ok(())
    }
}
