//! Frame sequences: a medium `uri` with a run of `#` read per frame, `--frame N` and
//! `--frames A..B` with `#` in the outputs, and a missing frame refused before any rendering.
use crate::common::cli::assert_refused;
use crate::common::scratch;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use brume::film::read_exr;

fn brume(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_brume"))
        .args(args)
        .output()
        .unwrap()
}

/// The cloud scene with its medium read from `cloud_####.vdb` in `dir`: frames 1 and 3 are
/// the cloud, frame 2 the smoke plume (`frames` of them are written).
fn sequence_scene(dir: &Path, frames: &[i32]) -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let json = std::fs::read_to_string(root.join("cloud.gltf")).unwrap();
    assert!(json.contains("\"vdb/cloud.vdb\""));
    let scene = dir.join("seq.gltf");
    std::fs::write(
        &scene,
        json.replace("\"vdb/cloud.vdb\"", "\"cloud_####.vdb\""),
    )
    .unwrap();
    for &f in frames {
        let source = if f == 2 { "smoke.vdb" } else { "cloud.vdb" };
        std::fs::copy(
            root.join("vdb").join(source),
            dir.join(format!("cloud_{f:04}.vdb")),
        )
        .unwrap();
    }
    scene
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
    let scene = sequence_scene(&dir, &[1, 2, 3]);
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
}

#[test]
fn a_missing_frame_is_refused_before_rendering() {
    let dir = scratch::dir("frames_missing");
    let scene = sequence_scene(&dir, &[1, 3]);
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
