//! The node hierarchy of the chosen glTF scene, flattened to one world matrix per node.
use glam::{Mat4, Quat, Vec3};

use super::animation::{Pose, Trs};
use super::error::{Ctx, SceneError};
use super::json::check_all;

/// A node reached from the scene's roots, with its world transform.
#[derive(Clone, Copy, Debug)]
pub struct PlacedNode {
    /// Index into the glTF `nodes` array.
    pub node: usize,
    /// world_from_node: the product of the local matrices from the root down.
    pub world_from_node: Mat4,
}

impl PlacedNode {
    /// The glTF node this is a placement of.
    pub fn in_doc<'a>(&self, doc: &'a gltf::Document) -> gltf::Node<'a> {
        doc.nodes()
            .nth(self.node)
            .expect("placed node index comes from the document")
    }
}

/// Smallest |det| accepted for a node's local 3x3 part. glTF units are metres; a scale of
/// 1e-4 on every axis (det 1e-12) is still a valid, if odd, transform.
pub(super) const MIN_ABS_DET: f32 = 1e-15;

/// Walks the scene chosen by the file (`scene`, else scene 0) depth first, in document order,
/// each node in its own transform with the animated parts of `pose` in place of its own.
pub fn place_nodes(
    ctx: &mut Ctx,
    doc: &gltf::Document,
    pose: &Pose,
) -> Result<Vec<PlacedNode>, SceneError> {
    let scene = match doc.default_scene().or_else(|| doc.scenes().next()) {
        Some(s) => s,
        None => {
            return Err(ctx.invalid(
                "/scenes",
                "the file defines no scene, so nothing would be rendered",
            ))
        }
    };
    let mut seen = vec![false; doc.nodes().len()];
    let mut out = Vec::new();
    // Explicit stack: a malicious file cannot overflow the call stack with deep nesting.
    let mut stack: Vec<(gltf::Node, Mat4, String)> = scene
        .nodes()
        .map(|n| {
            (
                n,
                Mat4::IDENTITY,
                format!("/scenes/{}/nodes", scene.index()),
            )
        })
        .collect();
    stack.reverse();
    while let Some((node, parent, via)) = stack.pop() {
        let i = node.index();
        if std::mem::replace(&mut seen[i], true) {
            return Err(ctx.invalid(
                via,
                format!("node {i} is reached twice: glTF node hierarchies must be disjoint trees"),
            ));
        }
        let world = parent * local_matrix(ctx, &node, pose.get(&i))?;
        if !world.is_finite() {
            return Err(ctx.invalid(
                format!("/nodes/{i}"),
                "world transform overflows to a non-finite value",
            ));
        }
        out.push(PlacedNode {
            node: i,
            world_from_node: world,
        });
        let children: Vec<_> = node.children().collect();
        for child in children.into_iter().rev() {
            stack.push((child, world, format!("/nodes/{i}/children")));
        }
    }
    Ok(out)
}

/// node_from_child: `matrix`, or `T * R * S` as the glTF spec defines, with the animated
/// parts of `animated` in place of the node's own. Rejects non-finite and singular
/// transforms, naming the offending property.
pub fn local_matrix(
    ctx: &Ctx,
    node: &gltf::Node,
    animated: Option<&Trs>,
) -> Result<Mat4, SceneError> {
    let i = node.index();
    match node.transform() {
        gltf::scene::Transform::Matrix { matrix } => {
            let flat: [f32; 16] = bytemuck::cast(matrix);
            check_all(ctx, flat, &format!("/nodes/{i}/matrix"), f32::MIN, f32::MAX)?;
            let m = Mat4::from_cols_array_2d(&matrix);
            if m.determinant().abs() < MIN_ABS_DET {
                return Err(ctx.invalid(
                    format!("/nodes/{i}/matrix"),
                    "matrix is not invertible (determinant ~ 0)",
                ));
            }
            Ok(m)
        }
        gltf::scene::Transform::Decomposed {
            translation,
            rotation,
            scale,
        } => {
            check_all(
                ctx,
                translation,
                &format!("/nodes/{i}/translation"),
                f32::MIN,
                f32::MAX,
            )?;
            check_all(ctx, rotation, &format!("/nodes/{i}/rotation"), -2.0, 2.0)?;
            check_all(ctx, scale, &format!("/nodes/{i}/scale"), f32::MIN, f32::MAX)?;
            let a = animated.copied().unwrap_or_default();
            let s = a.scale.unwrap_or(Vec3::from(scale));
            if (s.x * s.y * s.z).abs() < MIN_ABS_DET {
                return Err(ctx.invalid(
                    format!("/nodes/{i}/scale"),
                    format!("scale {s:?} makes the transform non-invertible"),
                ));
            }
            let q = a.rotation.unwrap_or(Quat::from_array(rotation));
            let len = q.length();
            if (len - 1.0).abs() > 1e-3 {
                return Err(ctx.invalid(
                    format!("/nodes/{i}/rotation"),
                    format!("quaternion has length {len}, glTF requires a unit quaternion"),
                ));
            }
            Ok(Mat4::from_scale_rotation_translation(
                s,
                q.normalize(),
                a.translation.unwrap_or(Vec3::from(translation)),
            ))
        }
    }
}
