//! Motion blur from the command line: `--shutter 0,0` renders exactly the still scene,
//! `brume info` reports the shutter and the velocity, the GPU backend renders blur (or says
//! why it cannot run at all), `--frames scene` renders the scene's frame range, and bad velocity and shutter
//! input is refused naming the file and what is wrong.
use crate::common::cli::{assert_refused, render_to};
use crate::common::scratch;
use crate::common::sequence::cloud_sequence;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use brume::film::read_exr;
use serde_json::{json, Value};

fn brume(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_brume"))
        .args(args)
        .output()
        .unwrap()
}

fn scene(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name)
}

const SMALL: [&str; 8] = [
    "--spp",
    "4",
    "--width",
    "24",
    "--height",
    "32",
    "--backend",
    "cpu",
];

fn render(scene: &Path, out: &Path, extra: &[&str]) -> Output {
    render_to(scene, out, &SMALL, extra)
}

/// `plume_blur.gltf` is `plume_sun.gltf` with a velocity grid beside the same density and a
/// shutter: closing the shutter gives plume_sun's image bit for bit, and the open shutter
/// another image.
#[test]
fn a_closed_shutter_renders_the_still_scene_exactly() {
    let d = scratch::dir("blur_cli");
    let (still, closed, open) = (
        d.join("still.exr"),
        d.join("closed.exr"),
        d.join("open.exr"),
    );
    for (scene_name, out, extra) in [
        ("plume_sun.gltf", &still, &[][..]),
        ("plume_blur.gltf", &closed, &["--shutter", "0,0"][..]),
        ("plume_blur.gltf", &open, &[][..]),
    ] {
        let o = render(&scene(scene_name), out, extra);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let px = |p: &Path| read_exr(p).unwrap().rgb;
    assert_eq!(px(&still), px(&closed), "--shutter 0,0 is the still render");
    assert_ne!(px(&still), px(&open), "the open shutter blurs");
    let o = brume(&["info", scene("plume_blur.gltf").to_str().unwrap()]);
    let info = String::from_utf8_lossy(&o.stdout);
    println!("{info}");
    assert!(info.contains("shutter: -0.25 to 0.25 frames around the frame (24 fps)"));
    assert!(info.contains("velocity \"velocity\" (staggered, per second, scale 8)"));
}

/// `--backend gpu` renders the blurred example where a Vulkan adapter exists (lavapipe
/// included), and where none does fails with a one-line reason and writes nothing.
#[test]
fn the_gpu_backend_renders_blur_or_says_why_not() {
    let d = scratch::dir("blur_gpu");
    let args = |out: &Path| {
        vec![
            "render".to_string(),
            scene("plume_blur.gltf").display().to_string(),
            "-o".into(),
            out.display().to_string(),
            "--spp".into(),
            "1".into(),
            "--width".into(),
            "8".into(),
            "--height".into(),
            "8".into(),
            "--backend".into(),
            "gpu".into(),
        ]
    };
    let out = d.join("gpu.exr");
    let o = Command::new(env!("CARGO_BIN_EXE_brume"))
        .args(args(&out))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    println!("{}", err.trim());
    assert!(!err.contains("panicked"), "{err}");
    if o.status.success() {
        assert!(out.exists());
        let img = read_exr(&out).unwrap();
        assert_eq!((img.width, img.height), (8, 8));
    } else {
        assert!(err.contains("adapter"), "{err}");
        assert!(!out.exists());
    }
    // No Vulkan driver at all: a clear refusal, nothing written.
    let none = d.join("none.exr");
    let o = Command::new(env!("CARGO_BIN_EXE_brume"))
        .args(args(&none))
        .env("VK_ICD_FILENAMES", d.join("no_such_icd.json"))
        .env("VK_DRIVER_FILES", d.join("no_such_icd.json"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    println!("{}", err.trim());
    assert!(!o.status.success());
    assert!(!err.contains("panicked"), "{err}");
    assert!(err.contains("adapter"), "{err}");
    assert!(!none.exists());
}

/// `--frames scene` renders `BRUME_render.frameRange`; without one it is refused.
#[test]
fn frames_scene_renders_the_scene_frame_range() {
    let d = scratch::dir("blur_frame_range");
    let seq = cloud_sequence(&d, [2, 3]);
    let mut doc: Value = serde_json::from_str(&std::fs::read_to_string(&seq).unwrap()).unwrap();
    let o = render(&seq, &d.join("x_####.exr"), &["--frames", "scene"]);
    assert_refused(&o, &seq, "no frameRange", "--frames scene without a range");
    doc["extensions"]["BRUME_render"] = json!({"frameRange": [2, 3]});
    if let Some(used) = doc["extensionsUsed"].as_array_mut() {
        used.push(json!("BRUME_render"));
    }
    let ranged = d.join("ranged.gltf");
    std::fs::write(&ranged, doc.to_string()).unwrap();
    let o = render(&ranged, &d.join("r_####.exr"), &["--frames", "scene"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(d.join("r_0002.exr").is_file() && d.join("r_0003.exr").is_file());
    assert!(!d.join("r_0001.exr").exists());
}

/// Bad velocity and shutter input: each refused with the scene file named and the reason.
#[test]
fn bad_velocity_and_shutter_input_is_refused() {
    let d = scratch::dir("blur_bad");
    let base: Value =
        serde_json::from_str(&std::fs::read_to_string(scene("plume_blur.gltf")).unwrap()).unwrap();
    let vdb = scene("vdb/plume_vel.vdb");
    let case = |name: &str, edit: &dyn Fn(&mut Value), why: &str| {
        let mut doc = base.clone();
        doc["nodes"][1]["extensions"]["BRUME_medium_vdb"]["uri"] = json!(vdb.to_str().unwrap());
        edit(&mut doc);
        let p = d.join(format!("{name}.gltf"));
        std::fs::write(&p, doc.to_string()).unwrap();
        let o = render(&p, &d.join(format!("{name}.exr")), &[]);
        assert_refused(&o, &p, why, name);
        assert!(!d.join(format!("{name}.exr")).exists());
    };
    let medium = |doc: &mut Value, k: &str, v: Value| {
        doc["nodes"][1]["extensions"]["BRUME_medium_vdb"][k] = v;
    };
    case(
        "float_velocity",
        &|doc| medium(doc, "velocityGrid", json!("density")),
        "velocityGrid",
    );
    case(
        "missing_velocity",
        &|doc| medium(doc, "velocityGrid", json!("vel")),
        "velocity",
    );
    case(
        "bad_unit",
        &|doc| medium(doc, "velocityUnit", json!("minute")),
        "not one of second, frame",
    );
    case(
        "negative_scale",
        &|doc| medium(doc, "velocityScale", json!(-1.0)),
        "velocityScale",
    );
    case(
        "shutter_backwards",
        &|doc| doc["extensions"]["BRUME_render"]["shutter"] = json!({"open": 0.5, "close": 0.0}),
        "closes",
    );
    case(
        "bad_frame_range",
        &|doc| doc["extensions"]["BRUME_render"]["frameRange"] = json!([5, 1]),
        "frameRange",
    );
    let o = render(
        &scene("plume_blur.gltf"),
        &d.join("flag.exr"),
        &["--shutter", "0.5"],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("OPEN,CLOSE"), "{err}");
}
