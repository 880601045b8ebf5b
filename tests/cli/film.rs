//! The transparent film end to end: `--film transparent` and `BRUME_render.filmTransparent`
//! write the coverage as alpha, and `oiiotool --over` lays the render over a plate as the
//! opaque render with that plate as its sky.
use std::path::Path;
use std::process::Command;

use crate::common::boxes::boxes_scene;
use crate::common::cli::render_to;
use crate::common::scratch;
use brume::film::read_exr;

const FIXED: [&str; 6] = ["--width", "16", "--height", "16", "--spp", "256"];

fn run(cmd: &mut Command) {
    let o = cmd.output().unwrap();
    assert!(
        o.status.success(),
        "{cmd:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// A grey box of medium under a white sky (strength 1), filling about half of the view.
fn scene(d: &Path) -> std::path::PathBuf {
    boxes_scene(
        d,
        &[([-0.6, -0.6, -0.5], [0.6, 0.6, 0.5], 2.0, 0.8)],
        false,
        0.6,
    )
}

#[test]
fn a_transparent_render_over_a_plate_is_the_opaque_render_with_that_sky() {
    if Command::new("oiiotool").arg("--version").output().is_err() {
        println!("SKIPPED: oiiotool is not on PATH (apt-get install openimageio-tools)");
        return;
    }
    let d = scratch::dir("film_over");
    let gltf = scene(&d);
    let (t, o) = (d.join("transparent.exr"), d.join("opaque.exr"));
    let out = render_to(&gltf, &t, &FIXED, &["--film", "transparent", "--seed", "1"]);
    assert!(out.status.success(), "{out:?}");
    let out = render_to(&gltf, &o, &FIXED, &["--seed", "2"]);
    assert!(out.status.success(), "{out:?}");
    let (plate, comp) = (d.join("plate.exr"), d.join("over.exr"));
    run(Command::new("oiiotool")
        .args([
            "--pattern",
            "constant:color=1,1,1,1",
            "16x16",
            "4",
            "-d",
            "float",
            "-o",
        ])
        .arg(&plate));
    run(Command::new("oiiotool")
        .arg(&t)
        .args(["--ch", "R,G,B,A"])
        .arg(&plate)
        .args(["--over", "-o"])
        .arg(&comp));
    let (t, o, comp) = (
        read_exr(&t).unwrap(),
        read_exr(&o).unwrap(),
        read_exr(&comp).unwrap(),
    );
    assert!(
        o.alpha.as_ref().unwrap().iter().all(|&a| a == 1.0),
        "an opaque film's alpha is 1"
    );
    let alpha = t.alpha.as_ref().unwrap();
    let (t_var, o_var) = (t.variance.as_ref().unwrap(), o.variance.as_ref().unwrap());
    let n = alpha.len();
    let threshold = crate::common::render::sidak_z(1e-3, 3 * n);
    let (mut failing, mut worst) = (0, 0f64);
    for i in 0..n {
        let a = alpha[i] as f64;
        // Alpha samples lie in [0, 1]: the variance of their mean is at most a (1 - a) / n.
        let sd_alpha = (a * (1.0 - a) / 256.0).sqrt();
        for c in 0..3 {
            let sd = (t_var[i][c] as f64).sqrt() + sd_alpha;
            let v = sd * sd + o_var[i][c] as f64;
            let z = (comp.rgb[i][c] as f64 - o.rgb[i][c] as f64).abs() / v.sqrt();
            worst = worst.max(z);
            failing += (z > threshold) as usize;
        }
    }
    let covered = alpha.iter().filter(|&&a| a > 0.05).count();
    println!(
        "oiiotool --over a white plate: {covered} of {n} pixels covered; {failing} of {} values \
         differ from the opaque render (worst z {worst:.2}, threshold {threshold:.2})",
        3 * n
    );
    assert!(covered > n / 4 && covered < n, "{covered} pixels covered");
    assert_eq!(failing, 0);
}

#[test]
fn the_scene_asks_for_a_transparent_film_and_the_command_line_overrides_it() {
    let d = scratch::dir("film_scene");
    let gltf = scene(&d);
    let mut doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&gltf).unwrap()).unwrap();
    doc["extensions"]["BRUME_render"] = serde_json::json!({"filmTransparent": true});
    doc["extensionsUsed"]
        .as_array_mut()
        .unwrap()
        .push("BRUME_render".into());
    let asks = d.join("transparent.gltf");
    std::fs::write(&asks, doc.to_string()).unwrap();
    let alpha_min = |extra: &[&str], name: &str| {
        let out = d.join(name);
        let o = render_to(
            &asks,
            &out,
            &["--width", "8", "--height", "8", "--spp", "4"],
            extra,
        );
        assert!(o.status.success(), "{o:?}");
        let image = read_exr(&out).unwrap();
        image.alpha.unwrap().into_iter().fold(1.0f32, f32::min)
    };
    let (scene_film, opaque) = (
        alpha_min(&[], "a.exr"),
        alpha_min(&["--film", "opaque"], "b.exr"),
    );
    println!("filmTransparent: least alpha {scene_film}; with --film opaque {opaque}");
    assert!(scene_film < 0.5);
    assert_eq!(opaque, 1.0);
}

#[test]
fn passes_are_layers_of_the_exr_on_both_backends_and_what_is_not_there_is_refused() {
    let d = scratch::dir("film_passes");
    let gltf = scene(&d);
    let out = d.join("passes.exr");
    let small = ["--width", "8", "--height", "8", "--spp", "4"];
    let o = render_to(&gltf, &out, &small, &["--passes", "beauty,light"]);
    assert!(o.status.success(), "{o:?}");
    let image = read_exr(&out).unwrap();
    assert_eq!(
        image.attributes.text("brume:passes"),
        Some("emission background volume.direct volume.indirect surface.direct surface.indirect")
    );
    let o = render_to(&gltf, &out, &small, &["--passes", "data"]);
    assert!(o.status.success(), "{o:?}");
    let image = read_exr(&out).unwrap();
    assert_eq!(
        image.attributes.text("brume:passes"),
        Some("albedo normal depth")
    );
    // Light groups: this scene's one source is its sky.
    let o = render_to(&gltf, &out, &small, &["--passes", "lights"]);
    assert!(o.status.success(), "{o:?}");
    let image = read_exr(&out).unwrap();
    assert_eq!(image.attributes.text("brume:passes"), Some("environment"));
    let o = render_to(&gltf, &d.join("no.exr"), &small, &["--passes", "volume"]);
    let err = String::from_utf8_lossy(&o.stderr);
    println!("--passes volume: {}", err.lines().next().unwrap_or(""));
    assert!(
        !o.status.success() && err.contains("not a pass list entry"),
        "{err}"
    );
    assert!(!d.join("no.exr").exists());
    // The GPU keeps them all too where a Vulkan adapter exists (lavapipe included); where
    // none does it says so and writes nothing. The light groups come after the light passes.
    let gpu = d.join("gpu.exr");
    let light = "emission background volume.direct volume.indirect surface.direct \
                 surface.indirect";
    for (list, names) in [
        ("light,data", format!("{light} albedo normal depth")),
        ("light,lights", format!("{light} environment")),
    ] {
        let o = render_to(&gltf, &gpu, &small, &["--passes", list, "--backend", "gpu"]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!err.contains("panicked"), "{err}");
        if o.status.success() {
            let image = read_exr(&gpu).unwrap();
            assert_eq!(image.attributes.text("brume:passes"), Some(names.as_str()));
        } else {
            let reason = err.lines().find(|l| l.contains("adapter"));
            assert!(reason.is_some(), "{err}");
            assert!(!gpu.exists());
            println!("--passes {list} --backend gpu: {}", reason.unwrap_or(""));
        }
    }
}

#[test]
fn adaptive_sampling_refuses_a_sample_range_part_and_reports_what_it_saved() {
    let d = scratch::dir("film_adaptive");
    let gltf = scene(&d);
    let small = ["--width", "8", "--height", "8"];
    let o = render_to(
        &gltf,
        &d.join("part.exr"),
        &small,
        &["--noise-threshold", "0.05", "--samples", "16..64"],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    println!("--samples 16..64: {}", err.lines().last().unwrap_or(""));
    assert!(
        !o.status.success() && err.contains("split by region"),
        "{err}"
    );
    assert!(!d.join("part.exr").exists());
    let o = render_to(
        &gltf,
        &d.join("none.exr"),
        &small,
        &["--noise-threshold", "0.05", "--min-spp", "0"],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("min spp 0"), "{err}");
    assert!(!d.join("none.exr").exists());
    let o = render_to(
        &gltf,
        &d.join("a.exr"),
        &small,
        &["--noise-threshold", "0.05", "--spp", "128"],
    );
    let out = String::from_utf8_lossy(&o.stdout);
    let line = out
        .lines()
        .find(|l| l.starts_with("adaptive:"))
        .unwrap_or("");
    println!("{line}");
    assert!(
        o.status.success() && line.contains("pixels stopped before 128 spp"),
        "{out}"
    );
}
