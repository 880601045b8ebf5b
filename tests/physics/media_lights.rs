//! Emitting media sampled as lights (`render::media_lights`, `integrator::emitters`):
//! - a purely emitting sphere (no extinction) over a plane, seen where the camera does not see
//!   the sphere: each pixel against the light the plane reflects, by quadrature over the
//!   emission field, with the media lights on (MIS against the paths' own emission) and off;
//! - the example fire over its floor: the media lights against the paths alone at four times
//!   the samples (8 x 8 block z-tests), and the light groups adding up to the beauty.
use crate::common::overlap::{dir, write_scene};
use crate::common::render::{compare, compare_renders, moments, render};

use brume::integrator::bsdf::Principled;
use brume::render::{RenderScene, RenderSettings};
use glam::Vec3;
use serde_json::json;

const W: u32 = 8;
const VOXEL: f64 = 0.0625;
/// The sphere's radius in voxels, and its centre (world, metres).
const RADIUS: i32 = 8;
const CENTRE: [f64; 3] = [0.0, 1.0, 0.0];
const STRENGTH: f32 = 3.0;
const COLOR: [f32; 3] = [1.0, 0.6, 0.3];
const BASE: f32 = 0.8;

fn sphere_voxels() -> Vec<([i32; 3], f32)> {
    let mut v = Vec::new();
    for z in -RADIUS..=RADIUS {
        for y in -RADIUS..=RADIUS {
            for x in -RADIUS..=RADIUS {
                if x * x + y * y + z * z <= RADIUS * RADIUS {
                    v.push(([x, y, z], 1.0));
                }
            }
        }
    }
    v
}

/// A 20 m ground quad at y = 0 (base colour [`BASE`], roughness 1), the emitting sphere over
/// it, and a camera 3 m up looking straight down beside the sphere.
fn sphere_scene() -> brume::scene::Scene {
    let d = dir("media_lights_sphere");
    let mut g = brume_ffi::GridSpec::fog("density", VOXEL, CENTRE);
    g.voxels = sphere_voxels();
    brume_ffi::write_float_grids(d.join("sphere.vdb"), &[g]).unwrap();
    let positions: [[f32; 3]; 4] = [
        [-10.0, 0.0, -10.0],
        [10.0, 0.0, -10.0],
        [10.0, 0.0, 10.0],
        [-10.0, 0.0, 10.0],
    ];
    let indices: [u16; 6] = [0, 2, 1, 0, 3, 2];
    let mut bytes: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
    bytes.extend(positions.iter().flatten().flat_map(|f| f.to_le_bytes()));
    crate::common::write_whole(&d.join("ground.bin"), &bytes);
    let s = std::f32::consts::FRAC_1_SQRT_2;
    let doc = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2]}],
        "nodes": [
            {"camera": 0, "translation": [1.6, 3.0, 0.0], "rotation": [-s, 0.0, 0.0, s]},
            {"mesh": 0},
            {"extensions": {"BRUME_medium_vdb": {"uri": "sphere.vdb", "densityScale": 0.0,
                "emissionGrid": "density", "emissionStrength": STRENGTH, "emissionColor": COLOR}}}
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.5, "znear": 0.01}}],
        "buffers": [{"uri": "ground.bin", "byteLength": bytes.len()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 12},
            {"buffer": 0, "byteOffset": 12, "byteLength": 48}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5123, "count": 6, "type": "SCALAR"},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [-10.0, 0.0, -10.0], "max": [10.0, 0.0, 10.0]}
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 1}, "indices": 0, "material": 0}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [BASE, BASE, BASE, 1.0],
            "metallicFactor": 0.0, "roughnessFactor": 1.0}}],
        "extensionsUsed": ["BRUME_medium_vdb"],
    });
    let p = write_scene(&d, "sphere.gltf", &doc);
    brume::scene::load(&p).unwrap_or_else(|e| panic!("{e}"))
}

/// The radiance the ground reflects towards the camera along `ray`: the integral over the
/// emission field of `f(wo, wi) Le(y) cos / r^2`, by the midpoint rule on sub-cells a quarter
/// of a voxel wide (their faces hold every voxel centre and corner, so the trilinear field is
/// trilinear inside each and only the smooth `cos / r^2 f` carries an error).
fn reflected(rs: &RenderScene, ray: &brume::math::Ray) -> Vec3 {
    let t = -ray.o.y / ray.d.y;
    let x = ray.at(t);
    let bsdf = Principled::new(Vec3::splat(BASE), 0.0, 1.0);
    let frame = brume::sampling::warp::Frame::from_z(Vec3::Y);
    let wo_l = frame.to_local(-ray.d);
    // The emission grid (with no density, the medium's density field is empty).
    let emission = rs.vdb[0].emission.as_ref().expect("the sphere emits");
    let field = emission.grid.as_ref().expect("through its grid");
    const SUB: i32 = 4;
    let h = VOXEL / SUB as f64;
    let reach = (RADIUS + 2) * SUB;
    let mut sum = Vec3::ZERO.as_dvec3();
    for k in -reach..reach {
        for j in -reach..reach {
            for i in -reach..reach {
                let y = [i, j, k].map(|c| (c as f64 + 0.5) * h);
                let y = Vec3::new(
                    (CENTRE[0] + y[0]) as f32,
                    (CENTRE[1] + y[1]) as f32,
                    (CENTRE[2] + y[2]) as f32,
                );
                let g = field.at_world(y);
                if g == 0.0 {
                    continue;
                }
                let to = y - x;
                let r2 = to.length_squared();
                let wi = to / r2.sqrt();
                let f = bsdf.eval(wo_l, frame.to_local(wi));
                sum += (f * (g * wi.y / r2)).as_dvec3();
            }
        }
    }
    (sum * h.powi(3)).as_vec3() * STRENGTH * Vec3::from(COLOR)
}

fn settings(spp: u32, seed: u32, media_lights: bool, max_depth: u32) -> RenderSettings {
    RenderSettings {
        width: W,
        height: W,
        spp,
        seed,
        max_depth,
        media_lights,
        ..RenderSettings::default()
    }
}

/// The ground's light from the emitting sphere, pixel by pixel against the quadrature (each
/// pixel the mean over a 2 x 2 grid of its rays), with and without the media lights.
#[test]
fn emitting_sphere_lights_the_ground_as_quadrature_says() {
    let scene = sphere_scene();
    let s = settings(1, 0, true, 1);
    let rs = RenderScene::prepare(&scene, &s).unwrap();
    let mut expected = vec![0.0f64; (3 * W * W) as usize];
    for p in 0..W * W {
        let mut e = Vec3::ZERO;
        for q in 0..4 {
            let fx = ((p % W) as f32 + 0.25 + 0.5 * (q % 2) as f32) / W as f32;
            let fy = ((p / W) as f32 + 0.25 + 0.5 * (q / 2) as f32) / W as f32;
            e += reflected(&rs, &rs.pinhole.primary_ray(fx, fy, 1.0).0) / 4.0;
        }
        for c in 0..3 {
            expected[(3 * p) as usize + c] = e[c] as f64;
        }
    }
    let zero = vec![0.0; expected.len()];
    for media_lights in [true, false] {
        let out = render(&scene, &settings(4096, 5, media_lights, 1));
        let (m, v) = moments(&out);
        let a = compare((&m, &v), (&expected, &zero), 1e-3);
        let on = if media_lights { "on" } else { "off" };
        a.assert_holds(&format!("media lights {on}"));
    }
}

/// The example fire over its floor, every order of scattering: the media lights against the
/// paths' own emission alone (8 x 8 blocks).
#[test]
fn fire_with_media_lights_matches_the_paths_alone() {
    let scene = crate::common::render::load_scene("fire.gltf");
    let (w, h) = (32u32, 24u32);
    let sized = |spp, seed, on| RenderSettings {
        width: w,
        height: h,
        ..settings(spp, seed, on, brume::render::settings::DEFAULT_MAX_DEPTH)
    };
    let on = render(&scene, &sized(256, 21, true));
    let off = render(&scene, &sized(1024, 22, false));
    let a = compare_renders(&on, &off, w as usize, h as usize, 8, 1e-3);
    a.assert_holds("fire, media lights against the paths alone, 8 x 8 blocks");
}
