//! Triangle meshes flattened to world space: one vertex array, one triangle array and one
//! instance record per (node, primitive), laid out for direct upload to the GPU. Beside them,
//! each distinct primitive's triangles in its mesh's local space and each instance's transform,
//! from which the CPU's two-level BVH traces meshes placed many times without their copies.
//!
//! Points and lines have no surface to scatter from, so such primitives are skipped with a
//! warning rather than rejected; triangle strips and fans are unrolled into triangles.
use bytemuck::{Pod, Zeroable};
use glam::{Mat3, Mat4, Vec3, Vec3A};
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

/// Flat mesh arrays of a scene, and the local shapes and placements they were flattened from.
#[derive(Clone, Debug, Default)]
pub struct Geometry {
    pub vertices: Vec<Vertex>,
    pub triangles: Vec<Triangle>,
    pub instances: Vec<Instance>,
    /// Each distinct primitive's triangle corners in its mesh's local space, once however
    /// many nodes place it (local triangle `k` is triangle `k` of each of its instances).
    pub shapes: Vec<Vec<[Vec3A; 3]>>,
    /// Per instance (`instances` order): its shape and world transform.
    pub placements: Vec<ShapePlacement>,
}

impl Geometry {
    /// Whether some primitive is placed more than once, so that a two-level BVH stores fewer
    /// triangles than the flat one.
    pub fn repeats_a_shape(&self) -> bool {
        let mut placed = vec![false; self.shapes.len()];
        self.placements
            .iter()
            .any(|p| std::mem::replace(&mut placed[p.shape as usize], true))
    }
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
    // Each primitive read once: its triangles and, where it has any, its shape's index.
    let mut read: HashMap<(usize, usize), Option<(LocalPrimitive, u32)>> = HashMap::new();
    for placed in nodes {
        let node = placed.in_doc(doc);
        let locals = instance_transforms(ctx, doc, buffers, &node)?;
        let Some(mesh) = node.mesh() else { continue };
        for prim in mesh.primitives() {
            let key = (mesh.index(), prim.index());
            let local = match read.entry(key) {
                Entry::Occupied(e) => e.into_mut(),
                Entry::Vacant(e) => {
                    let pointer = format!("/meshes/{}/primitives/{}", key.0, key.1);
                    let local = read_primitive(ctx, buffers, &prim, &pointer)
                        .map_err(|e| placed_by(e, &node))?;
                    e.insert(local.map(|local| {
                        geo.shapes.push(local_corners(&local));
                        (local, geo.shapes.len() as u32 - 1)
                    }))
                }
            };
            let Some((local, shape)) = local.as_ref() else {
                continue;
            };
            let material = prim
                .material()
                .index()
                .map_or(default_material, |m| m as u32);
            for local_from_instance in &locals {
                let fits = |have: usize, more: usize| {
                    have.checked_add(more)
                        .is_some_and(|n| n <= NO_INDEX as usize)
                };
                if !fits(geo.vertices.len(), local.positions.len())
                    || !fits(geo.triangles.len(), local.triangles.len())
                {
                    return Err(ctx.invalid(
                        format!("/nodes/{}/mesh", node.index()),
                        format!(
                            "{}: placing mesh {} primitive {} again makes more than 2^32 - 1 \
                             world-space vertices or triangles ({} and {} so far), more than \
                             Brume's 32-bit indices address",
                            node_label(&node),
                            key.0,
                            key.1,
                            geo.vertices.len(),
                            geo.triangles.len()
                        ),
                    ));
                }
                let world = placed.world_from_node * *local_from_instance;
                geo.placements.push(ShapePlacement {
                    shape: *shape,
                    world_from_local: world,
                    first_triangle: geo.triangles.len() as u32,
                });
                append(&mut geo, local, world, placed.node, key, material);
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
fn local_corners(local: &LocalPrimitive) -> Vec<[Vec3A; 3]> {
    local
        .triangles
        .iter()
        .map(|t| t.map(|i| Vec3A::from(local.positions[i as usize])))
        .collect()
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

/// Transforms a local primitive to world space by `world` (world_from_local) and appends it
/// as one instance of `(mesh, primitive)` placed by glTF node `node`.
fn append(
    geo: &mut Geometry,
    local: &LocalPrimitive,
    world: Mat4,
    node: usize,
    (mesh, prim): (usize, usize),
    material: u32,
) {
    // Normals transform by the inverse transpose; a mirroring transform flips the winding.
    let normal_from_local = Mat3::from_mat4(world).inverse().transpose();
    let mirrored = world.determinant() < 0.0;
    let base = geo.vertices.len() as u32;
    for (k, p) in local.positions.iter().enumerate() {
        let n = local.normals.as_ref().map_or(Vec3::ZERO, |ns| {
            (normal_from_local * ns[k]).normalize_or_zero()
        });
        let [u, v] = local.uvs.as_ref().map_or([0.0, 0.0], |uv| uv[k]);
        geo.vertices.push(Vertex {
            position: world.transform_point3(*p).to_array(),
            u,
            normal: n.to_array(),
            v,
        });
    }
    let instance = geo.instances.len() as u32;
    let first = geo.triangles.len() as u32;
    for t in &local.triangles {
        let [a, b, c] = if mirrored { [t[0], t[2], t[1]] } else { *t };
        geo.triangles.push(Triangle {
            vertices: [base + a, base + b, base + c],
            instance,
        });
    }
    geo.instances.push(Instance {
        material,
        first_triangle: first,
        triangle_count: local.triangles.len() as u32,
        node: node as u32,
        mesh: mesh as u32,
        primitive: prim as u32,
        _pad: [0; 2],
    });
}
