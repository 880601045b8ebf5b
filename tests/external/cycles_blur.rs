//! Motion blur against Blender Cycles (docs/comparing.md, docs/blender.md):
//! - velocity blur of a Mantaflow bake: tools/cycles/mantaflow_smoke.py bakes a small smoke
//!   simulation headless (OpenVDB cache with Mantaflow's own staggered `velocity` grid) and
//!   saves a .blend rendering its last frame as a Volume sequence with velocity blur; Brume
//!   renders the add-on's export of it (`brume import-blend`), Cycles the .blend itself;
//! - transformation blur of a camera panning across the still cloud (scenes/cloud.gltf with a
//!   glTF animation of the camera node), through tools/cycles/brume_to_cycles.py.
//!
//! Each asserts the agreement of tests/common/reference.rs (image means within 1 %, blocks by
//! the z-test) and that the blur shows: Cycles' blurred image against Brume's with the shutter
//! closed fails the block z-test in some blocks. Needs a Python that can `import bpy`
//! (tools/cycles/ci.sh installs one); without it each test prints a SKIPPED line on stderr and
//! passes. Seeds are fixed on both sides.
use crate::common;
use crate::common::external::{assert_ok, root, say, text, BpyRun};

use std::path::{Path, PathBuf};
use std::process::Command;

impl BpyRun {
    /// Renders `scene` with Brume at 32x24, 256 spp, into `out` (`extra` appended).
    fn render(&self, scene: &Path, out: &Path, extra: &[&str]) {
        let mut args: Vec<&std::ffi::OsStr> = vec!["render".as_ref(), scene.as_os_str()];
        args.extend(["-o".as_ref(), out.as_os_str()]);
        args.extend(
            [
                "--spp", "256", "--seed", "7", "--width", "32", "--height", "24",
            ]
            .map(std::ffi::OsStr::new),
        );
        args.extend(extra.iter().map(std::ffi::OsStr::new));
        assert_ok(&self.brume(&args), "brume render");
    }

    /// `brume cycles SCENE` (a .blend or a glTF), 4 runs of `spp` at 32x24, against `brume`:
    /// the agreement line, asserted.
    fn cycles_against(&self, scene: &Path, out: &Path, spp: &str, brume: &Path) -> String {
        let mut args: Vec<&std::ffi::OsStr> = vec!["cycles".as_ref(), scene.as_os_str()];
        args.extend(["-o".as_ref(), out.as_os_str()]);
        args.extend(
            [
                "--spp", spp, "--runs", "4", "--seed", "1", "--width", "32", "--height", "24",
            ]
            .map(std::ffi::OsStr::new),
        );
        args.extend(["--against".as_ref(), brume.as_os_str()]);
        let o = self.brume(&args);
        assert_ok(&o, "brume cycles");
        common::reference::assert_agreement(&String::from_utf8_lossy(&o.stdout))
    }

    /// The blocks of `blurred` that differ from `still` (`brume compare`'s 8x8 block z-test at
    /// the Sidak-corrected level): (failing, tests).
    fn blur_shows(&self, blurred: &Path, still: &Path) -> (usize, usize) {
        let o = self.brume(&["compare".as_ref(), blurred.as_os_str(), still.as_os_str()]);
        let out = String::from_utf8_lossy(&o.stdout).into_owned();
        let line = out
            .lines()
            .find(|l| l.starts_with("8x8 block z-test"))
            .unwrap_or_else(|| panic!("no block z-test in:\n{}", text(&o)));
        let number_before = |s: &str, word: &str| -> usize {
            let head = &s[..s.find(word).unwrap_or_else(|| panic!("{word} in {s}"))];
            head.trim_end()
                .rsplit(|c: char| !c.is_ascii_digit())
                .next()
                .unwrap()
                .parse()
                .unwrap()
        };
        let tests = number_before(line, " tests");
        let sidak = &line[line.find("Sidak").unwrap()..];
        (number_before(sidak, " fail"), tests)
    }
}

/// A Mantaflow smoke (24 cells across a 2 m domain, 16 frames, risen by buoyancy) rendered at
/// its last frame with its own velocity grid (staggered, per second) at Velocity Scale 2 under
/// a half-frame shutter centred on the frame: Cycles on the .blend and Brume on the add-on's
/// export agree, and the smear shows against Brume's closed-shutter render. The same export
/// through tools/cycles/brume_to_cycles.py gives back the .blend's velocity and motion
/// settings. Larger scales part the two renderers (docs/comparing.md, known differences).
#[test]
fn mantaflow_velocity_blur_agrees_with_cycles() {
    let Some(cx) = BpyRun::new("cycles_blur", "mantaflow") else {
        return;
    };
    let started = std::time::Instant::now();
    let o = Command::new(&cx.python)
        .arg(root().join("tools/cycles/mantaflow_smoke.py"))
        .arg(&cx.dir)
        .output()
        .unwrap();
    assert_ok(&o, "mantaflow_smoke.py");
    let bake = String::from_utf8_lossy(&o.stdout)
        .lines()
        .find_map(|l| l.strip_prefix("bake_seconds ").map(str::to_string))
        .unwrap_or_default();
    let blend = cx.path("smoke.blend");
    let gltf = cx.path("smoke.gltf");
    let o = cx.brume(&[
        "import-blend".as_ref(),
        blend.as_os_str(),
        "-o".as_ref(),
        gltf.as_os_str(),
    ]);
    assert_ok(&o, "brume import-blend");

    // The export: the cache as a sequence read at frame 16, its velocity, the shutter.
    let s = brume::scene::load(&gltf).unwrap();
    let m = &s.vdb_media[0];
    assert_eq!(m.uri, "cache/data/fluid_data_####.vdb");
    assert_eq!(m.vdb_path, cx.path("cache/data/fluid_data_0016.vdb"));
    let v = m.velocity.as_ref().expect("the velocity grid");
    assert_eq!((v.grid_name.as_str(), v.scale), ("velocity", 2.0));
    assert_eq!(v.unit, brume::scene::VelocityUnit::Second);
    assert!(v.grid.staggered, "Mantaflow writes a staggered velocity");
    assert_eq!((s.frame, s.fps), (16, 24.0));
    assert_eq!((s.shutter.open, s.shutter.close), (-0.25, 0.25));

    // The export translated back to Blender (without rendering): the .blend's settings.
    let back = cx.path("back.blend");
    let o = Command::new(&cx.python)
        .arg(root().join("tools/cycles/brume_to_cycles.py"))
        .arg(&gltf)
        .arg("-o")
        .arg(cx.path("unused.exr"))
        .arg("--save-blend")
        .arg(&back)
        .arg("--no-render")
        .output()
        .unwrap();
    assert_ok(&o, "brume_to_cycles.py --no-render");
    let probe = "import bpy, json, sys\n\
        bpy.ops.wm.open_mainfile(filepath=sys.argv[1])\n\
        s = bpy.context.scene; r = s.render\n\
        v = [o for o in s.objects if o.type == 'VOLUME'][0]\n\
        print(json.dumps([s.frame_current, r.fps / r.fps_base, r.use_motion_blur, r.motion_blur_shutter,\n\
            r.motion_blur_position, v.data.velocity_grid, v.data.velocity_unit, v.data.velocity_scale,\n\
            v.cycles.use_motion_blur, bpy.path.basename(v.data.filepath)]))\n";
    let o = Command::new(&cx.python)
        .args(["-c", probe])
        .arg(&back)
        .output()
        .unwrap();
    assert_ok(&o, "reading back.blend");
    let stdout = String::from_utf8_lossy(&o.stdout);
    let line = stdout.lines().rev().find(|l| l.starts_with('[')).unwrap();
    let got: serde_json::Value = serde_json::from_str(line).unwrap();
    assert_eq!(
        got,
        serde_json::json!([
            16,
            24.0,
            true,
            0.5,
            "CENTER",
            "velocity",
            "SECOND",
            2.0,
            true,
            "fluid_data_0016.vdb"
        ])
    );

    let (blurred, still, cycles) = (
        cx.path("brume.exr"),
        cx.path("still.exr"),
        cx.path("cycles.exr"),
    );
    cx.render(&gltf, &blurred, &[]);
    cx.render(&gltf, &still, &["--shutter", "0,0"]);
    let line = cx.cycles_against(&blend, &cycles, "64", &blurred);
    let (bad, tests) = cx.blur_shows(&cycles, &still);
    assert!(
        bad > 0,
        "Cycles' blurred smoke does not differ from Brume's still one ({bad} of {tests} block tests)"
    );
    say(&format!(
        "cycles_blur: Mantaflow smoke (bake {bake} s) 32x24, velocity scale 2, Brume 256 spp vs Cycles 4 x 64 spp: {line}; \
         against the closed shutter {bad} of {tests} block tests fail; {:.1} s",
        started.elapsed().as_secs_f64()
    ));
}

/// scenes/cloud.gltf with the camera panning: its node keyed (LINEAR) at frames 0 and 2 from
/// 2.5 m left of its place to 2.5 m right while turning by 0.1 rad about y, 24 fps, rendered at
/// frame 1 with a half-frame shutter centred on it (a 1.25 m sweep). Written into `dir` (with
/// its .bin).
fn panning_cloud(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(root().join("scenes/cloud.gltf")).unwrap();
    let mut doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    let vdb = root().join("scenes/vdb/cloud.vdb");
    let nodes = doc["nodes"].as_array_mut().unwrap();
    let camera = nodes
        .iter()
        .position(|n| n.get("camera").is_some())
        .unwrap();
    for n in nodes.iter_mut() {
        if let Some(m) = n.pointer_mut("/extensions/BRUME_medium_vdb") {
            m["uri"] = vdb.to_str().unwrap().into();
        }
    }
    let node = &nodes[camera];
    let number = |v: &serde_json::Value| v.as_f64().unwrap() as f32;
    let rest_t: Vec<f32> = node["translation"]
        .as_array()
        .unwrap()
        .iter()
        .map(number)
        .collect();
    let r: Vec<f32> = node["rotation"]
        .as_array()
        .unwrap()
        .iter()
        .map(number)
        .collect();
    let rest_q = glam::Quat::from_xyzw(r[0], r[1], r[2], r[3]);
    let fps = 24.0f32;
    let times = [0.0f32, 2.0 / fps];
    let translations = [
        [rest_t[0] - 2.5, rest_t[1], rest_t[2]],
        [rest_t[0] + 2.5, rest_t[1], rest_t[2]],
    ];
    let rotations = [
        glam::Quat::from_rotation_y(0.05) * rest_q,
        glam::Quat::from_rotation_y(-0.05) * rest_q,
    ];
    let floats: Vec<f32> = times
        .into_iter()
        .chain(translations.into_iter().flatten())
        .chain(rotations.into_iter().flat_map(|q| q.to_array()))
        .collect();
    let bin: Vec<u8> = floats.iter().flat_map(|x| x.to_le_bytes()).collect();
    std::fs::write(dir.join("pan.bin"), &bin).unwrap();
    doc["buffers"] = serde_json::json!([{"uri": "pan.bin", "byteLength": bin.len()}]);
    doc["bufferViews"] = serde_json::json!([
        {"buffer": 0, "byteOffset": 0, "byteLength": 8},
        {"buffer": 0, "byteOffset": 8, "byteLength": 24},
        {"buffer": 0, "byteOffset": 32, "byteLength": 32},
    ]);
    doc["accessors"] = serde_json::json!([
        {"bufferView": 0, "componentType": 5126, "count": 2, "type": "SCALAR", "min": [times[0]], "max": [times[1]]},
        {"bufferView": 1, "componentType": 5126, "count": 2, "type": "VEC3"},
        {"bufferView": 2, "componentType": 5126, "count": 2, "type": "VEC4"},
    ]);
    doc["animations"] = serde_json::json!([{
        "name": "pan",
        "samplers": [
            {"input": 0, "output": 1, "interpolation": "LINEAR"},
            {"input": 0, "output": 2, "interpolation": "LINEAR"},
        ],
        "channels": [
            {"sampler": 0, "target": {"node": camera, "path": "translation"}},
            {"sampler": 1, "target": {"node": camera, "path": "rotation"}},
        ],
    }]);
    doc["extensions"]["BRUME_render"] =
        serde_json::json!({"fps": fps, "frame": 1, "shutter": {"open": -0.25, "close": 0.25}});
    let used = doc["extensionsUsed"].as_array_mut().unwrap();
    if !used.iter().any(|e| e == "BRUME_render") {
        used.push("BRUME_render".into());
    }
    let scene = dir.join("cloud_pan.gltf");
    std::fs::write(&scene, serde_json::to_string(&doc).unwrap()).unwrap();
    scene
}

/// A camera panning across the still cloud: Brume evaluates the glTF animation at each
/// sample's time in the shutter; Cycles renders Blender's import of the same animation with
/// Blender's camera motion blur. They agree, and the smear shows against the closed shutter.
#[test]
fn camera_blur_agrees_with_cycles() {
    let Some(cx) = BpyRun::new("cycles_blur", "camera") else {
        return;
    };
    let started = std::time::Instant::now();
    let scene = panning_cloud(&cx.dir);
    let (blurred, still, cycles) = (
        cx.path("brume.exr"),
        cx.path("still.exr"),
        cx.path("cycles.exr"),
    );
    cx.render(&scene, &blurred, &[]);
    cx.render(&scene, &still, &["--shutter", "0,0"]);
    let line = cx.cycles_against(&scene, &cycles, "32", &blurred);
    let (bad, tests) = cx.blur_shows(&cycles, &still);
    assert!(
        bad > 0,
        "Cycles' blurred cloud does not differ from Brume's still one ({bad} of {tests} block tests)"
    );
    say(&format!(
        "cycles_blur: cloud under a panning camera 32x24, Brume 256 spp vs Cycles 4 x 32 spp: {line}; \
         against the closed shutter {bad} of {tests} block tests fail; {:.1} s",
        started.elapsed().as_secs_f64()
    ));
}
