//! glTF node animations: translation, rotation and scale channels (STEP, LINEAR, CUBICSPLINE)
//! evaluated at one time, as the glTF 2.0 specification defines them (section 3.11 and
//! Appendix C). Every animation of the file applies; times are seconds, and frame `f` of a
//! scene at `fps` frames per second is time `f / fps`, as Blender's glTF exporter writes them.
use std::collections::BTreeMap;

use glam::{Quat, Vec3, Vec4};
use gltf::accessor::{DataType, Dimensions};
use gltf::animation::{Interpolation, Property};

use super::accessor::check_accessor;
use super::error::{Ctx, SceneError};

/// Which part of a node's transform a channel drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Path {
    Translation,
    Rotation,
    Scale,
}

/// One channel: key times (strictly increasing) and values, `x y z w` (`w` unused but for
/// rotations); CUBICSPLINE keys hold three values each (in-tangent, value, out-tangent).
#[derive(Clone, Debug)]
struct Channel {
    node: usize,
    path: Path,
    interpolation: Interpolation,
    times: Vec<f32>,
    values: Vec<Vec4>,
}

/// A node's animated transform parts at one time; `None` keeps the node's own.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Trs {
    pub translation: Option<Vec3>,
    pub rotation: Option<Quat>,
    pub scale: Option<Vec3>,
}

/// Every node's animated parts at one time, by node index.
pub type Pose = BTreeMap<usize, Trs>;

/// The file's animation channels.
#[derive(Clone, Debug, Default)]
pub struct Animations {
    channels: Vec<Channel>,
}

impl Animations {
    /// Whether the file animates any node's transform.
    pub fn is_empty(&self) -> bool {
        self.channels.is_empty()
    }

    /// Every animated node's parts at time `t` (seconds).
    pub fn pose(&self, t: f32) -> Pose {
        let mut pose = Pose::new();
        for c in &self.channels {
            let v = c.sample(t);
            let trs = pose.entry(c.node).or_default();
            match c.path {
                Path::Translation => trs.translation = Some(v.truncate()),
                Path::Rotation => trs.rotation = Some(Quat::from_vec4(v).normalize()),
                Path::Scale => trs.scale = Some(v.truncate()),
            }
        }
        pose
    }
}

impl Channel {
    /// The channel's value at `t`: the first key's before it, the last key's after it.
    fn sample(&self, t: f32) -> Vec4 {
        let n = self.times.len();
        let cubic = self.interpolation == Interpolation::CubicSpline;
        let value = |k: usize| {
            if cubic {
                self.values[3 * k + 1]
            } else {
                self.values[k]
            }
        };
        if n == 1 || t <= self.times[0] {
            return value(0);
        }
        if t >= self.times[n - 1] {
            return value(n - 1);
        }
        // The last key at or before t.
        let k = self.times.partition_point(|&tk| tk <= t) - 1;
        let dt = self.times[k + 1] - self.times[k];
        let u = (t - self.times[k]) / dt;
        match self.interpolation {
            Interpolation::Step => value(k),
            Interpolation::Linear if self.path == Path::Rotation => {
                let (a, b) = (Quat::from_vec4(value(k)), Quat::from_vec4(value(k + 1)));
                Vec4::from(a.slerp(b, u))
            }
            Interpolation::Linear => value(k).lerp(value(k + 1), u),
            Interpolation::CubicSpline => {
                // Hermite with the tangents scaled by the key interval (Appendix C).
                let (u2, u3) = (u * u, u * u * u);
                let out_k = self.values[3 * k + 2];
                let in_k1 = self.values[3 * (k + 1)];
                value(k) * (2.0 * u3 - 3.0 * u2 + 1.0)
                    + out_k * (dt * (u3 - 2.0 * u2 + u))
                    + value(k + 1) * (-2.0 * u3 + 3.0 * u2)
                    + in_k1 * (dt * (u3 - u2))
            }
        }
    }
}

/// Reads and checks every animation channel of `doc` (a morph-target channel is left out with
/// a warning; two channels driving the same part of a node are an error).
pub fn read_animations(
    ctx: &mut Ctx,
    doc: &gltf::Document,
    buffers: &[Vec<u8>],
) -> Result<Animations, SceneError> {
    let mut channels: Vec<Channel> = Vec::new();
    for anim in doc.animations() {
        for channel in anim.channels() {
            let at = format!("/animations/{}/channels/{}", anim.index(), channel.index());
            let node = channel.target().node().index();
            let path = match channel.target().property() {
                Property::Translation => Path::Translation,
                Property::Rotation => Path::Rotation,
                Property::Scale => Path::Scale,
                Property::MorphTargetWeights => {
                    ctx.warn(at, "morph target weights are not animated (ignored)");
                    continue;
                }
            };
            if channels.iter().any(|c| c.node == node && c.path == path) {
                return Err(ctx.invalid(
                    at,
                    format!("a second channel drives the {path:?} of node {node}"),
                ));
            }
            if matches!(
                doc.nodes().nth(node).map(|n| n.transform()),
                Some(gltf::scene::Transform::Matrix { .. })
            ) {
                return Err(ctx.invalid(
                    at,
                    format!("node {node} has a matrix: glTF animates only nodes with TRS"),
                ));
            }
            channels.push(read_channel(ctx, &channel, buffers, node, path, &at)?);
        }
    }
    Ok(Animations { channels })
}

/// One channel's keys, checked: finite, strictly increasing times, one value per key (three
/// for CUBICSPLINE), finite values.
fn read_channel(
    ctx: &mut Ctx,
    channel: &gltf::animation::Channel,
    buffers: &[Vec<u8>],
    node: usize,
    path: Path,
    at: &str,
) -> Result<Channel, SceneError> {
    let sampler = channel.sampler();
    let interpolation = sampler.interpolation();
    check_accessor(
        ctx,
        &sampler.input(),
        at,
        &[DataType::F32],
        Dimensions::Scalar,
    )?;
    let (types, dims): (&[DataType], _) = match path {
        Path::Rotation => (
            &[
                DataType::F32,
                DataType::I8,
                DataType::U8,
                DataType::I16,
                DataType::U16,
            ],
            Dimensions::Vec4,
        ),
        _ => (&[DataType::F32], Dimensions::Vec3),
    };
    check_accessor(ctx, &sampler.output(), at, types, dims)?;
    let reader = channel.reader(|b| buffers.get(b.index()).map(|v| v.as_slice()));
    let times: Vec<f32> = reader
        .read_inputs()
        .map(|i| i.collect())
        .unwrap_or_default();
    use gltf::animation::util::ReadOutputs;
    let values: Vec<Vec4> = match reader.read_outputs() {
        Some(ReadOutputs::Translations(v)) | Some(ReadOutputs::Scales(v)) => {
            v.map(|x| Vec3::from(x).extend(0.0)).collect()
        }
        Some(ReadOutputs::Rotations(r)) => r.into_f32().map(Vec4::from).collect(),
        _ => Vec::new(),
    };
    let per_key = if interpolation == Interpolation::CubicSpline {
        3
    } else {
        1
    };
    if times.is_empty() || values.len() != per_key * times.len() {
        return Err(ctx.invalid(
            at,
            format!(
                "{} key times and {} values: {interpolation:?} needs {per_key} value(s) per key",
                times.len(),
                values.len()
            ),
        ));
    }
    if let Some(k) = times
        .iter()
        .enumerate()
        .position(|(k, &t)| !t.is_finite() || (k > 0 && t <= times[k - 1]))
    {
        return Err(ctx.invalid(
            at,
            format!(
                "key time {k} ({}) is not finite or not after the one before",
                times[k]
            ),
        ));
    }
    if let Some(k) = values.iter().position(|v| !v.is_finite()) {
        return Err(ctx.invalid(at, format!("value {k} is not finite")));
    }
    Ok(Channel {
        node,
        path,
        interpolation,
        times,
        values,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn channel(
        path: Path,
        interpolation: Interpolation,
        times: &[f32],
        values: &[Vec4],
    ) -> Channel {
        Channel {
            node: 0,
            path,
            interpolation,
            times: times.to_vec(),
            values: values.to_vec(),
        }
    }

    #[test]
    fn step_and_linear_hold_the_ends_and_interpolate_between() {
        let v = [Vec4::new(1.0, 0.0, 0.0, 0.0), Vec4::new(3.0, 2.0, 0.0, 0.0)];
        let step = channel(Path::Translation, Interpolation::Step, &[1.0, 2.0], &v);
        assert_eq!(step.sample(0.0), v[0]);
        assert_eq!(step.sample(1.9), v[0]);
        assert_eq!(step.sample(2.0), v[1]);
        let lin = channel(Path::Translation, Interpolation::Linear, &[1.0, 2.0], &v);
        assert_eq!(lin.sample(1.5), Vec4::new(2.0, 1.0, 0.0, 0.0));
        assert_eq!(lin.sample(5.0), v[1]);
    }

    #[test]
    fn linear_rotation_is_the_shortest_slerp() {
        let a = Quat::IDENTITY;
        // 90 degrees about y, written with a negative w: the same rotation as its negation.
        let b = -Quat::from_rotation_y(std::f32::consts::FRAC_PI_2);
        let c = channel(
            Path::Rotation,
            Interpolation::Linear,
            &[0.0, 1.0],
            &[Vec4::from(a), Vec4::from(b)],
        );
        let half = Quat::from_vec4(c.sample(0.5)).normalize();
        let want = Quat::from_rotation_y(std::f32::consts::FRAC_PI_4);
        assert!(half.dot(want).abs() > 1.0 - 1e-6, "{half:?}");
    }

    #[test]
    fn cubic_spline_follows_the_hermite_basis_with_scaled_tangents() {
        // Keys at t = 0 and 2: value 0 then 1, out-tangent 1 at the first key, in-tangent 0.
        let z = Vec4::ZERO;
        let x = |v: f32| Vec4::new(v, 0.0, 0.0, 0.0);
        let c = channel(
            Path::Scale,
            Interpolation::CubicSpline,
            &[0.0, 2.0],
            &[z, x(0.0), x(1.0), x(0.0), x(1.0), z],
        );
        // u = 0.5, dt = 2: 0.5 * 1 + (0.125 - 0.5 + 0.5) * 2 * 1 = 0.75.
        assert!((c.sample(1.0).x - 0.75).abs() < 1e-6);
        assert_eq!(c.sample(-1.0).x, 0.0);
        assert_eq!(c.sample(3.0).x, 1.0);
    }
}
