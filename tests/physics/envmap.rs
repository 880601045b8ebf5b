//! Environment maps (`BRUME_environment.uri`): Blender's equirectangular convention (known
//! directions land on known pixels), importance sampling (pdf integrates to 1, chi-square of
//! drawn directions against the pdf), the loader's errors on bad files, and an environment map
//! seen through an absorbing slab against the analytic transmittance (per-pixel z-tests); a
//! constant map renders exactly the constant environment.
use crate::common;
use common::render::*;

use brume::render::envmap::{
    direction_to_uv, lookup_from_world, uv_to_direction, EnvLight, EnvSampling, EnvironmentMap,
};
use brume::render::RenderSettings;
use brume::sampling::chi2::{chi2_test, sidak, SphereHistogram};
use brume::sampling::Rng;
use brume::scene::envmap::{write_environment_exr, EnvironmentImage};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// A dim vertical gradient with a small bright sun disc around Blender direction `sun`.
fn sky(w: u32, h: u32, sun: Vec3, sun_radius: f32) -> EnvironmentImage {
    let mut rgb = Vec::new();
    for j in 0..h {
        for i in 0..w {
            let uv = Vec2::new((i as f32 + 0.5) / w as f32, (j as f32 + 0.5) / h as f32);
            let d = uv_to_direction(uv);
            let up = d.z.max(0.0);
            let mut c = [0.2 + 0.3 * up, 0.3 + 0.4 * up, 0.5 + 0.5 * up];
            if d.dot(sun.normalize()).acos() < sun_radius {
                c = [200.0, 180.0, 150.0];
            }
            rgb.push(c);
        }
    }
    EnvironmentImage {
        width: w,
        height: h,
        rgb,
    }
}

fn close(a: Vec2, b: Vec2) {
    assert!((a - b).abs().max_element() < 1e-6, "{a} vs {b}");
}

#[test]
fn known_directions_land_on_blender_pixels() {
    // glTF (x, y, z) is Blender (x, -z, y); the image centre looks along +X, a quarter in
    // along Blender +Y (glTF -Z), three quarters along Blender -Y (glTF +Z), the top row up.
    let m0 = lookup_from_world([0.0; 3]);
    let uv = |w: Vec3| direction_to_uv(m0 * w);
    close(uv(Vec3::X), Vec2::new(0.5, 0.5));
    close(uv(-Vec3::Z), Vec2::new(0.25, 0.5));
    close(uv(Vec3::Z), Vec2::new(0.75, 0.5));
    close(uv(-Vec3::X), Vec2::new(0.0, 0.5));
    assert!(uv(Vec3::Y).y < 1e-6);
    assert!(uv(-Vec3::Y).y > 1.0 - 1e-6);

    // An 8 x 4 map whose pixels are all different: the direction through the centre of pixel
    // (1, 0) is theta = 22.5 deg, phi = 112.5 deg in Blender, i.e. Blender
    // (-0.14645, 0.35355, 0.92388), glTF (-0.14645, 0.92388, -0.35355).
    let rgb = (0..32)
        .map(|k| [(k % 8) as f32, (k / 8) as f32, 1.0])
        .collect();
    let image = Arc::new(EnvironmentImage {
        width: 8,
        height: 4,
        rgb,
    });
    let light = |rotation| EnvironmentMap::new(image.clone(), Vec3::ONE, rotation).unwrap();
    let w = Vec3::new(-0.146_446_6, 0.923_879_5, -0.353_553_4);
    let le = light([0.0; 3]).le(w);
    assert!(
        (le - Vec3::new(1.0, 0.0, 1.0)).abs().max_element() < 1e-4,
        "{le}"
    );
    // Every pixel centre round-trips.
    for j in 0..4 {
        for i in 0..8 {
            let uv = Vec2::new((i as f32 + 0.5) / 8.0, (j as f32 + 0.5) / 4.0);
            let w = m0.transpose() * uv_to_direction(uv);
            close(direction_to_uv(m0 * w), uv);
            let le = light([0.0; 3]).le(w);
            assert!(
                (le - Vec3::new(i as f32, j as f32, 1.0))
                    .abs()
                    .max_element()
                    < 1e-4
            );
        }
    }
    // Mapping rotation Z by +90 deg: glTF +X (Blender +X) is looked up where Blender +Y was,
    // a quarter of the way in. Rotation X by +90 deg: Blender +Y (glTF -Z) looks at the zenith.
    close(
        direction_to_uv(lookup_from_world([0.0, 0.0, PI / 2.0]) * Vec3::X),
        Vec2::new(0.25, 0.5),
    );
    assert!(direction_to_uv(lookup_from_world([PI / 2.0, 0.0, 0.0]) * -Vec3::Z).y < 1e-3);
}

/// World directions drawn by `light` with 2D uniforms, histogrammed and compared with the
/// expected counts from its pdf (midpoint rule on 24 x 24 sub-cells per bin).
fn chi2_of(light: &EnvLight, n: u32, seed: u32) -> (f64, f64) {
    let mut h = SphereHistogram::new(24, 48);
    // Draws refused because rounding moved the direction into a zero-weight cell or onto a
    // pole (sin(theta) rounds to 0): a few in 1e5, a bias of that order at most.
    let mut refused = 0;
    for i in 0..n {
        let mut rng = Rng::new(i, 0, seed);
        let u = rng.uniform_vec2();
        let Some(s) = light.sample(u) else {
            refused += 1;
            continue;
        };
        // The returned pdf is the pdf of the returned direction.
        let p = light.pdf(s.wi);
        assert!(
            (s.pdf - p).abs() <= 1e-3 * p,
            "sample pdf {} vs pdf(wi) {p}",
            s.pdf
        );
        h.add(s.wi);
    }
    let sub = 24;
    let mut expected = vec![0.0; h.counts.len()];
    let mut total = 0.0;
    for c in 0..h.n_cos {
        for p in 0..h.n_phi {
            let mut acc = 0.0f64;
            for a in 0..sub {
                for b in 0..sub {
                    let mu =
                        -1.0 + 2.0 * (c as f64 + (a as f64 + 0.5) / sub as f64) / h.n_cos as f64;
                    let phi =
                        2.0 * std::f64::consts::PI * (p as f64 + (b as f64 + 0.5) / sub as f64)
                            / h.n_phi as f64;
                    let s = (1.0 - mu * mu).max(0.0).sqrt();
                    let w = Vec3::new((s * phi.cos()) as f32, (s * phi.sin()) as f32, mu as f32);
                    acc += light.pdf(w) as f64;
                }
            }
            // dOmega = dmu dphi over a bin of (2 / n_cos) x (2 pi / n_phi).
            let integral = acc / (sub * sub) as f64
                * (2.0 / h.n_cos as f64)
                * (2.0 * std::f64::consts::PI / h.n_phi as f64);
            total += integral;
            expected[c * h.n_phi + p] = n as f64 * integral;
        }
    }
    assert!(refused * 10_000 <= n, "{refused} of {n} draws refused");
    let t = chi2_test(&h.counts, &expected, 5.0);
    println!(
        "chi2 {:.1} dof {} p {:.4}; pdf integral {total:.5}; {refused} draws refused",
        t.statistic, t.dof, t.p_value
    );
    (t.p_value, total)
}

#[test]
fn importance_sampling_matches_its_pdf() {
    let alpha = sidak(0.01, 3);
    // A smooth sky with a sun 3 degrees in radius, rotated off every axis.
    let image = Arc::new(sky(64, 32, Vec3::new(0.3, 0.5, 0.6), 0.06));
    let env = brume::scene::Environment {
        radiance: [1.0, 0.8, 0.6],
        map: None,
        image: Some(image.clone()),
        rotation: [0.4, -0.3, 1.1],
    };
    let mut light = EnvLight::new(&env).unwrap();
    // The discrete distribution is normalised over the unit square.
    let d = &light.map.as_ref().unwrap().distribution;
    let sum: f64 = d.func.iter().map(|&f| f as f64).sum::<f64>() / (d.nu * d.nv) as f64;
    assert!((sum / d.integral as f64 - 1.0).abs() < 1e-5);
    for (mode, seed) in [(EnvSampling::Importance, 7), (EnvSampling::Uniform, 8)] {
        light.map.as_mut().unwrap().sampling = mode;
        let (p, total) = chi2_of(&light, 600_000, seed);
        assert!(
            (total - 1.0).abs() < 2e-3,
            "{mode}: pdf integrates to {total}"
        );
        assert!(p >= alpha, "{mode}: p = {p}");
    }
    // A map with empty (black) regions: no sample lands where the pdf is zero (chi2_test fails
    // outright on such a sample), the pdf still integrates to 1.
    let mut dark = sky(32, 16, Vec3::new(-0.5, 0.2, 0.3), 0.2);
    for (k, p) in dark.rgb.iter_mut().enumerate() {
        if (k / 32) >= 8 || (k % 32) < 10 {
            *p = [0.0; 3];
        }
    }
    let env = brume::scene::Environment {
        image: Some(Arc::new(dark)),
        rotation: [0.0; 3],
        ..env
    };
    let light = EnvLight::new(&env).unwrap();
    let (p, total) = chi2_of(&light, 400_000, 9);
    assert!(
        (total - 1.0).abs() < 2e-3,
        "dark map: pdf integrates to {total}"
    );
    assert!(p >= alpha, "dark map: p = {p}");
}

#[test]
fn constant_and_black_maps_fold_into_the_constant_environment() {
    let image = EnvironmentImage {
        width: 4,
        height: 2,
        rgb: vec![[0.5, 0.25, 2.0]; 8],
    };
    let env = brume::scene::Environment {
        radiance: [2.0, 2.0, 1.0],
        map: None,
        image: Some(Arc::new(image)),
        rotation: [0.1, 0.2, 0.3],
    };
    let light = EnvLight::new(&env).unwrap();
    assert!(light.map.is_none());
    assert_eq!(light.radiance, Vec3::new(1.0, 0.5, 2.0));
    let black = EnvironmentImage {
        width: 4,
        height: 2,
        rgb: (0..8)
            .map(|k| [0.0, 0.0, if k == 3 { -0.0 } else { 0.0 }])
            .collect(),
    };
    let env = brume::scene::Environment {
        image: Some(Arc::new(black)),
        ..env
    };
    assert!(EnvLight::new(&env).is_none());
}

// ---------------------------------------------------------------------------------------
// Loading and bad input.

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("brume-envmap-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A scene with only a camera and `BRUME_environment` pointing at `uri`.
fn scene_with_map(dir: &Path, uri: &str) -> PathBuf {
    let doc = serde_json::json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"camera": 0, "translation": [0.0, 0.0, 3.0]}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.01}}],
        "extensions": {"BRUME_environment": {"color": [1.0, 0.5, 0.25], "strength": 2.0,
            "uri": uri, "rotation": [0.0, 0.0, 1.0]}},
        "extensionsUsed": ["BRUME_environment"],
    });
    let p = dir.join("scene.gltf");
    std::fs::write(&p, serde_json::to_string_pretty(&doc).unwrap()).unwrap();
    p
}

fn load_error(dir: &Path, uri: &str) -> String {
    let p = scene_with_map(dir, uri);
    let e = brume::scene::load(&p)
        .expect_err("the map must be refused")
        .to_string();
    assert!(e.contains("scene.gltf"), "{e}");
    assert!(e.contains("/extensions/BRUME_environment/uri"), "{e}");
    assert!(e.contains(uri), "{e}");
    println!("{uri}: {e}");
    e
}

/// A Radiance `.hdr` of `w x h` flat (uncompressed) RGBE pixels.
fn hdr_bytes(w: usize, h: usize, rgbe: &[[u8; 4]]) -> Vec<u8> {
    let mut b = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n").into_bytes();
    for p in rgbe {
        b.extend_from_slice(p);
    }
    b
}

#[test]
fn maps_load_and_bad_maps_are_clear_errors() {
    let dir = temp_dir("load");
    let good = sky(16, 8, Vec3::Z, 0.3);
    write_environment_exr(&dir.join("sky.exr"), &good).unwrap();
    let scene = brume::scene::load(&scene_with_map(&dir, "sky.exr")).unwrap();
    let env = &scene.environment;
    assert_eq!(env.image.as_deref(), Some(&good));
    assert_eq!(env.rotation, [0.0, 0.0, 1.0]);
    assert_eq!(env.radiance, [2.0, 1.0, 0.5]);
    assert!(scene.effects().names().contains(&"environment map"));
    assert!(scene.warnings.iter().all(|w| !w.contains("not decoded")));

    // Radiance HDR: (128, 64, 32) with exponent 129 is (1, 0.5, 0.25).
    let px = [[128u8, 64, 32, 129]; 8];
    std::fs::write(dir.join("sky.hdr"), hdr_bytes(4, 2, &px)).unwrap();
    let scene = brume::scene::load(&scene_with_map(&dir, "sky.hdr")).unwrap();
    let img = scene.environment.image.as_deref().unwrap();
    assert_eq!((img.width, img.height), (4, 2));
    for p in &img.rgb {
        assert!(
            (Vec3::from(*p) - Vec3::new(1.0, 0.5, 0.25))
                .abs()
                .max_element()
                < 1e-2,
            "{p:?}"
        );
    }

    // Not an image at all, under either extension.
    std::fs::write(dir.join("text.exr"), "this is not an EXR file").unwrap();
    load_error(&dir, "text.exr");
    std::fs::write(dir.join("text.hdr"), "this is not a Radiance file").unwrap();
    load_error(&dir, "text.hdr");
    // Truncated files.
    let bytes = std::fs::read(dir.join("sky.exr")).unwrap();
    std::fs::write(dir.join("cut.exr"), &bytes[..bytes.len() / 2]).unwrap();
    load_error(&dir, "cut.exr");
    let bytes = hdr_bytes(4, 2, &px);
    std::fs::write(dir.join("cut.hdr"), &bytes[..bytes.len() - 9]).unwrap();
    load_error(&dir, "cut.hdr");
    // Unsupported format, a directory, a missing file.
    std::fs::write(dir.join("sky.png"), [0x89, b'P', b'N', b'G']).unwrap();
    assert!(load_error(&dir, "sky.png").contains(".exr or .hdr"));
    std::fs::create_dir_all(dir.join("folder.exr")).unwrap();
    load_error(&dir, "folder.exr");
    load_error(&dir, "missing.exr");
    // NaN and infinite pixels.
    for (name, bad) in [("nan.exr", f32::NAN), ("inf.exr", f32::INFINITY)] {
        let mut m = good.clone();
        m.rgb[19][1] = bad;
        write_environment_exr(&dir.join(name), &m).unwrap();
        let e = load_error(&dir, name);
        assert!(
            e.contains("pixel (3, 1)") && e.contains("not finite"),
            "{e}"
        );
    }
    // Negative pixels are clamped to zero, with a warning.
    let mut m = good.clone();
    m.rgb[5] = [-1.0, 0.5, 0.5];
    write_environment_exr(&dir.join("neg.exr"), &m).unwrap();
    let scene = brume::scene::load(&scene_with_map(&dir, "neg.exr")).unwrap();
    assert_eq!(
        scene.environment.image.as_ref().unwrap().rgb[5],
        [0.0, 0.5, 0.5]
    );
    assert!(
        scene.warnings.iter().any(|w| w.contains("clamped")),
        "{:?}",
        scene.warnings
    );
    let _ = std::fs::remove_dir_all(&dir);
}

// ---------------------------------------------------------------------------------------
// Transport: an environment map through an absorbing slab.

/// Length of the ray `o + t d` (t > 0) inside the box `[-h, h]^3`.
fn chord(o: Vec3, d: Vec3, h: f32) -> f32 {
    let inv = d.recip();
    let t0 = (Vec3::splat(-h) - o) * inv;
    let t1 = (Vec3::splat(h) - o) * inv;
    let near = t0.min(t1).max_element().max(0.0);
    let far = t0.max(t1).min_element();
    (far - near).max(0.0)
}

#[test]
fn map_through_an_absorbing_slab_matches_the_analytic_transmittance() {
    // The furnace's index-matched box ([-3, 3]^3, camera at z = 6) filled with a chromatic
    // absorber instead of the cloud, under a rotated sky map with a sun behind the box. Each
    // pixel's expectation is the average over its footprint of exp(-sigma_a L(w)) Le(w); a
    // 24 x 24 midpoint rule per pixel gives it to ~1e-5, well below the noise.
    let mut scene = load_scene("furnace.gltf");
    scene.vdb_media.clear();
    let sigma_a = [0.05f32, 0.15, 0.3];
    scene
        .homogeneous_media
        .push(brume::scene::material::HomogeneousMedium {
            sigma_a,
            sigma_s: [0.0; 3],
            phase: brume::volume::phases::Phase::hg(0.0),
            material: 0,
        });
    scene.materials[0].interior_medium = 0;
    // The sun 12 degrees off the view axis (Blender +Y is glTF -Z, behind the box).
    let sun = Vec3::new(0.1, 1.0, 0.18);
    scene.environment.image = Some(Arc::new(sky(128, 64, sun, 0.12)));
    scene.environment.rotation = [0.0, 0.0, 0.05];
    scene.environment.radiance = [1.0, 1.0, 1.0];
    let settings = RenderSettings {
        width: 16,
        height: 12,
        spp: 256,
        seed: 5,
        ..RenderSettings::default()
    };
    let out = render(&scene, &settings);
    let (mean, var) = moments(&out);
    let light = EnvLight::new(&scene.environment).unwrap();
    assert!(light.map.is_some());
    let aspect = settings.width as f32 / settings.height as f32;
    let sub = 24;
    let mut reference = Vec::new();
    let mut lit = 0;
    for y in 0..settings.height {
        for x in 0..settings.width {
            let mut acc = glam::DVec3::ZERO;
            for a in 0..sub {
                for b in 0..sub {
                    let fx = (x as f32 + (b as f32 + 0.5) / sub as f32) / settings.width as f32;
                    let fy = (y as f32 + (a as f32 + 0.5) / sub as f32) / settings.height as f32;
                    let ray = scene.camera.generate_ray(fx, fy, aspect);
                    let l = chord(ray.o, ray.d, 3.0);
                    let t = Vec3::from(sigma_a.map(|s| (-s * l).exp()));
                    acc += (t * light.le(ray.d)).as_dvec3();
                }
            }
            let px = acc / (sub * sub) as f64;
            lit += (px.max_element() > 50.0) as usize;
            reference.extend([px.x, px.y, px.z]);
        }
    }
    assert!(lit > 0, "the sun must be in view through the slab");
    let zeros = vec![0.0; reference.len()];
    let a = compare((&mean, &var), (&reference, &zeros), 1e-3);
    println!(
        "slab: image mean {:.5} vs {:.5} (z {:.2}), worst pixel z {:.2} (threshold {:.2}), {} of {} fail, {lit} sun pixels",
        a.mean_a, a.mean_b, a.mean_z, a.worst_z, a.z_threshold, a.failing, a.pixels
    );
    assert_eq!(a.failing, 0, "{a:?}");
    assert!(a.mean_z < inverse_normal_two_sided(1e-3 / 3.0), "{a:?}");
}

#[test]
fn a_constant_map_renders_exactly_the_constant_environment() {
    // The cloud under its constant sky, and under the same sky times a map of ones: the same
    // estimator and random numbers, so the same image to the bit.
    let scene = load_scene("cloud.gltf");
    let mut mapped = load_scene("cloud.gltf");
    mapped.environment.image = Some(Arc::new(EnvironmentImage {
        width: 8,
        height: 4,
        rgb: vec![[1.0; 3]; 32],
    }));
    mapped.environment.rotation = [0.5, 0.1, -0.3];
    let s = RenderSettings {
        width: 16,
        height: 12,
        spp: 8,
        seed: 11,
        ..RenderSettings::default()
    };
    let (a, _) = moments(&render(&scene, &s));
    let (b, _) = moments(&render(&mapped, &s));
    assert!(a.iter().any(|&v| v > 0.0));
    assert_eq!(a, b);
}
