//! `EXT_mesh_gpu_instancing`: a node that places its mesh once per row of its `TRANSLATION`,
//! `ROTATION` and `SCALE` accessors, each row a transform under the node's own
//! (`world_from_node * T * R * S`), so thousands of copies of a mesh cost one node.
//!
//! Attributes whose names start with `_` are the application's own and ignored, as the
//! extension allows; any other attribute is ignored with a warning.
use glam::{Mat4, Quat, Vec3};
use gltf::accessor::{DataType, Dimensions};
use serde_json::Value;

use super::accessor::check_accessor;
use super::error::{Ctx, SceneError};
use super::nodes::MIN_ABS_DET;

/// The extension's name, as a node lists it under `extensions`.
pub const EXT_MESH_GPU_INSTANCING: &str = "EXT_mesh_gpu_instancing";

/// The node-local transforms of the instances `node` places: one per row of its
/// `EXT_mesh_gpu_instancing` accessors, or the identity alone for a node without the extension.
pub fn instance_transforms(
    ctx: &mut Ctx,
    doc: &gltf::Document,
    buffers: &[Vec<u8>],
    node: &gltf::Node,
) -> Result<Vec<Mat4>, SceneError> {
    let Some(ext) = node.extension_value(EXT_MESH_GPU_INSTANCING) else {
        return Ok(vec![Mat4::IDENTITY]);
    };
    let here = format!(
        "/nodes/{}/extensions/{EXT_MESH_GPU_INSTANCING}",
        node.index()
    );
    if node.mesh().is_none() {
        ctx.warn(&here, "the node has no mesh to instance; ignored");
        return Ok(Vec::new());
    }
    let Some(attributes) = ext.get("attributes").and_then(Value::as_object) else {
        return Err(ctx.invalid(
            format!("{here}/attributes"),
            "expected an object of TRANSLATION, ROTATION and SCALE accessors",
        ));
    };
    for key in attributes.keys() {
        if !key.starts_with('_') && !["TRANSLATION", "ROTATION", "SCALE"].contains(&key.as_str()) {
            ctx.warn(
                format!("{here}/attributes/{key}"),
                "unknown attribute, ignored",
            );
        }
    }
    let rows = Rows {
        doc,
        buffers,
        attributes,
        pointer: format!("{here}/attributes"),
    };
    let translation = rows.read::<3>(ctx, "TRANSLATION")?;
    let rotation = rows.read::<4>(ctx, "ROTATION")?;
    let scale = rows.read::<3>(ctx, "SCALE")?;
    let counts: Vec<(&str, usize)> = [
        ("TRANSLATION", translation.as_ref().map(Vec::len)),
        ("ROTATION", rotation.as_ref().map(Vec::len)),
        ("SCALE", scale.as_ref().map(Vec::len)),
    ]
    .into_iter()
    .filter_map(|(name, n)| Some((name, n?)))
    .collect();
    let Some(&(_, count)) = counts.first() else {
        return Err(ctx.invalid(
            format!("{here}/attributes"),
            "names none of TRANSLATION, ROTATION and SCALE",
        ));
    };
    if let Some((name, n)) = counts.iter().find(|(_, n)| *n != count) {
        return Err(ctx.invalid(
            format!("{here}/attributes/{name}"),
            format!(
                "holds {n} instances but {} holds {count}: every attribute needs one row per instance",
                counts[0].0
            ),
        ));
    }
    let mut out = Vec::with_capacity(count);
    for k in 0..count {
        let t = translation
            .as_ref()
            .map_or(Vec3::ZERO, |v| Vec3::from(v[k]));
        let q = rotation
            .as_ref()
            .map_or(Quat::IDENTITY, |v| Quat::from_array(v[k]));
        let s = scale.as_ref().map_or(Vec3::ONE, |v| Vec3::from(v[k]));
        if (q.length() - 1.0).abs() > 1e-3 {
            return Err(ctx.invalid(
                format!("{here}/attributes/ROTATION"),
                format!(
                    "instance {k}: quaternion has length {}, glTF requires a unit quaternion",
                    q.length()
                ),
            ));
        }
        if (s.x * s.y * s.z).abs() < MIN_ABS_DET {
            return Err(ctx.invalid(
                format!("{here}/attributes/SCALE"),
                format!("instance {k}: scale {s:?} makes the transform non-invertible"),
            ));
        }
        out.push(Mat4::from_scale_rotation_translation(s, q.normalize(), t));
    }
    Ok(out)
}

/// The extension's `attributes` object of one node, with what reading its accessors needs.
struct Rows<'a> {
    doc: &'a gltf::Document,
    buffers: &'a [Vec<u8>],
    attributes: &'a serde_json::Map<String, Value>,
    /// JSON pointer of `attributes`.
    pointer: String,
}

impl Rows<'_> {
    /// The rows of attribute `name` (`N` floats each, all finite), `None` when absent.
    fn read<const N: usize>(
        &self,
        ctx: &Ctx,
        name: &str,
    ) -> Result<Option<Vec<[f32; N]>>, SceneError> {
        let Some(value) = self.attributes.get(name) else {
            return Ok(None);
        };
        let at = format!("{}/{name}", self.pointer);
        let n = self.doc.accessors().len();
        let Some(acc) = value
            .as_u64()
            .and_then(|i| self.doc.accessors().nth(usize::try_from(i).ok()?))
        else {
            return Err(ctx.invalid(
                at,
                format!("expected the index of an accessor (the file has {n}), found {value}"),
            ));
        };
        let dims = if N == 4 {
            Dimensions::Vec4
        } else {
            Dimensions::Vec3
        };
        check_accessor(ctx, &acc, &at, &[DataType::F32], dims)?;
        // check_accessor has placed every row inside its view; `get` still never panics.
        let rows: Option<Vec<[f32; N]>> = acc.view().and_then(|view| {
            let data = self.buffers.get(view.buffer().index())?;
            let data = data.get(view.offset()..view.offset() + view.length())?;
            let stride = view.stride().unwrap_or(4 * N);
            (0..acc.count())
                .map(|k| {
                    let row = data.get(acc.offset() + k * stride..)?;
                    let mut out = [0.0f32; N];
                    for (j, x) in out.iter_mut().enumerate() {
                        *x = f32::from_le_bytes(row.get(4 * j..4 * j + 4)?.try_into().ok()?);
                    }
                    Some(out)
                })
                .collect()
        });
        let Some(rows) = rows else {
            return Err(ctx.invalid(at, "accessor runs past its buffer"));
        };
        if let Some(k) = rows.iter().position(|r| !r.iter().all(|x| x.is_finite())) {
            return Err(ctx.invalid(at, format!("instance {k} holds a non-finite value")));
        }
        Ok(Some(rows))
    }
}
