//! Writes `scenes/sky.exr`, the procedural HDR sky of `scenes/cloud_sky.gltf`:
//! `cargo run --release --example make_sky`.
//!
//! A 256 x 128 equirectangular map (Blender's convention, see `integrator::envmap`): a dim
//! blue gradient sky, a darker ground below the horizon, and a small bright sun disc (2 degrees
//! in radius, a few pixels) where the cloud scene's directional sun was. The scene looks the
//! map up with the rotation below, so the sun is placed at `R * B * s` in the image (B: glTF to
//! Blender axes, R: the Mapping rotation) and arrives from world direction `s`; the horizon is
//! level in the world, so it is a tilted curve in the image. Deterministic:
//! rerunning reproduces the committed file.
use brume::render::envmap::{lookup_from_world, uv_to_direction};
use brume::scene::envmap::{write_environment_exr, EnvironmentImage};
use glam::{Quat, Vec2, Vec3};

/// The Mapping rotation written into `cloud_sky.gltf` (`BRUME_environment.rotation`).
const ROTATION: [f32; 3] = [0.1, -0.15, 0.6];
const WIDTH: u32 = 256;
const HEIGHT: u32 = 128;
const SUN_RADIUS: f32 = 0.035;
const SUN_RADIANCE: [f32; 3] = [900.0, 860.0, 780.0];

fn main() {
    // cloud.gltf's sun node: a directional light shines along its local -Z, so the light
    // comes from local +Z.
    let q = Quat::from_xyzw(-0.330_366_1, 0.243_210_35, 0.088_521_33, 0.907_673_4);
    let sun_world = (q * Vec3::Z).normalize();
    let lookup_from_world = lookup_from_world(ROTATION);
    let sun = lookup_from_world * sun_world;
    let mut rgb = Vec::with_capacity((WIDTH * HEIGHT) as usize);
    for j in 0..HEIGHT {
        for i in 0..WIDTH {
            let uv = Vec2::new(
                (i as f32 + 0.5) / WIDTH as f32,
                (j as f32 + 0.5) / HEIGHT as f32,
            );
            // The pixel's direction in the lookup frame, and in the world, where the gradient
            // and the horizon are level (glTF +Y up) whatever the rotation.
            let d = uv_to_direction(uv);
            let up = (lookup_from_world.transpose() * d).y;
            let c = if d.dot(sun).clamp(-1.0, 1.0).acos() < SUN_RADIUS {
                SUN_RADIANCE
            } else if up >= 0.0 {
                // Whitish at the horizon, deeper blue overhead.
                let t = up.sqrt();
                [0.55 - 0.35 * t, 0.65 - 0.3 * t, 0.8 - 0.1 * t]
            } else {
                [0.12, 0.1, 0.08]
            };
            rgb.push(c);
        }
    }
    let image = EnvironmentImage {
        width: WIDTH,
        height: HEIGHT,
        rgb,
    };
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/sky.exr");
    write_environment_exr(&path, &image).unwrap_or_else(|e| panic!("{e}"));
    println!(
        "wrote {} ({WIDTH}x{HEIGHT}, sun towards world {sun_world}, rotation {ROTATION:?})",
        path.display()
    );
}
