//! `brume render` and `brume info` as a user runs them: every example scene to a finite EXR
//! with its metadata, tile logs whose counts add up to the printed totals, scene render
//! settings, Ctrl-C, and clear errors on bad input.
use crate::common::scratch;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use brume::film::{read_exr, read_tile_log, totals};

const SCENES: [&str; 10] = [
    "cloud",
    "cornell_smoke",
    "glass_volume",
    "fire",
    "chromatic",
    "chromatic_smoke",
    "furnace",
    "plume_sun",
    "plume_sky",
    "dense_fog",
];

fn scene(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(format!("{name}.gltf"))
}

fn brume(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_brume"))
        .args(args)
        .output()
        .unwrap()
}

fn text(o: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// The `totals:` line printed at the end, as (name, value) pairs.
fn printed_totals(stdout: &str) -> Vec<(String, u64)> {
    let line = stdout
        .lines()
        .find(|l| l.starts_with("totals:"))
        .expect("a totals line");
    let words: Vec<&str> = line["totals:".len()..].split_whitespace().collect();
    words
        .chunks(2)
        .map(|c| (c[0].to_string(), c[1].parse().unwrap()))
        .collect()
}

#[test]
fn every_example_scene_renders_to_a_finite_exr_with_logs() {
    for name in SCENES {
        let exr = scratch::file(&format!("{name}.exr"));
        let log = scratch::file(&format!("{name}.jsonl"));
        let cost = scratch::file(&format!("{name}-cost.exr"));
        let o = brume(&[
            "render",
            scene(name).to_str().unwrap(),
            "-o",
            exr.to_str().unwrap(),
            "--spp",
            "3",
            "--width",
            "24",
            "--height",
            "18",
            "--tile-log",
            log.to_str().unwrap(),
            "--cost-map",
            cost.to_str().unwrap(),
        ]);
        let (stdout, stderr) = text(&o);
        assert!(o.status.success(), "{name}: {stderr}");
        assert!(
            stderr.contains("scene effects:") && stderr.contains("cpu path:"),
            "{stderr}"
        );
        let img = read_exr(&exr).unwrap();
        assert_eq!((img.width, img.height), (24, 18));
        assert!(
            img.rgb.iter().flatten().all(|v| v.is_finite()),
            "{name}: non-finite pixels"
        );
        assert!(img
            .variance
            .as_ref()
            .unwrap()
            .iter()
            .flatten()
            .all(|v| v.is_finite() && *v >= 0.0));
        assert!(img.samples.as_ref().unwrap().iter().all(|&n| n == 3.0));
        for key in [
            "estimator",
            "b",
            "m",
            "majorant_mode",
            "spp",
            "seconds",
            "seed",
            "scene",
            "version",
            "backend",
            "features",
        ] {
            assert!(
                img.attributes.get(&format!("brume:{key}")).is_some(),
                "{name}: no brume:{key}"
            );
        }
        // One line per tile per pass: 2 x 2 tiles of 16 px, passes of 1, 1 and 1 spp.
        let records = read_tile_log(&log).unwrap();
        assert_eq!(records.len(), 4 * 3, "{name}");
        let t = totals(&records);
        for (k, v) in printed_totals(&stdout) {
            let logged = match k.as_str() {
                "samples" => t.counters.samples,
                "density_lookups" => t.counters.density_lookups,
                "null_collisions" => t.counters.null_collisions,
                "real_collisions" => t.counters.real_collisions,
                "shadow_lookups" => t.counters.shadow_lookups,
                "emission_lookups" => t.counters.emission_lookups,
                "path_length_sum" => t.counters.path_length_sum,
                "guard_fired" => t.counters.guard_fired,
                "majorant_violations" => t.counters.majorant_violations,
                "majorant_segments" => t.counters.majorant_segments,
                "shadow_segments" => t.counters.shadow_segments,
                other => panic!("unexpected total {other}"),
            };
            assert_eq!(logged, v, "{name}: {k}");
        }
        assert_eq!(t.counters.samples, 24 * 18 * 3);
        assert_eq!(
            t.counters.guard_fired, 0,
            "{name}: the guard must not fire in the example scenes"
        );
        assert!(read_exr(&cost).is_ok());
    }
}

#[test]
fn oiiotool_reads_the_metadata() {
    if Command::new("oiiotool").arg("--version").output().is_err() {
        eprintln!("SKIP: oiiotool not installed (Debian openimageio-tools)");
        return;
    }
    let exr = scratch::file("oiio.exr");
    assert!(brume(&[
        "render",
        scene("cloud").to_str().unwrap(),
        "-o",
        exr.to_str().unwrap(),
        "--spp",
        "1",
        "--width",
        "16",
        "--height",
        "12"
    ])
    .status
    .success());
    let o = Command::new("oiiotool")
        .args(["--info", "-v"])
        .arg(&exr)
        .output()
        .unwrap();
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success());
    for needle in [
        "brume:estimator",
        "delta",
        "brume:spp",
        "brume:version",
        "variance.R",
        "samples.Y",
    ] {
        assert!(
            out.contains(needle),
            "oiiotool output lacks {needle}:\n{out}"
        );
    }
}

#[test]
fn scene_render_settings_are_defaults_the_command_line_overrides() {
    let src = std::fs::read_to_string(scene("cloud")).unwrap();
    let mut doc: serde_json::Value = serde_json::from_str(&src).unwrap();
    doc["extensions"]["BRUME_render"] = serde_json::json!({"estimator": "weighted-delta", "b": 0.8, "spp": 2, "width": 20, "height": 10, "majorant": "global", "blackbody": "voxels"});
    let dir = scratch::file("settings");
    std::fs::create_dir_all(&dir).unwrap();
    let gltf = dir.join("cloud.gltf");
    std::fs::write(&gltf, serde_json::to_string(&doc).unwrap()).unwrap();
    std::os::unix::fs::symlink(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/vdb"),
        dir.join("vdb"),
    )
    .ok();
    let exr = dir.join("a.exr");
    let o = brume(&[
        "render",
        gltf.to_str().unwrap(),
        "-o",
        exr.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o).1);
    let img = read_exr(&exr).unwrap();
    assert_eq!((img.width, img.height), (20, 10));
    assert_eq!(
        img.attributes.text("brume:estimator"),
        Some("weighted-delta")
    );
    assert_eq!(img.attributes.text("brume:majorant_mode"), Some("global"));
    assert_eq!(img.attributes.text("brume:blackbody"), Some("voxels"));
    let o = brume(&[
        "render",
        gltf.to_str().unwrap(),
        "-o",
        exr.to_str().unwrap(),
        "--b",
        "1.25",
        "--estimator",
        "delta",
        "--width",
        "8",
        "--blackbody",
        "temperature",
    ]);
    assert!(o.status.success());
    let img = read_exr(&exr).unwrap();
    assert_eq!((img.width, img.height), (8, 10));
    assert_eq!(img.attributes.text("brume:estimator"), Some("delta"));
    assert_eq!(img.attributes.text("brume:blackbody"), None);
    // A bad value in the scene's settings names the file and the JSON location.
    doc["extensions"]["BRUME_render"]["estimator"] = serde_json::json!("fast");
    std::fs::write(&gltf, serde_json::to_string(&doc).unwrap()).unwrap();
    let (_, stderr) = text(&brume(&[
        "render",
        gltf.to_str().unwrap(),
        "-o",
        exr.to_str().unwrap(),
    ]));
    assert!(
        stderr.contains("cloud.gltf") && stderr.contains("/extensions/BRUME_render/estimator"),
        "{stderr}"
    );
}

#[test]
fn ctrl_c_keeps_what_has_accumulated() {
    // A folder of its own: the other tests write (atomically, through .tmp files) into the
    // shared one at the same time, and the check below looks for leftover .tmp files.
    let exr = scratch::file("ctrl-c").join("interrupted.exr");
    std::fs::create_dir_all(exr.parent().unwrap()).unwrap();
    let child = Command::new(env!("CARGO_BIN_EXE_brume"))
        .args([
            "render",
            scene("cloud").to_str().unwrap(),
            "-o",
            exr.to_str().unwrap(),
            "--spp",
            "1000000",
            "--width",
            "48",
            "--height",
            "36",
        ])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(1500));
    assert!(Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap()
        .success());
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "{}", text(&o).1);
    let img = read_exr(&exr).unwrap();
    assert_eq!(img.attributes.text("brume:interrupted"), Some("true"));
    let spp = img.samples.as_ref().unwrap()[0];
    assert!((1.0..1_000_000.0).contains(&spp), "{spp}");
    assert!(
        img.samples.unwrap().iter().all(|&n| n == spp),
        "whole passes only"
    );
    assert!(!std::fs::read_dir(exr.parent().unwrap()).unwrap().any(|e| e
        .unwrap()
        .file_name()
        .to_string_lossy()
        .contains(".tmp")));
}

#[test]
fn bad_render_inputs_fail_cleanly() {
    let missing_dir = scratch::file("no/such/dir/out.exr");
    for (args, needle) in [
        (
            vec![
                "render".to_string(),
                scratch::file("missing.gltf").display().to_string(),
                "-o".into(),
                scratch::file("x.exr").display().to_string(),
            ],
            "missing.gltf",
        ),
        (
            vec![
                "render".into(),
                scene("cloud").display().to_string(),
                "-o".into(),
                missing_dir.display().to_string(),
            ],
            "does not exist",
        ),
        (
            vec![
                "render".into(),
                scene("cloud").display().to_string(),
                "-o".into(),
                scratch::file("x.exr").display().to_string(),
                "--b".into(),
                "0".into(),
            ],
            "b = 0",
        ),
        (
            vec![
                "render".into(),
                scene("cloud").display().to_string(),
                "-o".into(),
                scratch::file("x.exr").display().to_string(),
                "--estimator".into(),
                "nope".into(),
            ],
            "unknown estimator",
        ),
    ] {
        let o = Command::new(env!("CARGO_BIN_EXE_brume"))
            .args(&args)
            .output()
            .unwrap();
        let (_, stderr) = text(&o);
        assert!(!o.status.success(), "{args:?}");
        assert!(
            stderr.contains(needle) && !stderr.contains("panicked"),
            "{args:?}: {stderr}"
        );
    }
}

#[test]
fn brume_info_prints_each_scenes_effects() {
    let expected = [
        ("cloud", "media, heterogeneous media, scattering, anisotropic phase, punctual lights, environment light"),
        ("furnace", "surfaces, media, heterogeneous media, scattering, anisotropic phase, environment light"),
        ("fire", "surfaces, media, heterogeneous media, scattering, absorption, media emission, environment light"),
        ("glass_volume", "surfaces, media, homogeneous media, scattering, absorption, chromatic extinction, anisotropic phase, punctual lights, environment light"),
        ("chromatic_smoke", "media, heterogeneous media, scattering, absorption, chromatic extinction, anisotropic phase, punctual lights, environment light"),
    ];
    for (name, effects) in expected {
        let o = brume(&["info", scene(name).to_str().unwrap()]);
        let (stdout, stderr) = text(&o);
        assert!(o.status.success(), "{stderr}");
        assert!(
            stdout.lines().any(|l| l == format!("effects: {effects}")),
            "{name}:\n{stdout}"
        );
    }
}

/// `brume info` and `brume render` say what the geometry costs: the grove's 5 primitives
/// (1536 triangles) stored once and placed 41 times (8976 triangles), its memory and timings,
/// and a render its peak memory.
#[test]
fn brume_info_and_render_count_stored_and_instanced_triangles() {
    let grove = scene("instancing/grove_ext");
    let o = brume(&["info", grove.to_str().unwrap()]);
    let (stdout, stderr) = text(&o);
    assert!(o.status.success(), "{stderr}");
    let counts = "triangles: 1536 stored (5 primitives, each once), 8976 instanced (41 placements";
    assert!(stdout.contains(counts), "{stdout}");
    assert!(
        stdout.contains("geometry memory: ") && stdout.contains("BVH built in "),
        "{stdout}"
    );
    let out = scratch::file("grove.exr");
    let o = brume(&[
        "render",
        grove.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--width",
        "16",
        "--height",
        "9",
        "--spp",
        "1",
    ]);
    let (_, stderr) = text(&o);
    assert!(o.status.success(), "{stderr}");
    assert!(stderr.contains(counts), "{stderr}");
    if cfg!(target_os = "linux") {
        assert!(stderr.contains("peak memory: "), "{stderr}");
    }
}

/// A grid of background only (a simulation's frame before the smoke, Mantaflow's `shadow`)
/// beside a density: `brume info` describes both, and says the empty one has no majorants.
#[test]
fn brume_info_describes_an_empty_grid() {
    use brume_ffi::{write_float_grids, GridSpec};
    let path = scratch::dir("info-empty").join("frame.vdb");
    let mut density = GridSpec::fog("density", 0.1, [0.0; 3]);
    density.voxels = vec![([1, 2, 3], 0.5), ([2, 2, 3], 1.0)];
    let empty = GridSpec::fog("shadow", 0.1, [0.0; 3]);
    write_float_grids(&path, &[density, empty]).unwrap();
    let o = brume(&["info", path.to_str().unwrap()]);
    let (stdout, stderr) = text(&o);
    assert!(
        o.status.success() && !stderr.contains("panicked"),
        "{stderr}"
    );
    assert!(stdout.contains("grid 'shadow'"), "{stdout}");
    assert!(
        stdout.contains("none (the grid holds no voxels)"),
        "{stdout}"
    );
}

#[test]
fn brume_info_shows_vec3_grids_with_class_and_speed() {
    use brume_ffi::{write_float_grids, GridClass, GridSpec};
    let path = scratch::dir("info-vec3").join("fluid.vdb");
    let mut grids = Vec::new();
    for (name, class) in [
        ("vel", GridClass::Staggered),
        ("vel_centred", GridClass::Unknown),
    ] {
        let mut g = GridSpec::vec3(name, class, 0.1, [0.0; 3]);
        let v = g.vectors.as_mut().unwrap();
        for i in 0..12 {
            for j in 0..10 {
                v.voxels.push(([i, j, 3], [3.0, -4.0, 0.0]));
            }
        }
        grids.push(g);
    }
    write_float_grids(&path, &grids).unwrap();
    let o = brume(&["info", path.to_str().unwrap()]);
    let (stdout, stderr) = text(&o);
    assert!(o.status.success(), "{stderr}");
    println!("{stdout}");
    for line in [
        "grid 'vel': vec3s, staggered (components on the voxel's lower faces)",
        "grid 'vel_centred': vec3s, cell-centred",
        "  background        [0.0, 0.0, 0.0]",
    ] {
        assert!(
            stdout.lines().any(|l| l == line),
            "no line {line:?} in:\n{stdout}"
        );
    }
    // |(3, -4, 0)| = 5 (up to the bounds' rounding slack of 2^-18) = 50 voxels of 0.1.
    let speeds: Vec<&str> = stdout
        .lines()
        .filter(|l| l.starts_with("  max speed"))
        .collect();
    assert_eq!(speeds.len(), 2, "{stdout}");
    for s in speeds {
        assert!(s.contains("5.0000") && s.contains("= 50.000"), "{s}");
    }
    assert_eq!(
        stdout
            .lines()
            .filter(|l| l.starts_with("  brume layout      3 components over"))
            .count(),
        2,
        "{stdout}"
    );
}

#[test]
fn render_says_which_accelerator_it_used_and_why() {
    let threshold = brume::accel::EMBREE_FROM_TRIANGLES.to_string();
    let (help, _) = text(&brume(&["render", "--help"]));
    assert!(
        help.contains(&format!("from {threshold} static triangles on")),
        "{help}"
    );
    for (accel, line) in [
        (None, "accel: bvh (auto: "),
        (Some("bvh"), "accel: bvh (--accel bvh, "),
        (Some("embree"), "accel: embree (--accel embree, "),
    ] {
        let exr = scratch::file(&format!("accel_{}.exr", accel.unwrap_or("auto")));
        let (path, out) = (scene("cornell_smoke"), exr.to_str().unwrap().to_string());
        let mut args = vec![path.to_str().unwrap(), "-o", &out, "--spp", "1"];
        args.extend(["--width", "8", "--height", "6", "--backend", "cpu"]);
        if let Some(a) = accel {
            args.extend(["--accel", a]);
        }
        let o = brume(&[&["render"], &args[..]].concat());
        let (_, stderr) = text(&o);
        assert!(o.status.success(), "{stderr}");
        let printed: Vec<&str> = stderr
            .lines()
            .filter(|l| l.starts_with("accel: "))
            .collect();
        assert_eq!(printed.len(), 1, "{stderr}");
        assert!(printed[0].starts_with(line), "{accel:?}: {}", printed[0]);
    }
}
