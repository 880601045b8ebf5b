//! glTF node animations through the scene loader: a node placed at the frame's time
//! (`frame / fps`), and each malformed channel refused with an error naming it.
use super::{base, f32_bytes, load_err_with, load_ok, triangle_bin, write};

use brume::scene::{self, LoadOptions};
use glam::Vec3;
use serde_json::{json, Value};

/// The triangle document with node 0 translated by a channel keyed at `times` to `values`
/// (x of each key; y and z 0), `interpolation`, its keys after the triangle's 44 bytes.
fn animated(times: &[f32], xs: &[f32], interpolation: &str) -> (Value, Vec<u8>) {
    let mut doc = base();
    let mut bin = triangle_bin();
    let values: Vec<f32> = xs.iter().flat_map(|&x| [x, 0.0, 0.0]).collect();
    let t0 = bin.len();
    bin.extend(f32_bytes(times));
    let v0 = bin.len();
    bin.extend(f32_bytes(&values));
    doc["buffers"][0]["byteLength"] = json!(bin.len());
    let views = doc["bufferViews"].as_array_mut().unwrap();
    views.push(json!({"buffer": 0, "byteOffset": t0, "byteLength": 4 * times.len()}));
    views.push(json!({"buffer": 0, "byteOffset": v0, "byteLength": 4 * values.len()}));
    let accessors = doc["accessors"].as_array_mut().unwrap();
    accessors.push(
        json!({"bufferView": 2, "componentType": 5126, "count": times.len(), "type": "SCALAR"}),
    );
    accessors
        .push(json!({"bufferView": 3, "componentType": 5126, "count": xs.len(), "type": "VEC3"}));
    doc["animations"] = json!([{
        "channels": [{"sampler": 0, "target": {"node": 0, "path": "translation"}}],
        "samplers": [{"input": 2, "output": 3, "interpolation": interpolation}]
    }]);
    (doc, bin)
}

fn at_frame(frame: i32) -> LoadOptions {
    LoadOptions {
        frame: Some(frame),
        ..Default::default()
    }
}

#[test]
fn an_animated_node_is_placed_at_the_frame_time() {
    // Keys at 0 s and 1 s; 24 fps: frame 6 is t = 0.25, frame 48 after the last key.
    let (doc, bin) = animated(&[0.0, 1.0], &[0.0, 8.0], "LINEAR");
    let path = write("anim_linear", &doc, &bin);
    for (frame, x) in [(0, 0.0), (6, 2.0), (12, 4.0), (48, 8.0), (-5, 0.0)] {
        let s = scene::load_with(&path, &at_frame(frame)).unwrap_or_else(|e| panic!("{e}"));
        let p = Vec3::from(s.vertices()[1].position);
        assert_eq!(p, Vec3::new(1.0 + x, 0.0, 0.0), "frame {frame}");
    }
    let (doc, bin) = animated(&[0.0, 1.0], &[0.0, 8.0], "STEP");
    let s = scene::load_with(&write("anim_step", &doc, &bin), &at_frame(23)).unwrap();
    assert_eq!(
        Vec3::from(s.vertices()[1].position),
        Vec3::new(1.0, 0.0, 0.0)
    );
    // The scene's own frame and fps: frame 3 at 12 fps is t = 0.25.
    let (mut doc, bin) = animated(&[0.0, 1.0], &[0.0, 8.0], "LINEAR");
    doc["extensions"] = json!({"BRUME_render": {"frame": 3, "fps": 12}});
    doc["extensionsUsed"] = json!(["BRUME_render"]);
    let s = load_ok(&write("anim_scene_frame", &doc, &bin));
    assert_eq!(
        Vec3::from(s.vertices()[1].position),
        Vec3::new(3.0, 0.0, 0.0)
    );
}

#[test]
fn malformed_channels_are_refused_naming_the_channel() {
    let channel = "/animations/0/channels/0";
    // Key times that do not increase.
    let (doc, bin) = animated(&[0.0, 1.0, 1.0], &[0.0, 1.0, 2.0], "LINEAR");
    let e = load_err_with(&write("anim_times", &doc, &bin), channel, &at_frame(1));
    assert!(e.to_string().contains("not after the one before"), "{e}");
    // Too few values for a cubic spline (three per key).
    let (doc, bin) = animated(&[0.0, 1.0], &[0.0, 1.0], "CUBICSPLINE");
    let e = load_err_with(&write("anim_cubic", &doc, &bin), channel, &at_frame(1));
    assert!(e.to_string().contains("3 value(s) per key"), "{e}");
    // A non-finite value.
    let (doc, bin) = animated(&[0.0, 1.0], &[0.0, f32::NAN], "LINEAR");
    let e = load_err_with(&write("anim_nan", &doc, &bin), channel, &at_frame(1));
    assert!(e.to_string().contains("not finite"), "{e}");
    // Two channels driving the same property of one node.
    let (mut doc, bin) = animated(&[0.0, 1.0], &[0.0, 1.0], "LINEAR");
    let c = doc["animations"][0]["channels"][0].clone();
    doc["animations"][0]["channels"] = json!([c.clone(), c]);
    let e = load_err_with(
        &write("anim_twice", &doc, &bin),
        "/animations/0/channels/1",
        &at_frame(1),
    );
    assert!(e.to_string().contains("second channel"), "{e}");
    // An animated node given as a matrix.
    let (mut doc, bin) = animated(&[0.0, 1.0], &[0.0, 1.0], "LINEAR");
    doc["nodes"][0]["matrix"] = json!([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]);
    let e = load_err_with(&write("anim_matrix", &doc, &bin), channel, &at_frame(1));
    assert!(e.to_string().contains("matrix"), "{e}");
}
