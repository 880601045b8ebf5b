//! The render camera: a glTF perspective camera, or a default one framing the scene.
//!
//! Orthographic cameras are not supported: a named orthographic camera is an error, and when
//! Brume picks the first camera itself it skips orthographic ones with a warning.
//! The glTF `aspectRatio` is kept for information only; the output image decides the aspect.
use glam::{Mat4, Quat, Vec3};

use super::error::{Ctx, SceneError};
use super::json::check_f32;
use super::nodes::PlacedNode;
use crate::math::{Aabb, Ray};

/// Where the camera came from.
#[derive(Clone, Debug, PartialEq)]
pub enum CameraSource {
    /// glTF camera `camera` placed by node `node`.
    Node { node: usize, camera: usize },
    /// No usable camera in the file: Brume framed the scene bounds.
    Default,
}

/// A pinhole camera looking down its local -Z with +Y up, as in glTF.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// world_from_camera, rigid: the node's scale is removed (glTF cameras ignore scale).
    pub world_from_camera: Mat4,
    /// Vertical field of view, radians, in (0, pi).
    pub yfov: f32,
    /// Near distance, metres; rays start this far along the view axis.
    pub znear: f32,
    /// Far distance, metres, if the file gives one (a path tracer does not clip; kept only).
    pub zfar: Option<f32>,
    /// The file's aspect ratio (width / height), informative only.
    pub file_aspect_ratio: Option<f32>,
    /// Camera name from the file.
    pub name: Option<String>,
    pub source: CameraSource,
}

impl Camera {
    /// World-space position of the pinhole.
    pub fn position(&self) -> Vec3 {
        self.world_from_camera.transform_point3(Vec3::ZERO)
    }

    /// Unit world-space viewing direction.
    pub fn forward(&self) -> Vec3 {
        self.world_from_camera
            .transform_vector3(Vec3::NEG_Z)
            .normalize()
    }

    /// Unit world-space up direction.
    pub fn up(&self) -> Vec3 {
        self.world_from_camera
            .transform_vector3(Vec3::Y)
            .normalize()
    }

    /// The primary ray through film point `(x, y)` in [0, 1]^2 ((0, 0) the top-left corner)
    /// of an image with `aspect` = width / height. `d` has unit length, `o` is the pinhole and
    /// the caller starts at [`Camera::t_min`].
    pub fn generate_ray(&self, x: f32, y: f32, aspect: f32) -> Ray {
        self.pinhole().generate_ray(x, y, aspect)
    }

    /// Ray parameter where the near plane cuts a unit-length ray through `(x, y)`.
    pub fn t_min(&self, x: f32, y: f32, aspect: f32) -> f32 {
        self.primary_ray(x, y, aspect).1
    }

    /// [`generate_ray`](Self::generate_ray) and [`t_min`](Self::t_min) at once, bit for bit.
    pub fn primary_ray(&self, x: f32, y: f32, aspect: f32) -> (Ray, f32) {
        self.pinhole().primary_ray(x, y, aspect)
    }

    /// What every primary ray shares, derived once ([`Pinhole`]).
    pub fn pinhole(&self) -> Pinhole {
        Pinhole {
            world_from_camera: self.world_from_camera,
            position: self.position(),
            forward: self.forward(),
            tan_half: (0.5 * self.yfov).tan(),
            znear: self.znear,
        }
    }
}

/// The camera as primary rays need it: the pinhole, the view axis and the field of view's
/// tangent, derived from [`Camera`] once per render rather than for every sample (they were
/// a `tanf`, a normalisation and two transforms a sample, about 2 % of a sample's
/// instructions on the fire; callgrind). [`Camera`]'s ray methods go through it, so both give
/// the same rays bit for bit, and the GPU's camera parameters are read from it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pinhole {
    pub world_from_camera: Mat4,
    pub position: Vec3,
    /// Unit view axis ([`Camera::forward`]).
    pub forward: Vec3,
    /// `tan(yfov / 2)`.
    pub tan_half: f32,
    pub znear: f32,
}

impl Pinhole {
    /// The same lens at another rigid pose (a moving camera at one sample's time).
    #[inline]
    pub fn posed(&self, world_from_camera: Mat4) -> Pinhole {
        Pinhole {
            world_from_camera,
            position: world_from_camera.transform_point3(Vec3::ZERO),
            forward: world_from_camera.transform_vector3(Vec3::NEG_Z).normalize(),
            ..*self
        }
    }

    /// [`Camera::generate_ray`].
    #[inline]
    pub fn generate_ray(&self, x: f32, y: f32, aspect: f32) -> Ray {
        let local = Vec3::new(
            (2.0 * x - 1.0) * self.tan_half * aspect,
            (1.0 - 2.0 * y) * self.tan_half,
            -1.0,
        );
        Ray::new(
            self.position,
            self.world_from_camera.transform_vector3(local).normalize(),
        )
    }

    /// Where world point `p` lies on the film (`[0, 1]^2` inside the image, as
    /// [`Self::generate_ray`] takes it); `None` behind the camera.
    pub fn film_point(&self, p: Vec3, aspect: f32) -> Option<glam::Vec2> {
        let local = self.world_from_camera.inverse().transform_point3(p);
        if !(local.z < 0.0) {
            return None;
        }
        let (u, v) = (local.x / -local.z, local.y / -local.z);
        Some(glam::Vec2::new(
            0.5 * (u / (self.tan_half * aspect) + 1.0),
            0.5 * (1.0 - v / self.tan_half),
        ))
    }

    /// [`Camera::primary_ray`]: the ray and where the near plane cuts it.
    #[inline]
    pub fn primary_ray(&self, x: f32, y: f32, aspect: f32) -> (Ray, f32) {
        let ray = self.generate_ray(x, y, aspect);
        let t_min = self.znear / ray.d.dot(self.forward).max(1e-6);
        (ray, t_min)
    }
}

/// A camera the file places (the render uses `Scene::camera`, chosen among these).
#[derive(Clone, Debug, PartialEq)]
pub struct CameraEntry {
    pub name: Option<String>,
    /// glTF node placing it.
    pub node: usize,
    /// glTF camera index.
    pub camera: usize,
    /// False for orthographic cameras (not supported).
    pub perspective: bool,
}

/// Every camera placed by the scene's nodes, in node order.
pub fn list_cameras(doc: &gltf::Document, nodes: &[PlacedNode]) -> Vec<CameraEntry> {
    nodes
        .iter()
        .filter_map(|placed| {
            let cam = doc.nodes().nth(placed.node)?.camera()?;
            Some(CameraEntry {
                name: cam.name().map(str::to_owned),
                node: placed.node,
                camera: cam.index(),
                perspective: matches!(cam.projection(), gltf::camera::Projection::Perspective(_)),
            })
        })
        .collect()
}

/// Vertical field of view of the default camera (40 degrees).
pub const DEFAULT_YFOV: f32 = 40.0 * std::f32::consts::PI / 180.0;

/// The camera to render through: the one named `wanted`, else the first perspective camera in
/// node order, else [`default_camera`] over `bounds`.
pub fn choose_camera(
    ctx: &mut Ctx,
    doc: &gltf::Document,
    nodes: &[PlacedNode],
    wanted: Option<&str>,
    bounds: &Aabb,
) -> Result<Camera, SceneError> {
    for placed in nodes {
        let node = placed.in_doc(doc);
        let Some(cam) = node.camera() else { continue };
        if let Some(name) = wanted {
            if cam.name() != Some(name) && node.name() != Some(name) {
                continue;
            }
        }
        let at = |p: &str| format!("/cameras/{}{p}", cam.index());
        let persp = match cam.projection() {
            gltf::camera::Projection::Perspective(p) => p,
            gltf::camera::Projection::Orthographic(_) => {
                if wanted.is_some() {
                    return Err(ctx.invalid(
                        at("/orthographic"),
                        "orthographic cameras are not supported",
                    ));
                }
                ctx.warn(
                    at("/orthographic"),
                    "orthographic camera skipped (not supported)",
                );
                continue;
            }
        };
        let yfov = check_f32(
            ctx,
            persp.yfov(),
            at("/perspective/yfov"),
            1e-6,
            std::f32::consts::PI - 1e-6,
        )?;
        let znear = check_f32(ctx, persp.znear(), at("/perspective/znear"), 0.0, f32::MAX)?;
        let zfar = persp
            .zfar()
            .map(|z| check_f32(ctx, z, at("/perspective/zfar"), znear, f32::MAX))
            .transpose()?;
        let aspect = persp
            .aspect_ratio()
            .map(|a| check_f32(ctx, a, at("/perspective/aspectRatio"), 1e-6, f32::MAX))
            .transpose()?;
        let (_, rotation, translation) = placed.world_from_node.to_scale_rotation_translation();
        if !rotation.is_finite() {
            return Err(ctx.invalid(
                format!("/nodes/{}", placed.node),
                "camera node's transform has no usable rotation",
            ));
        }
        return Ok(Camera {
            world_from_camera: Mat4::from_rotation_translation(rotation.normalize(), translation),
            yfov,
            znear,
            zfar,
            file_aspect_ratio: aspect,
            name: cam.name().map(str::to_owned),
            source: CameraSource::Node {
                node: placed.node,
                camera: cam.index(),
            },
        });
    }
    if let Some(name) = wanted {
        return Err(ctx.invalid(
            "/cameras",
            format!("no camera (or camera node) named {name:?} in the rendered scene"),
        ));
    }
    Ok(default_camera(bounds))
}

/// A camera in front of and slightly above `bounds` (looking along -Z, like a glTF camera
/// with identity rotation would) so the bounding sphere fits the vertical field of view with
/// a 10 % margin. Empty bounds: the unit cube around the origin.
pub fn default_camera(bounds: &Aabb) -> Camera {
    let b = if bounds.is_empty() {
        Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0))
    } else {
        *bounds
    };
    let center = 0.5 * (b.min + b.max);
    let radius = (0.5 * (b.max - b.min).length()).max(1e-3);
    let distance = 1.1 * radius / (0.5 * DEFAULT_YFOV).sin();
    let back = Vec3::new(0.0, 0.25, 1.0).normalize();
    let eye = center + distance * back;
    // Rotate -Z onto the view direction, keeping +Y up.
    let forward = (center - eye).normalize();
    let right = forward.cross(Vec3::Y).normalize();
    let up = right.cross(forward);
    let rotation = Quat::from_mat3(&glam::Mat3::from_cols(right, up, -forward));
    Camera {
        world_from_camera: Mat4::from_rotation_translation(rotation, eye),
        yfov: DEFAULT_YFOV,
        znear: 0.01 * radius,
        zfar: None,
        file_aspect_ratio: None,
        name: None,
        source: CameraSource::Default,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A point on the ray through a film point projects back onto that film point.
    #[test]
    fn film_point_inverts_the_primary_ray() {
        let rotation = glam::Quat::from_euler(glam::EulerRot::YXZ, 0.4, -0.2, 0.1);
        let world = Mat4::from_rotation_translation(rotation, Vec3::new(1.0, 2.0, 3.0));
        let pinhole = Pinhole {
            world_from_camera: world,
            position: Vec3::new(1.0, 2.0, 3.0),
            forward: rotation * Vec3::NEG_Z,
            tan_half: 0.3,
            znear: 0.01,
        };
        for (x, y) in [(0.5, 0.5), (0.1, 0.8), (0.93, 0.27)] {
            let ray = pinhole.generate_ray(x, y, 1.5);
            let f = pinhole.film_point(ray.at(4.0), 1.5).unwrap();
            assert!(
                (f.x - x).abs() < 1e-5 && (f.y - y).abs() < 1e-5,
                "{f} vs {x}, {y}"
            );
        }
        assert!(pinhole
            .film_point(Vec3::new(1.0, 2.0, 3.0) - pinhole.forward, 1.5)
            .is_none());
    }
}
