//! Triangle meshes as a glTF file places them: each distinct primitive read once in its mesh's
//! local space, and one instance record and transform per (node, primitive) placement, each
//! `EXT_mesh_gpu_instancing` row one more. The vertex, triangle and instance records are laid
//! out for direct upload to the GPU; [`super::world_mesh`] places the primitives in world space.
//!
//! Points and lines have no surface to scatter from, so such primitives are skipped with a
//! warning rather than rejected; triangle strips and fans are unrolled into triangles.
use bytemuck::{Pod, Zeroable};
use glam::{Vec3, Vec3A};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;

use std::collections::hash_map::{Entry, HashMap};

use super::accessor::check_accessor;
use super::error::{Ctx, SceneError};
use super::gpu_instancing::instance_transforms;
use super::nodes::PlacedNode;
use super::NO_INDEX;
use crate::accel::instanced::ShapePlacement;

/// One world-space vertex, 32 bytes (two vec4s in WGSL: `position.xyz, u` and `normal.xyz, v`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Vertex {
    /// World-space position, metres.
    pub position: [f32; 3],
    /// First texture coordinate (TEXCOORD_0), u.
    pub u: f32,
    /// World-space unit shading normal; all zero when the file gives none (use the geometric
    /// normal then).
    pub normal: [f32; 3],
    /// First texture coordinate (TEXCOORD_0), v.
    pub v: f32,
}

/// One triangle, 16 bytes. Counter-clockwise seen from its front, also when the node's
/// transform mirrors (the loader swaps two indices then, as the glTF spec asks).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct Triangle {
    /// Indices into `Scene::vertices`.
    pub vertices: [u32; 3],
    /// Index into `Scene::instances`.
    pub instance: u32,
}

/// One glTF primitive placed by one node, 32 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct Instance {
    /// Index into `Scene::materials`.
    pub material: u32,
    /// First triangle of this instance in `Scene::triangles`.
    pub first_triangle: u32,
    /// Number of triangles.
    pub triangle_count: u32,
    /// glTF node index that placed it.
    pub node: u32,
    /// glTF mesh index.
    pub mesh: u32,
    /// Primitive index within the mesh.
    pub primitive: u32,
    /// Explicit padding to a 16-byte multiple.
    pub _pad: [u32; 2],
}

const _: () = assert!(std::mem::size_of::<Vertex>() == 32);
const _: () = assert!(std::mem::size_of::<Triangle>() == 16);
const _: () = assert!(std::mem::size_of::<Instance>() == 32);

/// The meshes of a scene as read: each distinct primitive once in its local space, and each
/// (node, primitive) placement as an instance record and a transform. [`super::world_mesh`]
/// places them in world space.
#[derive(Clone, Debug, Default)]
pub struct Geometry {
    pub instances: Vec<Instance>,
    /// Each distinct primitive in its mesh's local space, once however many nodes place it
    /// (local triangle `k` is triangle `k` of each of its instances).
    pub locals: Vec<LocalPrimitive>,
    /// Per instance (`instances` order): its primitive (index into `locals`) and world
    /// transform.
    pub placements: Vec<ShapePlacement>,
}

/// Whether some of `placements` places a primitive more than once, so that a two-level BVH
/// stores fewer triangles than the flat one.
pub fn repeats_a_shape(placements: &[ShapePlacement]) -> bool {
    let shapes = placements
        .iter()
        .map(|p| p.shape as usize + 1)
        .max()
        .unwrap_or(0);
    let mut placed = vec![false; shapes];
    placements
        .iter()
        .any(|p| std::mem::replace(&mut placed[p.shape as usize], true))
}

/// Flattens every mesh placed by `nodes`, each `EXT_mesh_gpu_instancing` row as one more
/// placement. Each primitive is read once however many nodes place it. `default_material` is
/// used by primitives without one.
pub fn flatten(
    ctx: &mut Ctx,
    doc: &gltf::Document,
    buffers: &[Vec<u8>],
    nodes: &[PlacedNode],
    default_material: u32,
) -> Result<Geometry, SceneError> {
    let mut geo = Geometry::default();
    // World-space vertices and triangles the placements make, which 32-bit indices address.
    let (mut vertices, mut triangles) = (0usize, 0usize);
    // Each primitive read once: its shape's index where it has triangles.
    let mut read: HashMap<(usize, usize), Option<u32>> = HashMap::new();
    for placed in nodes {
        let node = placed.in_doc(doc);
        let locals = instance_transforms(ctx, doc, buffers, &node)?;
        let Some(mesh) = node.mesh() else { continue };
        for prim in mesh.primitives() {
            let key = (mesh.index(), prim.index());
            let shape = match read.entry(key) {
                Entry::Occupied(e) => *e.get(),
                Entry::Vacant(e) => {
                    let pointer = format!("/meshes/{}/primitives/{}", key.0, key.1);
                    let local = read_primitive(ctx, buffers, &prim, &pointer)
                        .map_err(|e| placed_by(e, &node))?;
                    *e.insert(local.map(|local| {
                        geo.locals.push(local);
                        geo.locals.len() as u32 - 1
                    }))
                }
            };
            let Some(shape) = shape else {
                continue;
            };
            let local = &geo.locals[shape as usize];
            let (n_vertices, n_triangles) = (local.positions.len(), local.triangles.len());
            let material = prim
                .material()
                .index()
                .map_or(default_material, |m| m as u32);
            for local_from_instance in &locals {
                let fits = |have: usize, more: usize| {
                    have.checked_add(more)
                        .is_some_and(|n| n <= NO_INDEX as usize)
                };
                if !fits(vertices, n_vertices) || !fits(triangles, n_triangles) {
                    return Err(ctx.invalid(
                        format!("/nodes/{}/mesh", node.index()),
                        format!(
                            "{}: placing mesh {} primitive {} again makes more than 2^32 - 1 \
                             world-space vertices or triangles ({} and {} so far), more than \
                             Brume's 32-bit indices address",
                            node_label(&node),
                            key.0,
                            key.1,
                            vertices,
                            triangles
                        ),
                    ));
                }
                geo.placements.push(ShapePlacement {
                    shape,
                    world_from_local: placed.world_from_node * *local_from_instance,
                    first_triangle: triangles as u32,
                });
                geo.instances.push(Instance {
                    material,
                    first_triangle: triangles as u32,
                    triangle_count: n_triangles as u32,
                    node: placed.node as u32,
                    mesh: key.0 as u32,
                    primitive: key.1 as u32,
                    _pad: [0; 2],
                });
                vertices += n_vertices;
                triangles += n_triangles;
            }
        }
    }
    Ok(geo)
}

/// `node 3 "rock"`, or `node 3` for a node without a name: how messages name a node.
pub fn node_label(node: &gltf::Node) -> String {
    match node.name() {
        Some(name) => format!("node {} {name:?}", node.index()),
        None => format!("node {}", node.index()),
    }
}

/// Adds the node that places a primitive to an error met while reading it.
fn placed_by(e: SceneError, node: &gltf::Node) -> SceneError {
    match e {
        SceneError::Invalid {
            file,
            pointer,
            message,
        } => SceneError::Invalid {
            file,
            pointer,
            message: format!("{message} (primitive placed by {})", node_label(node)),
        },
        other => other,
    }
}

/// A primitive in its mesh's local space.
#[derive(Clone, Debug, Default)]
pub struct LocalPrimitive {
    pub positions: Vec<Vec3>,
    pub normals: Option<Vec<Vec3>>,
    pub uvs: Option<Vec<[f32; 2]>>,
    /// Triangle list, counter-clockwise.
    pub triangles: Vec<[u32; 3]>,
}

/// Reads one primitive, checking every accessor it uses. `None` for points and lines.
pub fn read_primitive(
    ctx: &mut Ctx,
    buffers: &[Vec<u8>],
    prim: &gltf::Primitive,
    pointer: &str,
) -> Result<Option<LocalPrimitive>, SceneError> {
    let mode = prim.mode();
    if matches!(
        mode,
        Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip
    ) {
        ctx.warn(
            format!("{pointer}/mode"),
            format!("{mode:?} primitives have no surface; skipped"),
        );
        return Ok(None);
    }
    let src = PrimitiveSource {
        prim,
        buffers,
        pointer,
    };
    src.check_u32_counts(ctx)?;
    let positions = src.positions(ctx)?;
    let n = positions.len();
    let normals = src.normals(ctx, n)?;
    let uvs = src.uvs(ctx, n)?;
    let indices = src.indices(ctx, n)?;
    let mut triangles = assemble(mode, &indices);
    let all = triangles.len();
    triangles.retain(|t| {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        (b - a).cross(c - a) != Vec3::ZERO
    });
    if triangles.len() < all {
        ctx.warn(
            pointer,
            format!(
                "{} of {all} triangles are degenerate (zero area) and were skipped",
                all - triangles.len()
            ),
        );
    }
    if triangles.is_empty() && all == 0 {
        ctx.warn(pointer, "primitive has no complete triangle");
    }
    Ok(Some(LocalPrimitive {
        positions,
        normals,
        uvs,
        triangles,
    }))
}

/// A primitive being read: the glTF primitive, the file's buffers and its JSON pointer.
struct PrimitiveSource<'a> {
    prim: &'a gltf::Primitive<'a>,
    buffers: &'a [Vec<u8>],
    pointer: &'a str,
}

impl<'a> PrimitiveSource<'a> {
    fn reader(
        &self,
    ) -> gltf::mesh::Reader<'a, 'a, impl Clone + Fn(gltf::Buffer<'a>) -> Option<&'a [u8]>> {
        let buffers = self.buffers;
        self.prim
            .reader(move |b| buffers.get(b.index()).map(|v| v.as_slice()))
    }

    /// Refuses vertex and index counts that 32-bit indices cannot address, before any
    /// accessor is read (a declared count alone may be that large).
    fn check_u32_counts(&self, ctx: &Ctx) -> Result<(), SceneError> {
        let attributes = self
            .prim
            .attributes()
            .map(|(semantic, acc)| (format!("attributes/{}", semantic.to_string()), acc));
        let indices = self.prim.indices().map(|acc| ("indices".to_string(), acc));
        for (name, acc) in attributes.chain(indices) {
            if acc.count() > NO_INDEX as usize {
                return Err(ctx.invalid(
                    format!("{}/{name}", self.pointer),
                    format!(
                        "accessor {} holds {} elements, more than Brume's 32-bit indices \
                         address (2^32 - 1); split the mesh into primitives",
                        acc.index(),
                        acc.count()
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The POSITION attribute, which the primitive must have, as finite f32 vectors.
    fn positions(&self, ctx: &mut Ctx) -> Result<Vec<Vec3>, SceneError> {
        let pointer = self.pointer;
        let Some(acc) = self.prim.get(&gltf::Semantic::Positions) else {
            return Err(ctx.invalid(
                format!("{pointer}/attributes"),
                "primitive has no POSITION attribute",
            ));
        };
        let at = format!("{pointer}/attributes/POSITION");
        check_accessor(ctx, &acc, &at, &[DataType::F32], Dimensions::Vec3)?;
        let positions: Vec<Vec3> = self
            .reader()
            .read_positions()
            .map(|it| it.map(Vec3::from).collect())
            .unwrap_or_default();
        if let Some(k) = positions.iter().position(|p| !p.is_finite()) {
            return Err(ctx.invalid(
                at,
                format!(
                    "vertex {k} has a non-finite position (accessor {})",
                    acc.index()
                ),
            ));
        }
        Ok(positions)
    }

    /// The optional NORMAL attribute: finite f32 vectors, one per position (`n`).
    fn normals(&self, ctx: &mut Ctx, n: usize) -> Result<Option<Vec<Vec3>>, SceneError> {
        let semantic = gltf::Semantic::Normals;
        let Some(at) = self.optional(ctx, semantic, &[DataType::F32], Dimensions::Vec3)? else {
            return Ok(None);
        };
        let v: Vec<Vec3> = self
            .reader()
            .read_normals()
            .map(|it| it.map(Vec3::from).collect())
            .unwrap_or_default();
        per_vertex(ctx, at, v, n, |x| x.is_finite())
    }

    /// The optional TEXCOORD_0 attribute (f32, or normalized u8 or u16): finite coordinates,
    /// one per position (`n`).
    fn uvs(&self, ctx: &mut Ctx, n: usize) -> Result<Option<Vec<[f32; 2]>>, SceneError> {
        let types = [DataType::F32, DataType::U8, DataType::U16];
        let semantic = gltf::Semantic::TexCoords(0);
        let Some(at) = self.optional(ctx, semantic, &types, Dimensions::Vec2)? else {
            return Ok(None);
        };
        let v: Vec<[f32; 2]> = self
            .reader()
            .read_tex_coords(0)
            .map(|it| it.into_f32().collect())
            .unwrap_or_default();
        per_vertex(ctx, at, v, n, |x| x[0].is_finite() && x[1].is_finite())
    }

    /// The JSON pointer of the optional attribute `semantic` once its accessor is checked
    /// (one of `types`, `dims`); `None` when the primitive has none.
    fn optional(
        &self,
        ctx: &mut Ctx,
        semantic: gltf::Semantic,
        types: &[DataType],
        dims: Dimensions,
    ) -> Result<Option<String>, SceneError> {
        let name = semantic.to_string();
        let Some(acc) = self.prim.get(&semantic) else {
            return Ok(None);
        };
        let at = format!("{}/attributes/{name}", self.pointer);
        check_accessor(ctx, &acc, &at, types, dims)?;
        Ok(Some(at))
    }

    /// The indices, each below the vertex count `n`; `0..n` when the primitive has none.
    fn indices(&self, ctx: &mut Ctx, n: usize) -> Result<Vec<u32>, SceneError> {
        let Some(acc) = self.prim.indices() else {
            return Ok((0..n as u32).collect());
        };
        let at = format!("{}/indices", self.pointer);
        let types = [DataType::U8, DataType::U16, DataType::U32];
        check_accessor(ctx, &acc, &at, &types, Dimensions::Scalar)?;
        let v: Vec<u32> = self
            .reader()
            .read_indices()
            .map(|it| it.into_u32().collect())
            .unwrap_or_default();
        if let Some(bad) = v.iter().find(|&&i| i as usize >= n) {
            return Err(ctx.invalid(at, format!("index {bad} is out of range for {n} vertices")));
        }
        Ok(v)
    }
}

/// The values `v` of the attribute at JSON pointer `at`: one finite value per position (`n`).
fn per_vertex<T>(
    ctx: &mut Ctx,
    at: String,
    v: Vec<T>,
    n: usize,
    finite: impl Fn(&T) -> bool,
) -> Result<Option<Vec<T>>, SceneError> {
    if v.len() != n || !v.iter().all(finite) {
        let name = at.rsplit('/').next().unwrap_or_default().to_string();
        return Err(ctx.invalid(
            at,
            format!("{name} count differs from POSITION or holds non-finite values"),
        ));
    }
    Ok(Some(v))
}

/// The corner positions of a local primitive's triangles, in its order.
impl LocalPrimitive {
    /// The triangles' corners, local space, as the two-level BVH takes them.
    pub fn corners(&self) -> Vec<[Vec3A; 3]> {
        self.triangles
            .iter()
            .map(|t| t.map(|i| Vec3A::from(self.positions[i as usize])))
            .collect()
    }
}

/// Triangle list from a triangle list, strip or fan (glTF spec, section 3.7.2.1).
fn assemble(mode: Mode, idx: &[u32]) -> Vec<[u32; 3]> {
    match mode {
        Mode::TriangleStrip => (2..idx.len())
            .map(|i| {
                if i % 2 == 0 {
                    [idx[i - 2], idx[i - 1], idx[i]]
                } else {
                    [idx[i - 1], idx[i - 2], idx[i]]
                }
            })
            .collect(),
        Mode::TriangleFan => (2..idx.len())
            .map(|i| [idx[i - 1], idx[i], idx[0]])
            .collect(),
        _ => idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
    }
}
