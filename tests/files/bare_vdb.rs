//! `brume render X.vdb`: a bare `.vdb` renders in a scene made for it. Every example grid, a
//! grid made with OpenVDB's `vdb_tool` and a grid far from the origin give a framed, lit image:
//! the image corners see only the sky, the medium covers part of the frame and is lit. The
//! choice is printed on one line, `--save-scene` writes a scene that renders the same image,
//! and files whose density grid cannot be told are refused with the grids they hold.
use crate::common::scratch;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use brume::film::read_exr;
use brume::scene::bare_vdb::SKY_STRENGTH;

const BIN: &str = env!("CARGO_BIN_EXE_brume");
const SKY: [f32; 3] = [0.45, 0.62, 1.0];

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn brume(args: &[&str]) -> Output {
    Command::new(BIN)
        .args(args)
        .current_dir(root())
        .output()
        .expect("run brume")
}

fn render(vdb: &Path, exr: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "render",
        vdb.to_str().unwrap(),
        "-o",
        exr.to_str().unwrap(),
        "--width",
        "64",
        "--height",
        "48",
        "--spp",
        "4",
        "--backend",
        "cpu",
    ];
    args.extend_from_slice(extra);
    brume(&args)
}

/// Asserts that the image at `exr` is framed and lit; returns its mean over medium pixels.
fn assert_framed_and_lit(exr: &Path, what: &str) -> f32 {
    let img = read_exr(exr).unwrap();
    let sky = SKY.map(|c| c * SKY_STRENGTH);
    let is_sky = |p: [f32; 3]| (0..3).all(|c| (p[c] - sky[c]).abs() <= 1e-4 * sky[c].max(1.0));
    let (w, h) = (img.width, img.height);
    for (x, y) in [(0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1)] {
        assert!(
            is_sky(img.rgb_at(x, y)),
            "{what}: corner ({x}, {y}) is {:?}, not the sky {sky:?}: the medium is not framed",
            img.rgb_at(x, y)
        );
    }
    let medium: Vec<[f32; 3]> = img.rgb.iter().copied().filter(|p| !is_sky(*p)).collect();
    let covered = medium.len() as f32 / img.rgb.len() as f32;
    assert!(
        (0.03..0.9).contains(&covered),
        "{what}: the medium covers {:.1} % of the frame",
        100.0 * covered
    );
    let mean = medium
        .iter()
        .map(|p| (p[0] + p[1] + p[2]) / 3.0)
        .sum::<f32>()
        / medium.len() as f32;
    assert!(
        mean.is_finite() && mean > 0.05,
        "{what}: the medium's pixels average {mean}: not lit"
    );
    mean
}

fn scene_line(out: &Output) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr);
    let lines: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("scene for "))
        .collect();
    assert_eq!(lines.len(), 1, "one line says what was chosen:\n{stderr}");
    lines[0].to_string()
}

#[test]
fn every_example_grid_renders_framed_and_lit() {
    let dir = scratch::dir("examples");
    let mut vdbs: Vec<PathBuf> = std::fs::read_dir(root().join("scenes/vdb"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "vdb"))
        .collect();
    vdbs.sort();
    assert!(vdbs.len() >= 10, "the example grids are in scenes/vdb");
    for vdb in &vdbs {
        let name = vdb.file_stem().unwrap().to_str().unwrap();
        let exr = dir.join(format!("{name}.exr"));
        let out = render(vdb, &exr, &[]);
        assert!(
            out.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let line = scene_line(&out);
        assert!(line.contains("density grid '"), "{line}");
        assert!(line.contains("densityScale"), "{line}");
        assert_framed_and_lit(&exr, name);
    }
}

#[test]
fn emission_grids_are_found_by_name() {
    let dir = scratch::dir("emission");
    let out = render(
        &root().join("scenes/vdb/fire.vdb"),
        &dir.join("fire.exr"),
        &[],
    );
    assert!(out.status.success());
    let line = scene_line(&out);
    assert!(line.contains("density grid 'density'"), "{line}");
    assert!(line.contains("emission grid 'flame'"), "{line}");
    let out = render(
        &root().join("scenes/vdb/cloud.vdb"),
        &dir.join("cloud.exr"),
        &[],
    );
    assert!(
        !scene_line(&out).contains("emission"),
        "the cloud has no emission grid"
    );
}

#[test]
fn a_grid_made_by_vdb_tool_renders_framed_and_lit() {
    let dir = scratch::dir("vdb_tool");
    let vdb = dir.join("ball.vdb");
    let made = Command::new("vdb_tool")
        .args([
            "-quiet",
            "-sphere",
            "r=3.0",
            "dim=48",
            "-ls2fog",
            "name=density",
            "-write",
        ])
        .arg(&vdb)
        .status();
    match made {
        Ok(s) if s.success() => {}
        _ => {
            println!("SKIPPED: vdb_tool (Debian's libopenvdb-tools) is not installed");
            return;
        }
    }
    let exr = dir.join("ball.exr");
    let out = render(&vdb, &exr, &[]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_framed_and_lit(&exr, "vdb_tool sphere");
}

#[test]
fn a_grid_far_from_the_origin_with_its_own_name_is_framed() {
    let dir = scratch::dir("far");
    let vdb = dir.join("far.vdb");
    let mut g = brume_ffi::GridSpec::fog("smoke", 0.25, [1000.0, -40.0, 250.0]);
    for x in 0..24 {
        for y in 0..12 {
            for z in 0..16 {
                g.voxels.push(([x, y, z], 0.5 + 0.02 * (x + y) as f32));
            }
        }
    }
    brume_ffi::write_float_grids(&vdb, &[g]).unwrap();
    let exr = dir.join("far.exr");
    let out = render(&vdb, &exr, &[]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        scene_line(&out).contains("density grid 'smoke'"),
        "the only float grid"
    );
    assert_framed_and_lit(&exr, "a box 1000 m from the origin");
}

#[test]
fn the_saved_scene_renders_the_same_image() {
    let dir = scratch::dir("save");
    let gltf = dir.join("smoke.gltf");
    let a = dir.join("a.exr");
    let out = render(
        &root().join("scenes/vdb/smoke.vdb"),
        &a,
        &["--save-scene", gltf.to_str().unwrap()],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let scene = brume::scene::load(&gltf).expect("the saved scene loads");
    assert_eq!(scene.vdb_media.len(), 1);
    assert_eq!(scene.lights.len(), 1, "a sun");
    let b = dir.join("b.exr");
    let out = render(&gltf, &b, &[]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(
        read_exr(&a).unwrap().rgb,
        read_exr(&b).unwrap().rgb,
        "same scene, same seed"
    );
    // Only a bare .vdb has a scene to save.
    let out = brume(&[
        "render",
        gltf.to_str().unwrap(),
        "-o",
        dir.join("c.exr").to_str().unwrap(),
        "--save-scene",
        dir.join("again.gltf").to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--save-scene"));
}

#[test]
fn an_ambiguous_or_empty_file_is_refused_with_its_grids() {
    let dir = scratch::dir("refused");
    let two = dir.join("two.vdb");
    let grid = |name: &str| {
        let mut g = brume_ffi::GridSpec::fog(name, 0.1, [0.0; 3]);
        g.voxels.push(([0, 0, 0], 1.0));
        g
    };
    brume_ffi::write_float_grids(&two, &[grid("smoke"), grid("soot")]).unwrap();
    let out = render(&two, &dir.join("two.exr"), &[]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("smoke") && err.contains("soot"), "{err}");
    assert!(err.contains("density"), "{err}");

    let empty = dir.join("empty.vdb");
    brume_ffi::write_float_grids(
        &empty,
        &[brume_ffi::GridSpec::fog("density", 0.1, [0.0; 3])],
    )
    .unwrap();
    let out = render(&empty, &dir.join("empty.exr"), &[]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("no active voxels") || err.contains("no positive"),
        "{err}"
    );
}
