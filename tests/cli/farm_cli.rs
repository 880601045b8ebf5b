//! Farm rendering through the `brume` command as a farm task runs it: `--samples` and
//! `--region` parts merged by `brume merge` equal one render; every bad merge input is refused
//! with a message naming the file and nothing written; a render killed with SIGKILL after its
//! first checkpoint and resumed is the uninterrupted render bit for bit; SIGTERM writes a final
//! checkpoint; the thread pool follows SLURM_CPUS_PER_TASK.
use crate::common;
use common::farm::assert_rounding_equal;

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use brume::farm::{read_part, PartInfo};
use brume::film::{write_exr_with_state, AttrValue, Film, PixelStats};

fn scene(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(format!("{name}.gltf"))
        .display()
        .to_string()
}

fn brume(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_brume"))
        .args(args)
        .env_remove("SLURM_CPUS_PER_TASK")
        .output()
        .unwrap()
}

fn ok(o: Output, what: &str) -> Output {
    assert!(
        o.status.success(),
        "{what}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

const SIZE: [&str; 6] = ["--width", "40", "--height", "24", "--backend", "cpu"];

fn render(scene_name: &str, out: &Path, extra: &[&str]) -> Output {
    let sc = scene(scene_name);
    let mut args = vec!["render", sc.as_str(), "-o", out.to_str().unwrap()];
    args.extend(SIZE);
    args.extend(extra);
    brume(&args)
}

#[test]
fn parts_and_regions_merged_by_the_cli_equal_one_render() {
    let d = common::scratch::dir("split");
    let single = d.join("single.exr");
    ok(render("cloud", &single, &["--spp", "12"]), "single");
    let mut parts = Vec::new();
    for (k, (range, region)) in [
        ("0..1", None),
        ("1..5", None),
        ("5..12", Some("0,0,40,10")),
        ("5..12", Some("0,10,40,24")),
    ]
    .into_iter()
    .enumerate()
    {
        let p = d.join(format!("part-{k}.exr"));
        let mut extra = vec!["--samples", range];
        if let Some(r) = region {
            extra.extend(["--region", r]);
        }
        ok(render("cloud", &p, &extra), range);
        parts.push(p.to_str().unwrap().to_string());
    }
    let merged = d.join("merged.exr");
    let mut args = vec!["merge"];
    args.extend(parts.iter().rev().map(String::as_str));
    args.extend(["-o", merged.to_str().unwrap(), "--spp", "12"]);
    let o = ok(brume(&args), "merge");
    println!("{}", String::from_utf8_lossy(&o.stdout).trim());
    let (m, s) = (read_part(&merged).unwrap(), read_part(&single).unwrap());
    assert_rounding_equal(&m.film, &s.film, "cli split");
    let parts_seconds: f64 = parts
        .iter()
        .map(|p| read_part(Path::new(p)).unwrap().info.seconds)
        .sum();
    // The parts' sum (in another order: seconds need no bit-exact sum).
    assert!(
        (m.info.seconds - parts_seconds).abs() <= 1e-12 * parts_seconds,
        "total time {} is not the parts' sum {parts_seconds}",
        m.info.seconds
    );
    assert_eq!(m.info.parts, 4);
    assert_eq!(
        m.metadata.text("brume:coverage"),
        Some("0..5@0,0,40,24;5..12@0,0,40,10;5..12@0,10,40,24")
    );
    assert_eq!(m.info.scene_hash, s.info.scene_hash);
}

/// Runs `brume merge PARTS -o out` expecting a refusal that names `culprit` and says `why`;
/// checks nothing was written.
fn refused(d: &Path, parts: &[&Path], culprit: &Path, why: &str) {
    let out = d.join("never.exr");
    let mut args = vec!["merge".to_string()];
    args.extend(parts.iter().map(|p| p.display().to_string()));
    args.extend(["-o".into(), out.display().to_string()]);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let o = brume(&args);
    common::cli::assert_refused(&o, culprit, why, why);
    assert!(!out.exists(), "{why}: an output was written");
    assert!(
        common::cli::temporaries(d).is_empty(),
        "{why}: a temporary file was left"
    );
}

#[test]
fn merge_refuses_parts_of_other_images_overlaps_truncated_and_nan_parts() {
    let d = common::scratch::dir("refuse");
    let part = |name: &str, scene_name: &str, extra: &[&str]| {
        let p = d.join(name);
        ok(render(scene_name, &p, extra), name);
        p
    };
    let a = part("a.exr", "cloud", &["--samples", "0..4"]);
    let b = part("b.exr", "cloud", &["--samples", "4..8"]);
    let other_scene = part("scene.exr", "cornell_smoke", &["--samples", "4..8"]);
    let other_settings = part(
        "settings.exr",
        "cloud",
        &["--samples", "4..8", "--estimator", "weighted-delta"],
    );
    let other_seed = part("seed.exr", "cloud", &["--samples", "4..8", "--seed", "3"]);
    let other_size = d.join("size.exr");
    ok(
        brume(&[
            "render",
            &scene("cloud"),
            "-o",
            other_size.to_str().unwrap(),
            "--width",
            "40",
            "--height",
            "20",
            "--backend",
            "cpu",
            "--samples",
            "4..8",
        ]),
        "size",
    );
    let overlap = part("overlap.exr", "cloud", &["--samples", "2..6"]);
    // The sanity case: a and b merge.
    ok(
        brume(&[
            "merge",
            a.to_str().unwrap(),
            b.to_str().unwrap(),
            "-o",
            d.join("ab.exr").to_str().unwrap(),
        ]),
        "a + b",
    );
    std::fs::remove_file(d.join("ab.exr")).unwrap();

    refused(&d, &[&a, &other_scene], &other_scene, "not the same scene");
    refused(
        &d,
        &[&a, &other_settings],
        &other_settings,
        "not the same settings",
    );
    refused(&d, &[&a, &other_seed], &other_seed, "not the same seed");
    refused(&d, &[&a, &other_size], &other_size, "not the same size");
    refused(&d, &[&a, &b, &overlap], &overlap, "overlaps");

    // Another Brume version: the same part with its header changed.
    let version = d.join("version.exr");
    let p = read_part(&b).unwrap();
    let mut meta = p.metadata.clone();
    meta.set("brume:version", AttrValue::Text("0.0.1-other".into()));
    write_exr_with_state(&version, &p.film, &meta).unwrap();
    refused(&d, &[&a, &version], &version, "not the same Brume version");

    // A part cut short (a copy interrupted mid-transfer).
    let truncated = d.join("truncated.exr");
    let bytes = std::fs::read(&b).unwrap();
    std::fs::write(&truncated, &bytes[..bytes.len() * 3 / 5]).unwrap();
    refused(&d, &[&a, &truncated], &truncated, "OpenEXR");

    // A part with a NaN pixel (a renderer bug elsewhere must not poison the merge).
    let nan = d.join("nan.exr");
    let mut pixels: Vec<PixelStats> = p.film.pixels().to_vec();
    pixels[7].mean[1] = f64::NAN;
    let film = Film::from_pixels(p.film.width(), p.film.height(), pixels).unwrap();
    write_exr_with_state(&nan, &film, &p.metadata).unwrap();
    refused(&d, &[&a, &nan], &nan, "not finite");

    // Missing samples: --spp asks for the whole image.
    let o = brume(&[
        "merge",
        a.to_str().unwrap(),
        "-o",
        d.join("incomplete.exr").to_str().unwrap(),
        "--spp",
        "8",
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("incomplete"));
    assert!(!d.join("incomplete.exr").exists());
}

fn wait_for(path: &Path, limit: Duration) {
    let t = Instant::now();
    while !path.exists() {
        assert!(t.elapsed() < limit, "{} never appeared", path.display());
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn spawn_render(out: &Path, extra: &[&str]) -> std::process::Child {
    let sc = scene("cloud");
    let mut args = vec!["render", sc.as_str(), "-o", out.to_str().unwrap()];
    args.extend(["--width", "48", "--height", "32", "--backend", "cpu"]);
    args.extend(extra);
    Command::new(env!("CARGO_BIN_EXE_brume"))
        .args(&args)
        .env_remove("SLURM_CPUS_PER_TASK")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

#[test]
fn a_render_killed_after_its_first_checkpoint_resumes_to_the_uninterrupted_image() {
    let d = common::scratch::dir("resume");
    let spp = "1024";
    let uninterrupted = d.join("uninterrupted.exr");
    ok(
        spawn_render(&uninterrupted, &["--spp", spp])
            .wait_with_output()
            .unwrap(),
        "uninterrupted",
    );
    let part = d.join("part.exr");
    let child = spawn_render(&part, &["--spp", spp, "--checkpoint", "0.2"]);
    wait_for(&part, Duration::from_secs(120));
    // SIGKILL: no handler runs; only the checkpoint on disk survives.
    let status = Command::new("kill")
        .args(["-KILL", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let o = child.wait_with_output().unwrap();
    assert!(!o.status.success(), "the render was not killed");
    let ckpt = read_part(&part).unwrap();
    let reached = ckpt.info.coverage[0].end;
    println!("killed after a checkpoint at sample {reached} of {spp}");
    assert!(reached < 1024, "the render finished before the kill");
    assert_eq!(ckpt.info.target, Some((0, 1024)));
    let o = ok(
        spawn_render(&part, &["--spp", spp, "--resume", part.to_str().unwrap()])
            .wait_with_output()
            .unwrap(),
        "resume",
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains(&format!("rendering {reached}..1024")), "{err}");
    let (a, b) = (
        read_part(&part).unwrap(),
        read_part(&uninterrupted).unwrap(),
    );
    assert!(a.film == b.film, "resumed != uninterrupted (bit for bit)");
    assert_eq!(a.info.coverage, b.info.coverage);
    assert!(a.info.seconds > ckpt.info.seconds);
    // A resume must be of the same render.
    let o = spawn_render(
        &d.join("x.exr"),
        &[
            "--spp",
            spp,
            "--seed",
            "9",
            "--resume",
            part.to_str().unwrap(),
        ],
    )
    .wait_with_output()
    .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("not the same seed"));
}

#[test]
fn sigterm_writes_a_final_checkpoint_before_exiting() {
    let d = common::scratch::dir("sigterm");
    let part = d.join("part.exr");
    // No periodic checkpoint within the test: what is on disk comes from the SIGTERM.
    let child = spawn_render(
        &part,
        &["--samples", "3..1000000", "--checkpoint", "100000"],
    );
    std::thread::sleep(Duration::from_millis(1500));
    assert!(!part.exists());
    let status = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let p = read_part(&part).unwrap();
    let c = p.info.coverage[0];
    println!(
        "SIGTERM: wrote samples {}..{} of 3..1000000",
        c.start, c.end
    );
    assert_eq!(c.start, 3);
    assert!(c.end > 3 && c.end < 1_000_000);
    assert_eq!(p.metadata.text("brume:interrupted"), Some("true"));
    assert_eq!(p.info.target, Some((3, 1_000_000)));
}

#[test]
fn the_thread_pool_follows_slurm_cpus_per_task_or_the_flag() {
    let d = common::scratch::dir("threads");
    let out = d.join("t.exr");
    let sc = scene("cloud");
    let base = [
        "render",
        sc.as_str(),
        "-o",
        out.to_str().unwrap(),
        "--width",
        "8",
        "--height",
        "8",
        "--spp",
        "1",
        "--backend",
        "cpu",
    ];
    let run = |env: Option<&str>, extra: &[&str]| {
        let mut c = Command::new(env!("CARGO_BIN_EXE_brume"));
        c.args(base).args(extra).env_remove("SLURM_CPUS_PER_TASK");
        if let Some(v) = env {
            c.env("SLURM_CPUS_PER_TASK", v);
        }
        let o = ok(c.output().unwrap(), "threads");
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    assert!(run(Some("3"), &[]).contains("threads: 3 (from SLURM_CPUS_PER_TASK)"));
    assert!(run(Some("3"), &["--threads", "2"]).contains("threads: 2 (from --threads)"));
    let all = std::thread::available_parallelism().unwrap().get();
    assert!(run(None, &[]).contains(&format!("threads: {all} (from all cores)")));
    let p = read_part(&out).unwrap();
    let _: &PartInfo = &p.info;
}

#[test]
fn the_farm_scripts_run_without_slurm_and_a_rerun_task_resumes_its_part() {
    // `brume farm slurm` without --submit writes the scripts; here they run as Slurm would run
    // them (SLURM_ARRAY_TASK_ID, SLURM_CPUS_PER_TASK), one after the other.
    let d = common::scratch::dir("scripts");
    let final_exr = d.join("final.exr");
    let work = d.join("work");
    let o = ok(
        brume(&[
            "farm",
            "slurm",
            &scene("cloud"),
            "-o",
            final_exr.to_str().unwrap(),
            "--spp",
            "10",
            "--tasks",
            "3",
            "--cpus-per-task",
            "2",
            "--checkpoint",
            "60",
            "--dir",
            work.to_str().unwrap(),
            "--",
            "--width",
            "40",
            "--height",
            "24",
        ]),
        "farm slurm",
    );
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("--dependency=afterok:$A --kill-on-invalid-dep=yes"),
        "{out}"
    );
    let script = std::fs::read_to_string(work.join("render.sbatch")).unwrap();
    for needle in [
        "#SBATCH --array=0-2",
        "#SBATCH --cpus-per-task=2",
        "#SBATCH --requeue",
        "RANGES=(0..3 3..6 6..10)",
        "--checkpoint 60",
    ] {
        assert!(script.contains(needle), "{needle}:\n{script}");
    }
    let task = |i: u32| {
        let o = Command::new("bash")
            .arg(work.join("render.sbatch"))
            .env("SLURM_ARRAY_TASK_ID", i.to_string())
            .env("SLURM_CPUS_PER_TASK", "2")
            .output()
            .unwrap();
        ok(o, &format!("task {i}"))
    };
    for i in 0..3 {
        let err = String::from_utf8_lossy(&task(i).stderr).into_owned();
        assert!(
            err.contains("threads: 2 (from SLURM_CPUS_PER_TASK)"),
            "{err}"
        );
    }
    // A requeued task finds its part and resumes it (here: already complete, nothing to do).
    let err = String::from_utf8_lossy(&task(1).stderr).into_owned();
    assert!(
        err.contains("resume:") && err.contains("rendering 6..6"),
        "{err}"
    );
    ok(
        Command::new("bash")
            .arg(work.join("merge.sbatch"))
            .output()
            .unwrap(),
        "merge",
    );
    let single = d.join("single.exr");
    ok(render("cloud", &single, &["--spp", "10"]), "single");
    let (m, s) = (read_part(&final_exr).unwrap(), read_part(&single).unwrap());
    assert_rounding_equal(&m.film, &s.film, "farm scripts");
    assert_eq!(m.info.parts, 3);
}

#[test]
fn cpu_only_part_options_are_refused_on_the_gpu_backend_and_empty_ranges_on_the_cli() {
    let d = common::scratch::dir("gpu-refuse");
    let out = d.join("x.exr");
    for extra in [
        ["--checkpoint", "5"],
        ["--region", "0,0,8,8"],
        ["--resume", "nowhere.exr"],
        ["--noise-threshold", "0.05"],
    ] {
        let sc = scene("cloud");
        let mut args = vec!["render", "--backend", "gpu"];
        args.extend([sc.as_str(), "-o", out.to_str().unwrap(), "--spp", "1"]);
        args.extend(extra);
        let o = brume(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{extra:?}");
        assert!(err.contains("CPU backend only"), "{extra:?}: {err}");
    }
    let o = render("cloud", &out, &["--samples", "4..4"]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("is empty"));
    assert!(!out.exists());
    // Farm tasks split the samples: adaptive sampling cannot be split so.
    let sc = scene("cloud");
    let o = brume(&[
        "farm",
        "slurm",
        &sc,
        "-o",
        out.to_str().unwrap(),
        "--spp",
        "64",
        "--tasks",
        "4",
        "--",
        "--noise-threshold",
        "0.05",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("--tasks 1"), "{err}");
}

#[test]
fn the_farm_scripts_of_a_sequence_merge_each_frame_to_its_single_render() {
    // Frames 1..2 of a sequence, 2 tasks each: task i renders samples of frame 1 + i / 2.
    let d = common::scratch::dir("sequence_scripts");
    let seq = common::sequence::cloud_sequence(&d, [1, 2]);
    let work = d.join("work");
    let merged = d.join("final_####.exr");
    let mut args = vec!["farm", "slurm", seq.to_str().unwrap(), "-o"];
    args.extend([merged.to_str().unwrap(), "--spp", "6", "--tasks", "2"]);
    args.extend(["--frames", "1..2", "--dir", work.to_str().unwrap()]);
    args.extend(["--", "--width", "40", "--height", "24"]);
    let o = ok(brume(&args), "farm slurm --frames");
    assert!(String::from_utf8_lossy(&o.stdout).contains("(4 tasks"));
    let script = std::fs::read_to_string(work.join("render.sbatch")).unwrap();
    for needle in ["#SBATCH --array=0-3", "FRAMES=(1 2)", "--frame \"$f\""] {
        assert!(script.contains(needle), "{needle}:\n{script}");
    }
    for i in 0..4 {
        let o = Command::new("bash")
            .arg(work.join("render.sbatch"))
            .env("SLURM_ARRAY_TASK_ID", i.to_string())
            .env("SLURM_CPUS_PER_TASK", "1")
            .output()
            .unwrap();
        ok(o, &format!("task {i}"));
    }
    let merge = Command::new("bash")
        .arg(work.join("merge.sbatch"))
        .output()
        .unwrap();
    ok(merge, "merge");
    for f in [1, 2] {
        let single = d.join(format!("single_{f}.exr"));
        let mut args = vec![
            "render",
            seq.to_str().unwrap(),
            "-o",
            single.to_str().unwrap(),
        ];
        args.extend(["--spp", "6", "--frame", if f == 1 { "1" } else { "2" }]);
        args.extend(SIZE);
        ok(brume(&args), "single");
        let m = read_part(&d.join(format!("final_{f:04}.exr"))).unwrap();
        let s = read_part(&single).unwrap();
        assert_rounding_equal(&m.film, &s.film, &format!("frame {f}"));
        assert_eq!(m.info.parts, 2);
    }
    // Several frames into one file name would overwrite each other.
    let one = d.join("one.exr");
    let mut args = vec!["farm", "slurm", seq.to_str().unwrap(), "-o"];
    args.extend([one.to_str().unwrap(), "--spp", "6", "--tasks", "2"]);
    args.extend(["--frames", "1..2", "--dir", work.to_str().unwrap()]);
    let o = brume(&args);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("run of #"));
}
