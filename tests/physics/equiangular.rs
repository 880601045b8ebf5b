//! Equiangular sampling towards point lights (`integrator::equiangular`), alone and weighed
//! against free flight by MIS:
//! - single scattering (max depth 1) of a point light inside a homogeneous slab, each pixel
//!   against the 1-D integral along its rays by quadrature, for every `--volume-sampling`;
//! - the same with the lamp in view: the pixel holding it, whose jitter is drawn towards it
//!   (`integrator::glow`), against the quadrature over the pixel, its variance settled;
//! - a point light inside a heterogeneous blob, all orders of scattering: MIS and equiangular
//!   sampling against free flight alone at four times the samples (per-pixel z-tests).
use crate::common::boxes::lit_slab_scene;
use crate::common::overlap::{dir, medium, write_grid, write_scene, N};
use crate::common::render::{compare, compare_renders, footprint_mean, moments, render};
use crate::common::stress::blob_voxels;

use brume::integrator::glow::Glows;
use brume::math::Ray;
use brume::render::{RenderScene, RenderSettings, VolumeSampling};
use glam::Vec3;
use serde_json::json;

const W: u32 = 16;
/// The light, inside the slab and outside the view (every camera ray passes it at a distance:
/// the quadrature's integrand is smooth over each pixel).
const LIGHT: [f32; 3] = [0.8, 0.1, 0.0];
const LO: [f32; 3] = [-2.0, -2.0, -0.5];
const HI: [f32; 3] = [2.0, 2.0, 0.5];

fn settings(spp: u32, seed: u32, sampling: VolumeSampling, max_depth: u32) -> RenderSettings {
    RenderSettings {
        width: W,
        height: W,
        spp,
        seed,
        max_depth,
        volume_sampling: sampling,
        ..RenderSettings::default()
    }
}

/// The slab of `boxes_scene` in the dark, lit by a point light at [`LIGHT`].
fn slab_scene() -> brume::scene::Scene {
    lit_slab_scene("equiangular_slab", LO, HI, LIGHT)
}

/// The single-scattered radiance along `ray` (one channel, intensity `i`): the integral over
/// the slab's chord of `exp(-sigma_t s) sigma_s p_HG(cos) I exp(-sigma_t r) / r^2`, taken in
/// the equiangular variable `theta` (`t = t_c + D tan theta`), where the `1 / r^2` becomes
/// the constant `1 / D` and the integrand is smooth: 512 midpoints.
fn single_scattering(rs: &RenderScene, ray: &Ray, i: f32) -> f64 {
    single_scattering_with_light(rs, ray, i, Vec3::from(LIGHT))
}

/// [`single_scattering`] from a light at `light`.
fn single_scattering_with_light(rs: &RenderScene, ray: &Ray, i: f32, light: Vec3) -> f64 {
    let h = &rs.homogeneous[0];
    let (sigma_t, sigma_s) = (h.sigma_t().x as f64, h.sigma_s.x as f64);
    let g = 0.3f64;
    let (o, d) = (ray.o.as_dvec3(), ray.d.as_dvec3().normalize());
    let c = light.as_dvec3();
    let t_in = (HI[2] as f64 - o.z) / d.z;
    let t_out = (LO[2] as f64 - o.z) / d.z;
    let t_c = (c - o).dot(d);
    let dist = (o + t_c * d - c).length();
    let (ta, tb) = ((t_in - t_c).atan2(dist), (t_out - t_c).atan2(dist));
    const Q: usize = 512;
    let mut sum = 0.0;
    for k in 0..Q {
        let theta = ta + (k as f64 + 0.5) / Q as f64 * (tb - ta);
        let t = t_c + dist * theta.tan();
        let x = o + t * d;
        let r = (c - x).length();
        let cos = d.dot((c - x) / r);
        let p =
            (1.0 - g * g) / (4.0 * std::f64::consts::PI * (1.0 + g * g - 2.0 * g * cos).powf(1.5));
        sum += (-sigma_t * (t - t_in)).exp() * sigma_s * p * (-sigma_t * r).exp() / dist;
    }
    sum * (tb - ta) / Q as f64 * i as f64
}

/// Single scattering from a point light in a homogeneous medium, per pixel and channel
/// against the quadrature, for free flight, equiangular sampling and their MIS.
#[test]
fn single_scattering_from_a_point_light_matches_quadrature() {
    let scene = slab_scene();
    let s = settings(512, 3, VolumeSampling::Mis, 1);
    let rs = RenderScene::prepare(&scene, &s).unwrap();
    let intensity = Vec3::from(rs.lights.punctual[0].intensity);
    let mut expected = Vec::new();
    for k in 0..W * W {
        for c in 0..3 {
            let f = |ray: &Ray| single_scattering(&rs, ray, intensity[c]);
            expected.push(footprint_mean(&rs, W, (k % W, k / W), f));
        }
    }
    let zero = vec![0.0; expected.len()];
    for sampling in [
        VolumeSampling::Mis,
        VolumeSampling::Equiangular,
        VolumeSampling::Distance,
    ] {
        let out = render(&scene, &settings(512, 3, sampling, 1));
        let (m, v) = moments(&out);
        let a = compare((&m, &v), (&expected, &zero), 1e-3);
        a.assert_holds(sampling.name());
    }
}

/// The lamp in view: the pixel holding its film point, where the glow falls off as `1 / d`,
/// against the quadrature of its single scattering over the pixel (polar about that point,
/// where the integrand times `d` is smooth). Glow sampling (`integrator::glow`) keeps the
/// pixel's variance finite: four seeds agree with the quadrature and with each other's
/// variance within a factor of 3 (uniform jitter gives estimates that differ by orders of
/// magnitude).
#[test]
fn single_scattering_of_a_lamp_in_view_matches_quadrature() {
    let probe = RenderScene::prepare(&slab_scene(), &settings(1, 0, VolumeSampling::Mis, 1))
        .unwrap()
        .pinhole;
    // A light in the slab's middle plane whose film point is inside pixel (7, 8), off centre.
    let (cx, cy) = (7.3f32, 8.6f32);
    let ray = probe.primary_ray(cx / W as f32, cy / W as f32, 1.0).0;
    let light = ray.at(-ray.o.z / ray.d.z);
    let scene = lit_slab_scene("equiangular_lamp_in_view", LO, HI, light.to_array());
    let s = settings(1024, 5, VolumeSampling::Mis, 1);
    let rs = RenderScene::prepare(&scene, &s).unwrap();
    let c = rs.pinhole.film_point(light, 1.0).unwrap() * W as f32;
    assert!(
        (c - glam::Vec2::new(cx, cy)).length() < 1e-3,
        "film point {c}"
    );
    let glows = Glows::of_scene(&rs, VolumeSampling::Mis, 0.0, W, W);
    assert_eq!(glows.count, 1, "the lamp draws the jitter of its pixel");
    assert!((glows.centres[0] - c).length() < 1e-3);
    let i = Vec3::from(rs.lights.punctual[0].intensity).x;
    // Four triangles with their apex at the film point cover the pixel.
    let corners =
        [(7.0, 8.0), (8.0, 8.0), (8.0, 9.0), (7.0, 9.0)].map(|(x, y)| glam::DVec2::new(x, y));
    let cd = c.as_dvec2();
    const Q: usize = 48;
    let mut expected = 0.0;
    for k in 0..4 {
        let (p, q) = (corners[k], corners[(k + 1) % 4]);
        let area = (p - cd).perp_dot(q - p).abs();
        for a in 0..Q {
            for b in 0..Q {
                let (sr, v) = ((a as f64 + 0.5) / Q as f64, (b as f64 + 0.5) / Q as f64);
                let f = cd + sr * (p + v * (q - p) - cd);
                let ray = rs
                    .pinhole
                    .primary_ray(f.x as f32 / W as f32, f.y as f32 / W as f32, 1.0)
                    .0;
                expected += single_scattering_with_light(&rs, &ray, i, light) * sr * area;
            }
        }
    }
    expected /= (Q * Q) as f64;
    let mut variances = Vec::new();
    for seed in 0..4 {
        let lamp = RenderSettings {
            region: Some([7, 8, 8, 9]),
            ..settings(4096, 40 + seed, VolumeSampling::Mis, 1)
        };
        let out = render(&scene, &lamp);
        let (m, v) = (
            out.film.mean(7, 8)[0] as f64,
            out.film.variance_of_mean(7, 8)[0] as f64,
        );
        let z = (m - expected) / v.sqrt();
        println!("seed {seed}: lamp pixel {m:.5} against {expected:.5} (z {z:.2}), variance of the mean {v:.3e}");
        assert!(z.abs() < 4.0, "seed {seed}: z {z}");
        variances.push(v);
    }
    let (lo, hi) = variances
        .iter()
        .fold((f64::MAX, 0.0f64), |(l, h), &v| (l.min(v), h.max(v)));
    assert!(
        hi < 3.0 * lo,
        "variance estimates {variances:?} do not settle"
    );
}

/// A point light inside a heterogeneous blob (out of view, so free flight's variance is
/// finite), every order of scattering: MIS and equiangular sampling against free flight.
#[test]
fn heterogeneous_medium_with_a_point_light_matches_free_flight() {
    let d = dir("equiangular_blob");
    write_grid(&d.join("blob.vdb"), blob_voxels(N));
    let doc = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2]}],
        "nodes": [
            {"camera": 0, "translation": [0.0, 0.0, 3.0]},
            {"translation": [0.3, -0.05, 0.05], "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"extensions": {"BRUME_medium_vdb": medium("blob.vdb", false)}}
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.12, "znear": 0.01}}],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "point", "color": [1, 1, 1], "intensity": 2.0}]}},
        "extensionsUsed": ["BRUME_medium_vdb", "KHR_lights_punctual"],
    });
    let p = write_scene(&d, "blob_bulb.gltf", &doc);
    let scene = brume::scene::load(&p).unwrap_or_else(|e| panic!("{e}"));
    let depth = brume::render::settings::DEFAULT_MAX_DEPTH;
    let reference = render(&scene, &settings(4096, 11, VolumeSampling::Distance, depth));
    for sampling in [VolumeSampling::Mis, VolumeSampling::Equiangular] {
        let out = render(&scene, &settings(1024, 12, sampling, depth));
        let a = compare_renders(&out, &reference, W as usize, W as usize, 1, 1e-3);
        a.assert_holds(&format!("{} against distance", sampling.name()));
    }
}

/// The Cornell smoke's light passes with MIS against free flight alone (8 x 8 blocks, pass by
/// pass): an equiangular estimate is gathered as the light of the event it samples, so a
/// camera ray that crosses the smoke and then meets a wall keeps its light in the surface
/// passes.
#[test]
fn light_passes_with_equiangular_sampling_match_free_flight() {
    use brume::film::passes::LIGHT_PASSES;
    let scene = crate::common::render::load_scene("cornell_smoke.gltf");
    let s = |spp, seed, sampling| RenderSettings {
        width: 32,
        height: 32,
        light_passes: true,
        ..settings(spp, seed, sampling, 8)
    };
    let mis = render(&scene, &s(512, 31, VolumeSampling::Mis));
    let distance = render(&scene, &s(2048, 32, VolumeSampling::Distance));
    let block = |out: &brume::backend::cpu::RenderOutput, k: usize| {
        let passes = out.film.passes().expect("light passes kept");
        let (mut m, mut v) = (vec![0.0; 48], vec![0.0; 48]);
        for i in 0..32 * 32 {
            let b = (i / 32 / 8) * 4 + (i % 32) / 8;
            let count = out.film.pixels()[i].count;
            let (mean, var) = (passes.mean(i, k), passes.variance_of_mean(i, k, count));
            for c in 0..3 {
                m[3 * b + c] += mean[c] / 64.0;
                v[3 * b + c] += var[c] / 4096.0;
            }
        }
        (m, v)
    };
    for (k, name) in LIGHT_PASSES.iter().enumerate() {
        let (a, b) = (block(&mis, k), block(&distance, k));
        let r = compare((&a.0, &a.1), (&b.0, &b.1), 1e-3 / LIGHT_PASSES.len() as f64);
        println!(
            "{name}: mis against distance, 8 x 8 blocks: {}",
            r.summary()
        );
        assert_eq!(r.failing, 0, "{name}");
    }
}
