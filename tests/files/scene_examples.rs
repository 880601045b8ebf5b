//! Loads every example scene in `scenes/` and checks it against values worked out by hand from
//! the glTF text: counts, transforms, camera, media coefficients and the effect list.
use std::path::{Path, PathBuf};

use brume::scene::{self, BoundsSource, CameraSource, Scene};
use glam::{Mat4, Quat, Vec3};

/// Path of an example scene.
fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name)
}

/// Checks a medium's world bounds against the grid's facts read independently from OpenVDB:
/// the active voxels, widened by the one voxel over which trilinear reconstruction falls off,
/// lie inside the bounds, and the bounds exceed that by at most Brume's one-cell padding plus
/// rounding to whole cells (16 voxels on each side).
fn check_medium_bounds(m: &brume::scene::VdbMediumDesc, world_from_node: Mat4) {
    let file = brume_ffi::VdbFile::open(&m.vdb_path).unwrap();
    let info = file
        .grids()
        .iter()
        .find(|g| g.name == m.density_grid)
        .unwrap();
    let (lo, hi) = info.active_bbox.unwrap();
    let world_from_index = glam::DMat4::from_cols_array_2d(&info.world_from_index)
        .transpose()
        .as_mat4();
    let world_from_medium = world_from_node * world_from_index;
    let corners = |pad: f32| {
        let a = Vec3::new(lo[0] as f32, lo[1] as f32, lo[2] as f32) - pad;
        let b = Vec3::new(hi[0] as f32, hi[1] as f32, hi[2] as f32) + pad;
        scene::transform_aabb(&world_from_medium, &brume::math::Aabb::new(a, b))
    };
    let (inner, outer) = (corners(1.0), corners(17.0));
    let eps = 1e-4 * (1.0 + outer.max.abs().max_element());
    assert_eq!(m.bounds_source, BoundsSource::Grid);
    assert!(
        m.world_bounds.min.cmple(inner.min + eps).all()
            && m.world_bounds.max.cmpge(inner.max - eps).all(),
        "{:?} does not contain the active voxels {:?}",
        m.world_bounds,
        inner
    );
    assert!(
        m.world_bounds.min.cmpge(outer.min - eps).all()
            && m.world_bounds.max.cmple(outer.max + eps).all(),
        "{:?} is looser than the padded cell box {:?}",
        m.world_bounds,
        outer
    );
}

fn load(name: &str) -> Scene {
    let path = example(name);
    let s = scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    s.validate().unwrap();
    assert!(!s.summary().is_empty());
    check_winding(&s);
    assert!(
        !s.warnings.iter().any(|w| w.contains("not closed")),
        "{:?}",
        s.warnings
    );
    assert!(s.to_string().contains("effects: "));
    s
}

fn close(a: &[f32], b: &[f32], tol: f32) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(x, y)| (x - y).abs() <= tol * (1.0 + y.abs()))
}

/// Every triangle of the examples is wound counter-clockwise around its shading normal.
fn check_winding(s: &Scene) {
    for (k, t) in s.triangles().iter().enumerate() {
        let [a, b, c] = s.triangle_corners(k);
        let n: Vec3 = t
            .vertices
            .iter()
            .map(|&i| Vec3::from(s.vertices()[i as usize].normal))
            .sum();
        assert!(
            (b - a).cross(c - a).dot(n) > 0.0,
            "{}: triangle {k} is wound against its normals",
            s.source.display()
        );
    }
}

fn effects(s: &Scene) -> Vec<&'static str> {
    s.effects().names()
}

/// Camera placed at `eye` looking at `target` with `yfov`: checks what the glTF text says.
fn check_camera(s: &Scene, eye: Vec3, target: Vec3, yfov: f32) {
    let c = &s.camera;
    assert!(matches!(c.source, CameraSource::Node { .. }));
    assert!(c.position().distance(eye) < 1e-5, "{:?}", c.position());
    assert!(c.forward().dot((target - eye).normalize()) > 1.0 - 1e-5);
    assert!(c.up().y > 0.0);
    assert_eq!(c.yfov, yfov);
    assert_eq!(c.znear, 0.05);
    assert_eq!(c.file_aspect_ratio, Some(1.5));
}

#[test]
fn cloud() {
    let s = load("cloud.gltf");
    assert_eq!(
        (
            s.triangle_count(),
            s.instances.len(),
            s.lights.len(),
            s.vdb_media.len()
        ),
        (0, 0, 1, 1)
    );
    check_camera(&s, Vec3::new(0.0, 0.6, 9.0), Vec3::ZERO, 0.6);
    assert!(close(&s.lights[0].intensity, &[3.0, 2.91, 2.7], 1e-6));
    assert!(close(&s.environment.radiance, &[0.27, 0.372, 0.6], 1e-6));
    let m = &s.vdb_media[0];
    assert!(m.vdb_path.is_absolute() && m.vdb_path.ends_with("vdb/cloud.vdb"));
    assert_eq!(m.density_grid, "density");
    assert_eq!(m.pointer, "/nodes/2/extensions/BRUME_medium_vdb");
    // world_from_medium = node (uniform scale 2) * the VDB's own index-to-world transform.
    assert_eq!(
        m.world_from_medium,
        Mat4::from_scale(Vec3::splat(2.0)) * m.grids[0].vdb_world_from_index
    );
    check_medium_bounds(m, Mat4::from_scale(Vec3::splat(2.0)));
    assert!(
        close(&m.sigma_s_per_density(), &[8.0; 3], 0.0)
            && close(&m.sigma_a_per_density(), &[0.0; 3], 0.0)
    );
    assert_eq!(
        effects(&s),
        [
            "media",
            "heterogeneous media",
            "scattering",
            "anisotropic phase",
            "punctual lights",
            "environment light"
        ]
    );
}

#[test]
fn cornell_smoke() {
    let s = load("cornell_smoke.gltf");
    assert_eq!(
        (
            s.instances.len(),
            s.triangle_count(),
            s.materials.len(),
            s.lights.len()
        ),
        (4, 12, 5, 1)
    );
    check_camera(
        &s,
        Vec3::new(0.0, 1.0, 3.9),
        Vec3::new(0.0, 1.0, 0.0),
        0.6911,
    );
    // The emissive quad: emissiveFactor * emissiveStrength 12.
    let lamp = s
        .material_names
        .iter()
        .position(|n| n.as_deref() == Some("ceiling_light"))
        .unwrap();
    assert!(close(&s.materials[lamp].emission, &[12.0, 10.2, 7.2], 1e-6));
    let l = &s.lights[0];
    assert_eq!(
        (l.kind, l.position),
        (scene::lights::LIGHT_POINT, [0.0, 1.5, 0.0])
    );
    assert!(close(&l.intensity, &[2.0, 1.8, 1.6], 1e-6));
    let m = &s.vdb_media[0];
    let node = Mat4::from_translation(Vec3::Y) * Mat4::from_scale(Vec3::splat(0.6));
    assert!(m
        .world_from_medium
        .abs_diff_eq(node * m.grids[0].vdb_world_from_index, 1e-6));
    check_medium_bounds(m, node);
    // Principled Volume: sigma_s = color * scale, sigma_a = (1 - color)(1 - sqrt(absorption)) * scale.
    assert!(close(&m.sigma_s_per_density(), &[2.8; 3], 1e-6));
    assert!(close(
        &m.sigma_a_per_density(),
        &[0.3 * (1.0 - 0.1f32.sqrt()) * 4.0; 3],
        1e-5
    ));
    assert!((m.anisotropy - 0.3).abs() < 1e-7);
    let light_inside = m.world_bounds.min.cmple(Vec3::from(l.position)).all()
        && m.world_bounds.max.cmpge(Vec3::from(l.position)).all();
    let mut expected = vec![
        "surfaces",
        "media",
        "heterogeneous media",
        "scattering",
        "absorption",
        "surface emission",
        "anisotropic phase",
        "punctual lights",
    ];
    if light_inside {
        expected.push("lights inside media");
    }
    assert_eq!(effects(&s), expected);
    // The smoke node is a sibling of the camera; the walls hang under the "box" node.
    assert!(s.instances.iter().all(|i| i.node >= 1 && i.node <= 4));
}

#[test]
fn glass_volume() {
    let s = load("glass_volume.gltf");
    assert_eq!(
        (
            s.instances.len(),
            s.triangle_count(),
            s.homogeneous_media.len()
        ),
        (2, 2 + 320, 1)
    );
    check_camera(&s, Vec3::new(0.0, 1.6, 5.0), Vec3::new(0.0, 0.9, 0.0), 0.6);
    // The ball node translates the unit icosphere to (0, 1, 0).
    let ball = &s.instances[1];
    for t in &s.triangles()[ball.first_triangle as usize..][..ball.triangle_count as usize] {
        for &v in &t.vertices {
            let p = Vec3::from(s.vertices()[v as usize].position);
            assert!((p.distance(Vec3::Y) - 1.0).abs() < 1e-5);
        }
    }
    // KHR_materials_volume: sigma_t = -ln(attenuationColor) / attenuationDistance, split by
    // the scattering albedo 0.9.
    let m = &s.homogeneous_media[0];
    let sigma_t = [0.8f32, 0.6, 0.4].map(|c| -c.ln() / 0.5);
    assert!(close(&m.sigma_t(), &sigma_t, 1e-6));
    assert!(close(&m.sigma_s, &sigma_t.map(|x| 0.9 * x), 1e-6));
    assert_eq!(m.phase, brume::volume::phases::Phase::hg(0.5));
    let mat = &s.materials[m.material as usize];
    assert_eq!(
        (mat.transmission, mat.ior, mat.interior_medium),
        (1.0, 1.5, 0)
    );
    assert!(s.inside_medium(Vec3::Y) && !s.inside_medium(Vec3::new(0.0, 2.5, 0.0)));
    assert_eq!(
        effects(&s),
        [
            "surfaces",
            "media",
            "homogeneous media",
            "scattering",
            "absorption",
            "chromatic extinction",
            "anisotropic phase",
            "punctual lights",
            "environment light"
        ]
    );
    // The sun: rotated -50 degrees about X then -40 about Y; travels along the node's -Z.
    let q = Quat::from_rotation_y((-40.0f32).to_radians())
        * Quat::from_rotation_x((-50.0f32).to_radians());
    assert!(close(
        &s.lights[0].direction,
        &(q * Vec3::NEG_Z).to_array(),
        1e-5
    ));
}

#[test]
fn fire() {
    let s = load("fire.gltf");
    assert_eq!(
        (s.triangle_count(), s.lights.len(), s.vdb_media.len()),
        (2, 0, 1)
    );
    let m = &s.vdb_media[0];
    let names: Vec<_> = m.grids.iter().map(|g| g.name.as_str()).collect();
    assert_eq!(names, ["density", "flame", "temperature"]);
    assert_eq!(
        (
            m.emission_strength,
            m.blackbody_intensity,
            m.temperature_scale
        ),
        (4.0, 1.0, 1000.0)
    );
    assert!(m.emits());
    check_medium_bounds(m, Mat4::from_scale(Vec3::splat(1.5)));
    // The floor sits below the grid's box.
    assert!(s.vertices().iter().all(|v| v.position[1] == -1.5));
    assert!(
        close(&m.sigma_s_per_density(), &[0.6; 3], 1e-6)
            && close(&m.sigma_a_per_density(), &[1.4; 3], 1e-6)
    );
    assert_eq!(
        effects(&s),
        [
            "surfaces",
            "media",
            "heterogeneous media",
            "scattering",
            "absorption",
            "media emission",
            "environment light"
        ]
    );
}

#[test]
fn fire2() {
    let s = load("fire2.gltf");
    assert_eq!(
        (s.triangle_count(), s.lights.len(), s.vdb_media.len()),
        (2, 0, 2)
    );
    let files: Vec<_> = s
        .vdb_media
        .iter()
        .map(|m| {
            m.vdb_path
                .file_name()
                .unwrap()
                .to_string_lossy()
                .into_owned()
        })
        .collect();
    assert_eq!(files, ["fire2_smoke.vdb", "fire2_flame.vdb"]);
    assert!(!s.vdb_media[0].emits() && s.vdb_media[1].emits());
    for m in &s.vdb_media {
        check_medium_bounds(m, Mat4::from_scale(Vec3::splat(1.6)));
    }
    let e = effects(&s);
    assert!(
        e.contains(&"overlapping media") && !e.contains(&"nested media"),
        "{e:?}"
    );
}

#[test]
fn smoke_tank() {
    let s = load("smoke_tank.gltf");
    assert_eq!(
        (s.triangle_count(), s.lights.len(), s.vdb_media.len()),
        (14, 1, 1)
    );
    assert_eq!(s.homogeneous_media.len(), 1);
    check_winding(&s);
    let e = effects(&s);
    assert!(
        e.contains(&"nested media") && !e.contains(&"overlapping media"),
        "{e:?}"
    );
    let rs = brume::render::RenderScene::new(&s, false).unwrap();
    // The smoke adds to the tank's medium: the mixture runs.
    assert!(rs.features.nested && rs.features.overlapping);
}

#[test]
fn chromatic() {
    let s = load("chromatic.gltf");
    assert_eq!(
        (
            s.triangle_count(),
            s.homogeneous_media.len(),
            s.lights.len()
        ),
        (14, 1, 1)
    );
    let sigma_t = [0.9f32, 0.3, 0.05].map(|c| -c.ln());
    assert!(close(&s.homogeneous_media[0].sigma_t(), &sigma_t, 1e-6));
    assert!(close(
        &sigma_t,
        &[0.105_360_5, 1.203_972_8, 2.995_732_3],
        1e-6
    ));
    let l = &s.lights[0];
    assert_eq!(l.kind, scene::lights::LIGHT_SPOT);
    assert!((l.cos_inner - 0.3f32.cos()).abs() < 1e-6 && (l.cos_outer - 0.5f32.cos()).abs() < 1e-6);
    // The cube (half size 0.75, rotated 45 degrees about Y) contains its centre, not the light.
    assert!(s.inside_medium(Vec3::ZERO) && s.inside_medium(Vec3::new(0.0, 0.7, 0.0)));
    assert!(!s.inside_medium(Vec3::new(0.74, 0.0, 0.74)));
    assert_eq!(
        effects(&s),
        [
            "surfaces",
            "media",
            "homogeneous media",
            "scattering",
            "absorption",
            "chromatic extinction",
            "punctual lights",
            "environment light"
        ]
    );
}

/// The plume scenes: one VDB medium of albedo 0.9 (color 0.9, absorptionColor 0:
/// sigma_s = 0.9 * 20, sigma_a = (1 - 0.9) * (1 - sqrt 0) * 20 per unit density), isotropic.
fn check_plume(s: &Scene) {
    assert_eq!((s.triangle_count(), s.vdb_media.len()), (0, 1));
    let c = &s.camera;
    assert!(c.position().distance(Vec3::new(0.0, 0.0, 9.0)) < 1e-6);
    assert!(c.forward().dot(Vec3::NEG_Z) > 1.0 - 1e-6);
    assert_eq!(c.yfov, 0.55);
    let m = &s.vdb_media[0];
    assert!(m.vdb_path.ends_with("vdb/plume.vdb"));
    assert_eq!(m.anisotropy, 0.0);
    check_medium_bounds(m, Mat4::from_scale(Vec3::splat(2.0)));
    assert!(close(&m.sigma_s_per_density(), &[18.0; 3], 1e-6));
    assert!(close(&m.sigma_a_per_density(), &[2.0; 3], 1e-5));
    let (ss, sa) = (m.sigma_s_per_density()[0], m.sigma_a_per_density()[0]);
    assert!((ss / (ss + sa) - 0.9).abs() < 1e-6, "albedo");
}

#[test]
fn plume_sun() {
    let s = load("plume_sun.gltf");
    check_plume(&s);
    assert_eq!(s.lights.len(), 1);
    assert_eq!(s.lights[0].kind, scene::lights::LIGHT_DIRECTIONAL);
    assert!(close(&s.lights[0].intensity, &[3.0, 2.91, 2.7], 1e-6));
    assert!(close(&s.environment.radiance, &[0.0; 3], 0.0));
    assert_eq!(
        effects(&s),
        [
            "media",
            "heterogeneous media",
            "scattering",
            "absorption",
            "punctual lights"
        ]
    );
}

#[test]
fn plume_sky() {
    let s = load("plume_sky.gltf");
    check_plume(&s);
    assert!(s.lights.is_empty());
    assert!(close(&s.environment.radiance, &[0.55, 0.7, 1.0], 1e-6));
    assert_eq!(
        effects(&s),
        [
            "media",
            "heterogeneous media",
            "scattering",
            "absorption",
            "environment light"
        ]
    );
}

/// Grey extinction (7 per unit density), chromatic albedo (0.95, 0.8, 0.6): absorptionColor 0
/// makes sigma_a = 1 - color, so no spectral tracking is needed; HG g = 0.5; sun and sky.
#[test]
fn dense_fog() {
    let s = load("dense_fog.gltf");
    assert_eq!(
        (s.triangle_count(), s.vdb_media.len(), s.lights.len()),
        (0, 1, 1)
    );
    let m = &s.vdb_media[0];
    assert!(m.vdb_path.ends_with("vdb/icosa_fog.vdb"));
    assert_eq!(m.anisotropy, 0.5);
    check_medium_bounds(m, Mat4::from_scale(Vec3::splat(1.5)));
    let albedo = [0.95f32, 0.8, 0.6];
    assert!(close(
        &m.sigma_s_per_density(),
        &albedo.map(|a| 7.0 * a),
        1e-6
    ));
    assert!(close(
        &m.sigma_a_per_density(),
        &albedo.map(|a| 7.0 * (1.0 - a)),
        1e-5
    ));
    let t: Vec<f32> = (0..3)
        .map(|c| m.sigma_s_per_density()[c] + m.sigma_a_per_density()[c])
        .collect();
    assert!(close(&t, &[7.0; 3], 1e-6), "grey extinction {t:?}");
    assert!(close(&s.environment.radiance, &[0.25, 0.3, 0.4], 1e-6));
    assert_eq!(
        effects(&s),
        [
            "media",
            "heterogeneous media",
            "scattering",
            "absorption",
            "anisotropic phase",
            "punctual lights",
            "environment light"
        ]
    );
}

#[test]
fn textured_backdrop() {
    let s = load("textured_backdrop.gltf");
    check_winding(&s);
    assert_eq!(s.vdb_media.len(), 1);
    assert_eq!(s.textures.len(), 3);
    assert_eq!(s.images.len(), 3);
    let dims: Vec<(u32, u32)> = s.images.iter().map(|i| (i.width, i.height)).collect();
    assert_eq!(dims, [(128, 128), (4, 4), (32, 8)]);
    // The backdrop clamps and blends, the ground repeats the nearest texel under a transform.
    use scene::texture::{WRAP_CLAMP, WRAP_REPEAT};
    assert_eq!(
        (s.textures[0].wrap, s.textures[0].nearest),
        ([WRAP_CLAMP; 2], false)
    );
    assert_eq!(
        (s.textures[1].wrap, s.textures[1].nearest),
        ([WRAP_REPEAT; 2], true)
    );
    assert_ne!(s.textures[1].transform, scene::texture::IDENTITY_TRANSFORM);
    // The sign's emission is textured: its triangles are light sources.
    let sign = &s.materials[2];
    assert_eq!(sign.emissive_texture, 2);
    assert!(s.mean_emission_luminance(sign) > 0.0);
    assert_eq!(
        effects(&s),
        [
            "surfaces",
            "media",
            "heterogeneous media",
            "scattering",
            "surface emission",
            "anisotropic phase",
            "punctual lights",
            "environment light",
            "textures"
        ]
    );
}

/// The cloud under the procedural HDR sky: no punctual light, the map decoded with its
/// rotation, "environment map" among the effects, the sun where `scenes/make_sky.rs` put it
/// (cloud.gltf's sun direction): the brightest direction of the map's light.
#[test]
fn cloud_sky() {
    let s = load("cloud_sky.gltf");
    assert!(s.lights.is_empty());
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let img = s.environment.image.as_ref().expect("the map is decoded");
    assert_eq!((img.width, img.height), (256, 128));
    assert_eq!(s.environment.rotation, [0.1, -0.15, 0.6]);
    assert_eq!(
        effects(&s),
        [
            "media",
            "heterogeneous media",
            "scattering",
            "anisotropic phase",
            "environment light",
            "environment map"
        ]
    );
    let light = brume::render::envmap::EnvLight::new(&s.environment).unwrap();
    let sun = Vec3::new(0.383, 0.643, 0.663).normalize();
    assert!(light.le(sun).min_element() > 500.0, "{}", light.le(sun));
    assert!(light.le(-sun).max_element() < 1.0);
}
