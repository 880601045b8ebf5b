//! Outputs survive faults, through the `brume` command as a user or a farm runs it: a full
//! device (a file-size limit) fails naming the file and keeps the previous output; SIGKILL at
//! random moments of a checkpointed render, then a resume from whatever is on disk, gives the
//! uninterrupted image bit for bit; truncated and damaged checkpoints and parts are refused by
//! `--resume` and `brume merge`; an unwritable output folder is refused before the first
//! sample; two renders writing one path leave one whole image; a CPU render on a machine
//! whose only GPU is a software one prints no "error".
use crate::common;
use common::cli::{assert_refused, temporaries};

use std::os::unix::process::CommandExt;
use std::path::Path;
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use brume::farm::read_part;

fn scene(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(format!("{name}.gltf"))
        .display()
        .to_string()
}

/// `brume render cloud -o out` at a small size on the CPU, with `extra` flags.
fn render_cmd(out: &Path, extra: &[&str]) -> Command {
    render_on(out, "cpu", extra)
}

/// [`render_cmd`] on the backend `backend`.
fn render_on(out: &Path, backend: &str, extra: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_brume"));
    c.args(["render", &scene("cloud"), "-o", out.to_str().unwrap()])
        .args(["--width", "40", "--height", "24", "--backend", backend])
        .args(extra)
        .env_remove("SLURM_CPUS_PER_TASK")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    c
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn ok(o: Output, what: &str) -> Output {
    assert!(o.status.success(), "{what}: {}", stderr(&o));
    o
}

/// A file-size limit of `bytes` for the child (`ulimit -f`): writes past it fail with EFBIG,
/// as on a full device.
fn limit_file_size(c: &mut Command, bytes: u64) {
    // SAFETY: setrlimit is async-signal-safe; nothing else runs between fork and exec.
    unsafe {
        c.pre_exec(move || {
            let lim = libc::rlimit {
                rlim_cur: bytes,
                rlim_max: bytes,
            };
            if libc::setrlimit(libc::RLIMIT_FSIZE, &lim) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
}

#[test]
fn a_full_device_fails_naming_the_file_and_keeps_the_previous_output() {
    let d = common::scratch::dir("full");
    let out = d.join("out.exr");
    ok(
        render_cmd(&out, &["--spp", "4"]).output().unwrap(),
        "first render",
    );
    let before = std::fs::read(&out).unwrap();
    // The final write fails: the earlier image stays as it was, whole.
    let mut c = render_cmd(&out, &["--spp", "8", "--seed", "5"]);
    limit_file_size(&mut c, 4096);
    let o = c.output().unwrap();
    assert_refused(&o, &out, "cannot write", "final write past the limit");
    assert_eq!(
        std::fs::read(&out).unwrap(),
        before,
        "the previous output changed"
    );
    assert!(temporaries(&d).is_empty(), "{:?}", temporaries(&d));
    // A checkpoint that cannot be written stops the render at once (the rest of it would be
    // kept nowhere); the checkpoint already on disk stays whole and resumable.
    let ckpt = d.join("ckpt.exr");
    let mut child = render_cmd(&ckpt, &["--spp", "100000", "--checkpoint", "100000"])
        .spawn()
        .unwrap();
    // Once a pass is done (the signal handler is in place), SIGTERM writes a final
    // checkpoint and exits.
    let mut lines = std::io::BufRead::lines(std::io::BufReader::new(child.stderr.take().unwrap()));
    assert!(lines.any(|l| l.unwrap().starts_with("pass done")));
    // SAFETY: a plain kill(2) of our own child.
    unsafe { libc::kill(child.id() as i32, libc::SIGTERM) };
    let drain = std::thread::spawn(move || lines.for_each(drop));
    ok(child.wait_with_output().unwrap(), "checkpoint");
    drain.join().unwrap();
    let before = std::fs::read(&ckpt).unwrap();
    let mut c = render_cmd(
        &ckpt,
        &[
            "--spp",
            "100000",
            "--checkpoint",
            "0",
            "--resume",
            ckpt.to_str().unwrap(),
        ],
    );
    limit_file_size(&mut c, 4096);
    let o = c.output().unwrap();
    assert_refused(&o, &ckpt, "checkpoint", "checkpoint write past the limit");
    // The first pass's checkpoint fails; the pass in flight then ends the render.
    let passes = stderr(&o)
        .lines()
        .filter(|l| l.starts_with("pass done"))
        .count();
    assert!(
        passes <= 2,
        "the render went on after its checkpoint failed: {passes} passes"
    );
    assert_eq!(std::fs::read(&ckpt).unwrap(), before);
    read_part(&ckpt).expect("the checkpoint on disk is still whole");
    assert!(temporaries(&d).is_empty(), "{:?}", temporaries(&d));
}

/// A small deterministic generator for the kill moments (the test must not depend on a seed
/// drawn at run time).
fn lcg(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    (*state >> 11) as f64 / (1u64 << 53) as f64
}

#[test]
fn sigkill_at_random_moments_then_resume_gives_the_uninterrupted_image_bit_for_bit() {
    let d = common::scratch::dir("kill");
    // Every pass writes a checkpoint, so kills land in writes as well as between them.
    let flags = ["--spp", "1024", "--checkpoint", "0"];
    let whole = d.join("whole.exr");
    let t = Instant::now();
    ok(
        render_cmd(&whole, &flags).output().unwrap(),
        "uninterrupted",
    );
    let span = t.elapsed().as_secs_f64();
    let reference = read_part(&whole).unwrap();
    let mut rng = 0x5eed_u64;
    let (mut from_scratch, mut resumed, mut finished) = (0, 0, 0);
    for trial in 0..20 {
        let out = d.join(format!("trial{trial}.exr"));
        let at = lcg(&mut rng) * span;
        let mut child: Child = render_cmd(&out, &flags).spawn().unwrap();
        std::thread::sleep(Duration::from_secs_f64(at));
        // SIGKILL: no handler runs; only what is on disk survives.
        let _ = child.kill();
        let killed = child.wait_with_output().unwrap();
        let finished_first = killed.status.success();
        let mut extra = flags.to_vec();
        let path = out.to_str().unwrap().to_string();
        let on_disk = out.exists();
        if on_disk {
            extra.extend(["--resume", path.as_str()]);
        }
        ok(render_cmd(&out, &extra).output().unwrap(), "resume");
        let p = read_part(&out).unwrap();
        assert!(
            p.film == reference.film,
            "trial {trial} (killed at {at:.3} s, checkpoint on disk: {on_disk}): resumed != uninterrupted"
        );
        assert_eq!(p.info.coverage, reference.info.coverage);
        match (finished_first, on_disk) {
            (true, _) => finished += 1,
            (false, true) => resumed += 1,
            (false, false) => from_scratch += 1,
        }
    }
    println!(
        "20 kills over {span:.2} s: {resumed} resumed from a checkpoint, {from_scratch} before \
         the first checkpoint, {finished} after the render finished; all 20 bit for bit"
    );
    assert!(resumed >= 5, "too few kills landed mid-render: {resumed}");
}

#[test]
fn truncated_or_damaged_checkpoints_and_parts_are_refused() {
    let d = common::scratch::dir("damaged");
    let a = d.join("a.exr");
    let b = d.join("b.exr");
    ok(
        render_cmd(&a, &["--samples", "0..4"]).output().unwrap(),
        "a",
    );
    ok(
        render_cmd(&b, &["--samples", "4..8"]).output().unwrap(),
        "b",
    );
    let bytes = std::fs::read(&a).unwrap();
    let n = bytes.len();
    // The header ends where the first scan-line block's offset table begins; its Brume
    // attributes are found by name.
    let attr = |name: &str| {
        bytes
            .windows(name.len())
            .position(|w| w == name.as_bytes())
            .unwrap()
    };
    let mut cases: Vec<(String, Vec<u8>)> = Vec::new();
    for cut in [n / 10, n / 2, n * 9 / 10, n - 1] {
        cases.push((format!("cut at {cut} of {n} bytes"), bytes[..cut].to_vec()));
    }
    let mut flips: Vec<usize> = (1..10).map(|k| n * k / 10).collect();
    // In the value of the coverage and of the seconds the part took (a number nothing else
    // checks).
    flips.push(attr("brume:coverage") + "brume:coverage".len() + 1 + 7 + 4 + 2);
    flips.push(attr("brume:seconds") + "brume:seconds".len() + 1 + 7 + 4 + 5);
    for at in flips {
        let mut v = bytes.clone();
        v[at] ^= 0x10;
        cases.push((format!("byte {at} of {n} flipped"), v));
    }
    for (k, (what, content)) in cases.iter().enumerate() {
        let bad = d.join(format!("bad{k}.exr"));
        std::fs::write(&bad, content).unwrap();
        // --resume: refused before any sample; the damaged file is left as it was.
        let out = d.join(format!("resumed{k}.exr"));
        let o = render_cmd(
            &out,
            &["--samples", "0..8", "--resume", bad.to_str().unwrap()],
        )
        .output()
        .unwrap();
        assert_refused(&o, &bad, "", &format!("--resume, {what}"));
        assert!(!out.exists(), "{what}: --resume wrote an output");
        assert_eq!(&std::fs::read(&bad).unwrap(), content);
        // merge: refused, nothing written.
        let merged = d.join(format!("merged{k}.exr"));
        let o = Command::new(env!("CARGO_BIN_EXE_brume"))
            .args(["merge", bad.to_str().unwrap(), b.to_str().unwrap()])
            .args(["-o", merged.to_str().unwrap()])
            .output()
            .unwrap();
        assert_refused(&o, &bad, "", &format!("merge, {what}"));
        assert!(!merged.exists(), "{what}: merge wrote an output");
    }
    assert!(temporaries(&d).is_empty(), "{:?}", temporaries(&d));
    // The undamaged pair still merges.
    ok(
        Command::new(env!("CARGO_BIN_EXE_brume"))
            .args(["merge", a.to_str().unwrap(), b.to_str().unwrap()])
            .args(["-o", d.join("ab.exr").to_str().unwrap()])
            .output()
            .unwrap(),
        "a + b",
    );
}

/// Runs `c` so that folder permissions bind it even as root: the child drops
/// CAP_DAC_OVERRIDE and CAP_DAC_READ_SEARCH from its bounding set before exec (root keeps
/// every other power, and still owns the files it reads).
fn without_dac_override(c: &mut Command) {
    // SAFETY: prctl is async-signal-safe; nothing else runs between fork and exec.
    unsafe {
        c.pre_exec(|| {
            if libc::geteuid() == 0 {
                for cap in [1, 2] {
                    if libc::prctl(libc::PR_CAPBSET_DROP, cap, 0, 0, 0) != 0 {
                        return Err(std::io::Error::last_os_error());
                    }
                }
            }
            Ok(())
        });
    }
}

#[test]
fn an_unwritable_output_folder_is_refused_before_the_first_sample() {
    use std::os::unix::fs::PermissionsExt;
    let d = common::scratch::dir("readonly");
    let ro = d.join("ro");
    std::fs::create_dir(&ro).unwrap();
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o555)).unwrap();
    let mut probe = Command::new("sh");
    probe
        .args(["-c", &format!("touch {}/probe", ro.display())])
        .stderr(Stdio::null());
    without_dac_override(&mut probe);
    let probe = probe.status();
    if !matches!(probe, Ok(s) if !s.success()) {
        println!("SKIPPED: the test process can write into a mode-555 folder even without CAP_DAC_OVERRIDE");
        return;
    }
    for (what, flags) in [
        ("the image", vec![]),
        ("the tile log", vec!["--tile-log"]),
        ("the cost map", vec!["--cost-map"]),
    ] {
        let image = if flags.is_empty() {
            ro.join("out.exr")
        } else {
            d.join("out.exr")
        };
        let target = ro.join("log");
        let mut args = vec!["--spp", "100000"];
        let t = target.to_str().unwrap().to_string();
        if let Some(f) = flags.first() {
            args.extend([*f, t.as_str()]);
        }
        let mut c = render_cmd(&image, &args);
        without_dac_override(&mut c);
        let o = c.output().unwrap();
        let culprit = if flags.is_empty() { &image } else { &target };
        assert_refused(&o, culprit, "cannot be written", what);
        let err = stderr(&o);
        assert!(
            !err.contains("pass done") && !err.contains("threads:"),
            "{what}: refused only after starting the render: {err}"
        );
        assert!(!d.join("out.exr").exists());
    }
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o755)).unwrap();
}

#[test]
fn two_renders_writing_one_path_leave_one_whole_image() {
    let d = common::scratch::dir("race");
    let flags = |seed: &'static str| ["--spp", "48", "--checkpoint", "0", "--seed", seed];
    let (sa, sb) = (d.join("seed1.exr"), d.join("seed2.exr"));
    ok(render_cmd(&sa, &flags("1")).output().unwrap(), "seed 1");
    ok(render_cmd(&sb, &flags("2")).output().unwrap(), "seed 2");
    let (ra, rb) = (read_part(&sa).unwrap(), read_part(&sb).unwrap());
    let shared = d.join("shared.exr");
    let mut winners = [0; 2];
    for round in 0..5 {
        // Both write a checkpoint after every pass, then the final image, to the same path.
        let a = render_cmd(&shared, &flags("1")).spawn().unwrap();
        let b = render_cmd(&shared, &flags("2")).spawn().unwrap();
        ok(a.wait_with_output().unwrap(), "render 1");
        ok(b.wait_with_output().unwrap(), "render 2");
        let p = read_part(&shared)
            .unwrap_or_else(|e| panic!("round {round}: the file on disk is not whole: {e}"));
        if p.film == ra.film {
            winners[0] += 1;
        } else if p.film == rb.film {
            winners[1] += 1;
        } else {
            panic!("round {round}: the image on disk is neither render's");
        }
        assert!(temporaries(&d).is_empty(), "{:?}", temporaries(&d));
    }
    println!("5 rounds of two renders on one path: the last writer was seed 1 {} times, seed 2 {} times; every file whole", winners[0], winners[1]);
}

#[test]
fn a_cpu_render_beside_a_software_gpu_prints_no_error() {
    let d = common::scratch::dir("console");
    let out = d.join("out.exr");
    let o = render_on(&out, "auto", &["--spp", "2"])
        .env_remove("XDG_RUNTIME_DIR")
        .env_remove("NODEVICE_SELECT")
        .output()
        .unwrap();
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    let backend: Vec<&str> = err.lines().filter(|l| l.starts_with("backend:")).collect();
    println!("{}", backend.join("\n"));
    assert_eq!(backend.len(), 1, "{err}");
    assert!(
        !err.to_lowercase().contains("error"),
        "a successful render said error: {err}"
    );
}
