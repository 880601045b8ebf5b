//! Frame sequences: a medium `uri` with a run of `#` read per frame, `--frame N` and
//! `--frames A..B` with `#` in the outputs, and a missing frame refused before any rendering.
use crate::common::cli::{assert_refused, render_to};
use crate::common::scratch;
use crate::common::sequence::cloud_sequence;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use brume::film::read_exr;

fn brume(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_brume"))
        .args(args)
        .output()
        .unwrap()
}

const SMALL: [&str; 8] = [
    "--spp",
    "2",
    "--width",
    "16",
    "--height",
    "12",
    "--backend",
    "cpu",
];

fn pixels(path: &Path) -> Vec<[f32; 3]> {
    read_exr(path).unwrap().rgb
}

#[test]
fn each_frame_of_a_sequence_equals_its_single_render() {
    let dir = scratch::dir("frames");
    let scene = cloud_sequence(&dir, [1, 2, 3]);
    let pattern = dir.join("out_####.exr");
    let mut args = vec!["render", scene.to_str().unwrap(), "-o"];
    args.extend([pattern.to_str().unwrap(), "--frames", "1..3"]);
    args.extend(SMALL);
    let o = brume(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let frames: Vec<_> = (1..=3)
        .map(|f| pixels(&dir.join(format!("out_{f:04}.exr"))))
        .collect();
    assert_eq!(frames[0], frames[2], "frames 1 and 3 read the same file");
    assert_ne!(frames[0], frames[1], "frame 2 reads another file");
    let single = dir.join("single.exr");
    let mut args = vec!["render", scene.to_str().unwrap(), "-o"];
    args.extend([single.to_str().unwrap(), "--frame", "2"]);
    args.extend(SMALL);
    let o = brume(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(
        pixels(&single),
        frames[1],
        "--frame 2 equals frame 2 of --frames"
    );
    let o = brume(&["info", scene.to_str().unwrap()]);
    let info = String::from_utf8_lossy(&o.stdout);
    assert!(
        info.contains("frame 1 at 24 fps: 0 animated node(s), 1 medium file sequence(s)"),
        "{info}"
    );
}

#[test]
fn a_missing_frame_is_refused_before_rendering() {
    let dir = scratch::dir("frames_missing");
    let scene = cloud_sequence(&dir, [1, 3]);
    let pattern = dir.join("out_####.exr");
    let mut args = vec!["render", scene.to_str().unwrap(), "-o"];
    args.extend([pattern.to_str().unwrap(), "--frames", "1..3"]);
    args.extend(SMALL);
    let o = brume(&args);
    assert_refused(&o, &dir.join("cloud_0002.vdb"), "frame 2", "missing frame");
    assert!(
        !dir.join("out_0001.exr").exists(),
        "nothing is rendered before the check"
    );
    // Several frames into one file name would overwrite each other.
    let one = dir.join("out.exr");
    let mut args = vec!["render", scene.to_str().unwrap(), "-o"];
    args.extend([one.to_str().unwrap(), "--frames", "1..3"]);
    args.extend(SMALL);
    assert_refused(&brume(&args), &one, "run of #", "no # in --output");
}

/// The cloud scene with its camera node's translation animated linearly from `z0` at time 0
/// to `z1` at time 1 (keys in `NAME.bin`), or, with `still`, placed at `still` instead.
fn animated_cloud(dir: &Path, name: &str, z: (f32, f32), still: Option<f32>) -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(root.join("cloud.gltf")).unwrap()).unwrap();
    let t = doc["nodes"][0]["translation"].clone();
    let (x, y) = (t[0].as_f64().unwrap() as f32, t[1].as_f64().unwrap() as f32);
    // The cloud's file relative to the new scene's folder.
    let vdb = root.join("vdb/cloud.vdb");
    set_vdb_uri(&mut doc, &vdb);
    if let Some(z) = still {
        doc["nodes"][0]["translation"] = serde_json::json!([x, y, z]);
    } else {
        let floats = [0.0f32, 1.0, x, y, z.0, x, y, z.1];
        let bytes: Vec<u8> = floats.iter().flat_map(|f| f.to_le_bytes()).collect();
        let bin = format!("{name}.bin");
        std::fs::write(dir.join(&bin), bytes).unwrap();
        doc["buffers"] = serde_json::json!([{ "byteLength": 32, "uri": bin }]);
        doc["bufferViews"] = serde_json::json!([
            { "buffer": 0, "byteOffset": 0, "byteLength": 8 },
            { "buffer": 0, "byteOffset": 8, "byteLength": 24 }
        ]);
        doc["accessors"] = serde_json::json!([
            { "bufferView": 0, "componentType": 5126, "count": 2, "type": "SCALAR",
              "min": [0.0], "max": [1.0] },
            { "bufferView": 1, "componentType": 5126, "count": 2, "type": "VEC3" }
        ]);
        doc["animations"] = serde_json::json!([{
            "channels": [{ "sampler": 0, "target": { "node": 0, "path": "translation" } }],
            "samplers": [{ "input": 0, "output": 1, "interpolation": "LINEAR" }]
        }]);
    }
    let path = dir.join(name);
    std::fs::write(&path, serde_json::to_string(&doc).unwrap()).unwrap();
    path
}

/// Points every `BRUME_medium_vdb` of `doc` at `vdb` (an absolute path, percent-encoded).
fn set_vdb_uri(doc: &mut serde_json::Value, vdb: &Path) {
    for node in doc["nodes"].as_array_mut().unwrap() {
        if let Some(m) = node.pointer_mut("/extensions/BRUME_medium_vdb") {
            let p = vdb
                .to_str()
                .unwrap()
                .replace('%', "%25")
                .replace(' ', "%20");
            m["uri"] = serde_json::Value::String(p);
        }
    }
}

#[test]
fn an_animated_camera_renders_as_the_still_camera_at_its_pose() {
    let dir = scratch::dir("animated_camera");
    let animated = animated_cloud(&dir, "animated.gltf", (9.0, 13.0), None);
    // Frame 12 at 24 fps is time 0.5: z = 9 + (13 - 9) * 0.5 = 11 exactly.
    let still = animated_cloud(&dir, "still.gltf", (9.0, 13.0), Some(11.0));
    let render = |scene: &Path, out: &str, extra: &[&str]| {
        let out = dir.join(out);
        let o = render_to(scene, &out, &SMALL, extra);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        pixels(&out)
    };
    let at_12 = render(&animated, "a12.exr", &["--frame", "12"]);
    assert_eq!(
        at_12,
        render(&still, "still.exr", &[]),
        "frame 12 is the pose at t = 0.5"
    );
    assert_ne!(
        at_12,
        render(&animated, "a0.exr", &["--frame", "0"]),
        "frame 0 is the first key's pose"
    );
}
