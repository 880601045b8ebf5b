//! Seeded random-input tests ("fuzzing") of the two parsers that read files from users:
//!
//! 1. the VDB loader through the OpenVDB shim (`VdbFile::open` + `volume::load_grid_from`):
//!    bytes of the valid files in `tests/fuzz/vdb/` are mutated (bit flips, interesting
//!    integers, truncations, splices of two files, random insertions and deletions);
//! 2. the glTF `BRUME_medium_vdb` parser (`scene::load`): the extension objects of the scenes
//!    in `tests/fuzz/gltf/` are mutated structurally (wrong types, out-of-range, huge and tiny
//!    numbers, NaN-like strings, missing and unknown fields, odd URIs) and sometimes as text.
//!
//! 3. the environment-map loader (`scene::envmap::read_environment_image`): bytes of the `.exr`
//!    and `.hdr` maps in `tests/fuzz/envmap/` mutated as the VDB files are.
//!
//! Property: no panic, abort, crash or hang; every input gives either a clear error (non-empty,
//! naming the file) or a valid result (grid bounds validate, values finite and non-negative;
//! an accepted scene validates, its medium parameters are in range and a tiny render of it is
//! finite).
//!
//! Inputs run in a child process (this test binary re-run as a worker, under `ulimit -v` so a
//! corrupt size field meets `bad_alloc` rather than the OOM killer): a crash or hang then fails
//! the test with the iteration that caused it instead of killing the harness. Iteration `i` of a
//! campaign with seed `s` is generated from `(s, i)` alone, so the parent re-creates the input of
//! a crashed child and saves it. Iterations first replay every corpus file unmutated, so inputs
//! that once failed are kept as regression inputs by committing them to the corpus.
//!
//! OpenVDB's own reader runs in a process of its own (`VdbFile::open`): a file that crashes it
//! (tests/fuzz/vdb-regressions) is a clear error, so it counts as refused, never as a crash.
//!
//! The inputs are made in `mutate.rs`, the properties checked in `check.rs`; this file runs the
//! campaigns and their workers.
//!
//! CI runs a fixed number of iterations (about 20 s in all). The long mode is
//! `BRUME_FUZZ_SECONDS=600 cargo test --release --test files fuzz_inputs:: -- --ignored --nocapture long`.
use crate::common::scratch;

mod check;
mod mutate;

use std::io::Write;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::{json, Value};

use check::{check_envmap, check_gltf, check_vdb, Verdict};
use mutate::input;

/// Iterations per campaign in CI (each well under a minute on two cores; OpenVDB reads each
/// file in a process of its own).
const CI_VDB_ITERATIONS: u64 = 160;
const CI_GLTF_ITERATIONS: u64 = 1000;
const CI_ENVMAP_ITERATIONS: u64 = 1000;
/// A child that reports no progress for this long is hung.
const HANG_SECONDS: u64 = 30;
/// Address-space limit of the worker, KiB: corrupt sizes then fail to allocate quickly.
const WORKER_VMEM_KIB: u64 = 2 << 20;

/// Inputs per worker process. OpenVDB's reader runs in a child process of its own
/// (`VdbFile::open`), so one worker serves many inputs of either kind.
const BATCH: u64 = 100_000;

/// Where a VDB worker is, written to `state/stage` so that the parent can say where a dead
/// worker died.
fn set_stage(stage: &str) {
    if let Ok(dir) = std::env::var("BRUME_FUZZ_STATE") {
        std::fs::write(Path::new(&dir).join("stage"), stage).unwrap();
    }
}

/// The stage in which OpenVDB 10's own stream reader (`io::Stream`) parses the file. It trusts
/// chunk sizes in the file: `bloscFromStream` reads a corrupt length into a buffer sized from
/// the node masks before checking it (a heap overflow found by this test, confirmed with
/// valgrind). `VdbFile::open` therefore parses in a child process and reports a crash there as
/// an error; a worker that still dies here is a Brume failure like any other.
const STAGE_OPENVDB_READER: &str = "openvdb-reader";

fn fuzz_dir(kind: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fuzz")
        .join(kind)
}

/// The extensions of campaign `kind`'s corpus files.
fn corpus_extensions(kind: &str) -> &'static [&'static str] {
    match kind {
        "vdb" => &["vdb"],
        "envmap" => &["exr", "hdr"],
        _ => &["gltf"],
    }
}

/// The file an input of `kind` is written to: an environment map keeps the extension its
/// bytes claim (Radiance files start with `#?`), so both decoders see mutated inputs.
fn input_name(kind: &str, bytes: &[u8]) -> &'static str {
    match kind {
        "vdb" => "input.vdb",
        "envmap" if bytes.starts_with(b"#?") => "input.hdr",
        "envmap" => "input.exr",
        _ => "input.gltf",
    }
}

/// The corpus files of `kind` ("vdb", "gltf" or "envmap"), sorted by name.
fn corpus(kind: &str) -> Vec<(String, Vec<u8>)> {
    let exts = corpus_extensions(kind);
    let mut files: Vec<_> = std::fs::read_dir(fuzz_dir(kind))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| exts.iter().any(|e| x == *e)))
        .map(|p| {
            (
                p.file_name().unwrap().to_string_lossy().into_owned(),
                std::fs::read(&p).unwrap(),
            )
        })
        .collect();
    files.sort();
    assert!(!files.is_empty(), "empty corpus for {kind}");
    files
}

// ---------------------------------------------------------------------------------------------
// Worker (child process) and campaign (parent)

/// The worker: runs iterations `from..` of one campaign until `count` are done or the deadline
/// passes, writing the current iteration to `state/progress` before each one.
#[test]
#[ignore = "run by the fuzz campaigns as a child process"]
fn fuzz_worker() {
    let Ok(kind) = std::env::var("BRUME_FUZZ_WORKER") else {
        return;
    };
    let var = |k: &str| std::env::var(k).unwrap();
    let seed: u64 = var("BRUME_FUZZ_SEED").parse().unwrap();
    let from: u64 = var("BRUME_FUZZ_FROM").parse().unwrap();
    let count: u64 = var("BRUME_FUZZ_COUNT").parse().unwrap();
    let deadline: f64 = var("BRUME_FUZZ_DEADLINE").parse().unwrap();
    let state = PathBuf::from(var("BRUME_FUZZ_STATE"));
    let corpus = corpus(&kind);
    if kind == "gltf" {
        // The scenes' URIs are relative: the grids they name sit next to the input.
        for e in std::fs::read_dir(fuzz_dir("gltf")).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x == "vdb") {
                std::fs::copy(&p, state.join(p.file_name().unwrap())).unwrap();
            }
        }
    }
    // Panics are caught and reported per input; keep the default hook quiet.
    std::panic::set_hook(Box::new(|_| {}));
    let start = Instant::now();
    let (mut accepted, mut refused, mut done, mut reader_crashed) = (0u64, 0u64, 0u64, 0u64);
    let mut rss_warm = None;
    for i in from..from + count {
        if start.elapsed().as_secs_f64() > deadline {
            break;
        }
        std::fs::write(state.join("progress"), i.to_string()).unwrap();
        let bytes = input(&kind, &corpus, seed, i);
        let path = state.join(input_name(&kind, &bytes));
        std::fs::write(&path, &bytes).unwrap();
        let verdict = catch_unwind(AssertUnwindSafe(|| match kind.as_str() {
            "vdb" => check_vdb(&path),
            "envmap" => check_envmap(&path),
            _ => check_gltf(&path),
        }));
        match verdict {
            Ok(Ok(Verdict::Accepted)) => accepted += 1,
            Ok(Ok(Verdict::Refused)) => refused += 1,
            Ok(Ok(Verdict::ReaderCrashed)) => {
                refused += 1;
                reader_crashed += 1;
            }
            Ok(Err(msg)) => println!("FAIL {i} {msg}"),
            Err(p) => {
                let msg = p
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default();
                println!("FAIL {i} panic: {msg}");
            }
        }
        done += 1;
        if done == RSS_WARMUP {
            rss_warm = resident_kib();
        }
    }
    if let (Some(a), Some(b)) = (rss_warm, resident_kib()) {
        println!("RSS {a} {b}");
    }
    println!("DONE {done} {accepted} {refused} {reader_crashed}");
    std::io::stdout().flush().unwrap();
}

/// Inputs after which a worker's resident size is taken as its baseline for the leak check.
const RSS_WARMUP: u64 = 200;
/// Largest growth of a worker's resident size after the warm-up that is not called a leak, KiB.
const RSS_GROWTH_LIMIT_KIB: i64 = 64 << 10;

/// This process's resident set size, KiB (`VmRSS` in /proc/self/status).
fn resident_kib() -> Option<i64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmRSS:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

#[derive(Debug, Default)]
struct Campaign {
    iterations: u64,
    accepted: u64,
    refused: u64,
    /// Of the refused: OpenVDB's reader crashed or hung, contained in its own process.
    reader_crashed: u64,
    /// Property violations and panics: (iteration, message).
    failures: Vec<(u64, String)>,
    /// Worker processes that died (signal, abort) or hung: (iteration, what).
    crashes: Vec<(u64, String)>,
    /// Largest growth of a worker's resident size after its warm-up, KiB (a leak shows here:
    /// the long runs feed one worker tens of thousands of inputs).
    /// `None` when no worker got past the warm-up.
    rss_growth_kib: Option<i64>,
    seconds: f64,
}

/// Runs iterations `0..iterations` (or until `seconds` pass) of campaign `kind` with `seed` in
/// worker processes, restarting after a crash or hang. Inputs that fail are saved in the
/// state directory (printed) for adding to the corpus.
fn campaign(kind: &str, seed: u64, iterations: u64, seconds: f64) -> Campaign {
    let state = scratch::dir(&format!("{kind}-{seed}"));
    let exe = std::env::current_exe().unwrap();
    let corpus = corpus(kind);
    let start = Instant::now();
    let mut c = Campaign::default();
    let mut next = 0u64;
    while next < iterations && start.elapsed().as_secs_f64() < seconds {
        let left = seconds - start.elapsed().as_secs_f64();
        let count = (iterations - next).min(BATCH);
        let _ = std::fs::remove_file(state.join("progress"));
        let _ = std::fs::remove_file(state.join("stage"));
        let mut child = Command::new("sh")
            .arg("-c")
            .arg(format!("ulimit -v {WORKER_VMEM_KIB}; exec \"$0\" \"$@\""))
            .arg(&exe)
            .args([
                "--exact",
                "fuzz_inputs::fuzz_worker",
                "--ignored",
                "--nocapture",
            ])
            .args(["--test-threads", "1"])
            .env("BRUME_FUZZ_WORKER", kind)
            .env("BRUME_FUZZ_SEED", seed.to_string())
            .env("BRUME_FUZZ_FROM", next.to_string())
            .env("BRUME_FUZZ_COUNT", count.to_string())
            .env("BRUME_FUZZ_DEADLINE", left.to_string())
            .env("BRUME_FUZZ_STATE", &state)
            // OpenVDB's reader process gives up before the hang watchdog fires.
            .env("BRUME_VDB_READ_TIMEOUT", (HANG_SECONDS / 3).to_string())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        // Watch for hangs: the progress file must change within HANG_SECONDS.
        let mut last = (String::new(), Instant::now());
        let status = loop {
            if let Some(s) = child.try_wait().unwrap() {
                break Some(s);
            }
            let p = std::fs::read_to_string(state.join("progress")).unwrap_or_default();
            if p != last.0 {
                last = (p, Instant::now());
            } else if last.1.elapsed() > Duration::from_secs(HANG_SECONDS) {
                child.kill().unwrap();
                child.wait().unwrap();
                break None;
            }
            std::thread::sleep(Duration::from_millis(5));
        };
        let mut out = String::new();
        std::io::Read::read_to_string(&mut child.stdout.take().unwrap(), &mut out).unwrap();
        let progress: Option<u64> = std::fs::read_to_string(state.join("progress"))
            .ok()
            .and_then(|s| s.parse().ok());
        let stage = std::fs::read_to_string(state.join("stage")).unwrap_or_default();
        // libtest prints "test fuzz_worker ... " before the first output line: search in lines.
        for line in out.lines() {
            if let Some(rest) = line.find("FAIL ").map(|k| &line[k + 5..]) {
                let (i, msg) = rest.split_once(' ').unwrap();
                let i: u64 = i.parse().unwrap();
                save(kind, &state, &corpus, seed, i, "fail");
                c.failures.push((i, msg.to_string()));
            }
        }
        if let Some(v) = out.lines().find_map(|l| {
            let rest = &l[l.find("RSS ")? + 4..];
            let v: Vec<i64> = rest.split(' ').filter_map(|x| x.parse().ok()).collect();
            (v.len() == 2).then_some(v)
        }) {
            c.rss_growth_kib = Some(c.rss_growth_kib.unwrap_or(i64::MIN).max(v[1] - v[0]));
        }
        let done = out.lines().find_map(|l| {
            let rest = &l[l.find("DONE ")? + 5..];
            Some(
                rest.split(' ')
                    .map(|x| x.parse::<u64>().unwrap())
                    .collect::<Vec<_>>(),
            )
        });
        match (status, done) {
            (Some(s), Some(v)) if s.success() => {
                c.iterations += v[0];
                c.accepted += v[1];
                c.refused += v[2];
                c.reader_crashed += v[3];
                next += v[0];
                if v[0] < count {
                    break; // the deadline passed
                }
            }
            (status, _) => {
                let i = progress.unwrap_or(next);
                let what = match status {
                    None => format!("hang (no progress for {HANG_SECONDS} s)"),
                    Some(s) => format!("worker died: {s}"),
                };
                c.iterations += i + 1 - next;
                next = i + 1;
                save(kind, &state, &corpus, seed, i, "crash");
                c.crashes.push((i, format!("{what} (stage {stage:?})")));
            }
        }
    }
    c.seconds = start.elapsed().as_secs_f64();
    println!(
        "fuzz {kind} seed {seed}: {} iterations in {:.1} s ({} accepted, {} refused, of which {} \
         crashed OpenVDB's reader in its own process), \
         {} failures, {} crashes/hangs, worker resident size after {RSS_WARMUP} inputs grew by {}",
        c.iterations,
        c.seconds,
        c.accepted,
        c.refused,
        c.reader_crashed,
        c.failures.len(),
        c.crashes.len(),
        c.rss_growth_kib
            .map_or("(not measured: too few inputs)".into(), |k| format!(
                "at most {k} KiB"
            )),
    );
    for (i, m) in c.failures.iter().chain(&c.crashes) {
        println!("  iteration {i}: {m}");
    }
    c
}

/// Saves the input of iteration `i` for the report (and for the corpus).
fn save(kind: &str, state: &Path, corpus: &[(String, Vec<u8>)], seed: u64, i: u64, what: &str) {
    let bytes = input(kind, corpus, seed, i);
    let ext = input_name(kind, &bytes).trim_start_matches("input.");
    let p = state.join(format!("{what}-seed{seed}-{i}.{ext}"));
    std::fs::write(&p, bytes).unwrap();
    println!("saved {}", p.display());
}

fn assert_clean(c: &Campaign) {
    assert!(
        c.failures.is_empty() && c.crashes.is_empty(),
        "failures {:?}, crashes {:?}",
        c.failures,
        c.crashes
    );
    if let Some(k) = c.rss_growth_kib {
        assert!(
            k < RSS_GROWTH_LIMIT_KIB,
            "a worker's resident size grew by {k} KiB: a leak?"
        );
    }
}

#[test]
fn fuzz_vdb_loader() {
    let c = campaign("vdb", 1, CI_VDB_ITERATIONS, 120.0);
    assert_clean(&c);
    assert_eq!(c.iterations, CI_VDB_ITERATIONS);
    assert!(c.accepted > 0 && c.refused > 0, "{c:?}");
}

#[test]
fn fuzz_gltf_medium_parser() {
    let c = campaign("gltf", 1, CI_GLTF_ITERATIONS, 120.0);
    assert_clean(&c);
    assert_eq!(c.iterations, CI_GLTF_ITERATIONS);
    assert!(c.accepted > 0 && c.refused > 0, "{c:?}");
}

#[test]
fn fuzz_envmap_loader() {
    let c = campaign("envmap", 1, CI_ENVMAP_ITERATIONS, 120.0);
    assert_clean(&c);
    assert_eq!(c.iterations, CI_ENVMAP_ITERATIONS);
    assert!(c.accepted > 0 && c.refused > 0, "{c:?}");
}

fn long_seconds() -> f64 {
    std::env::var("BRUME_FUZZ_SECONDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(600.0)
}

fn long_seed() -> u64 {
    std::env::var("BRUME_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1000)
}

#[test]
#[ignore = "long mode: BRUME_FUZZ_SECONDS (default 600)"]
fn long_fuzz_vdb_loader() {
    assert_clean(&campaign("vdb", long_seed(), u64::MAX / 2, long_seconds()));
}

#[test]
#[ignore = "long mode: BRUME_FUZZ_SECONDS (default 600)"]
fn long_fuzz_envmap_loader() {
    assert_clean(&campaign(
        "envmap",
        long_seed(),
        u64::MAX / 2,
        long_seconds(),
    ));
}

#[test]
#[ignore = "long mode: BRUME_FUZZ_SECONDS (default 600)"]
fn long_fuzz_gltf_medium_parser() {
    assert_clean(&campaign("gltf", long_seed(), u64::MAX / 2, long_seconds()));
}

/// Writes the environment-map seed corpus (run once; the files are committed): a small sky as
/// a float EXR, as a flat Radiance file and as a run-length-encoded one (the `image` crate's
/// encoder), and a grey (`Y`-only) EXR.
#[test]
#[ignore = "regenerates tests/fuzz/envmap"]
fn write_envmap_corpus() {
    use brume::scene::envmap::{write_environment_exr, EnvironmentImage};
    let dir = fuzz_dir("envmap");
    std::fs::create_dir_all(&dir).unwrap();
    let (w, h) = (16u32, 8u32);
    let rgb: Vec<[f32; 3]> = (0..w * h)
        .map(|k| {
            let (i, j) = (k % w, k / w);
            let sun = if (i, j) == (5, 2) { 50.0 } else { 0.0 };
            [
                0.2 + 0.05 * j as f32 + sun,
                0.3 + 0.01 * i as f32,
                0.6 + sun,
            ]
        })
        .collect();
    let sky = EnvironmentImage {
        width: w,
        height: h,
        rgb: rgb.clone(),
    };
    write_environment_exr(&dir.join("sky.exr"), &sky).unwrap();
    brume::film::write_exr_single(
        dir.join("grey.exr"),
        8,
        4,
        &(0..32).map(|k| k as f32 * 0.25).collect::<Vec<_>>(),
        &brume::film::Metadata::new(),
    )
    .unwrap();
    let mut flat = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n").into_bytes();
    for p in &rgb {
        // RGBE: a shared exponent e with max(p) in [2^(e-1), 2^e), mantissas scaled to 256.
        let e = p[0].max(p[1]).max(p[2]).log2().floor() as i32 + 1;
        let scale = 256.0 / 2f32.powi(e);
        flat.extend_from_slice(&[
            (p[0] * scale) as u8,
            (p[1] * scale) as u8,
            (p[2] * scale) as u8,
            (e + 128) as u8,
        ]);
    }
    std::fs::write(dir.join("flat.hdr"), flat).unwrap();
    let mut rle = Vec::new();
    let pixels: Vec<image::Rgb<f32>> = rgb.iter().map(|p| image::Rgb(*p)).collect();
    image::codecs::hdr::HdrEncoder::new(&mut rle)
        .encode(&pixels, w as usize, h as usize)
        .unwrap();
    std::fs::write(dir.join("rle.hdr"), rle).unwrap();
}

/// Writes the seed corpora (run once; the files are committed).
#[test]
#[ignore = "regenerates tests/fuzz/{vdb,gltf}"]
fn write_seed_corpus() {
    use brume_ffi::{write_float_grids, GridClass, GridSpec};
    let vdb = fuzz_dir("vdb");
    let gltf = fuzz_dir("gltf");
    std::fs::create_dir_all(&vdb).unwrap();
    std::fs::create_dir_all(&gltf).unwrap();
    let blob = |n: i32, peak: f32| {
        let mut v = Vec::new();
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    let q = [x, y, z].map(|c| (c as f32 + 0.5) / n as f32 - 0.5);
                    let d = (1.0 - 4.0 * (q[0] * q[0] + q[1] * q[1] + q[2] * q[2])).max(0.0);
                    if d > 0.0 {
                        v.push(([x - n / 2, y, z], peak * d));
                    }
                }
            }
        }
        v
    };
    let mut g = GridSpec::fog("density", 0.1, [0.0; 3]);
    g.voxels = blob(10, 1.0);
    write_float_grids(vdb.join("blob.vdb"), &[g.clone()]).unwrap();
    let mut h = g.clone();
    h.save_as_half = true;
    write_float_grids(vdb.join("blob_half.vdb"), &[h]).unwrap();
    // Constant 16^3 block: pruned to tiles.
    let mut t = GridSpec::fog("density", 0.5, [1.0, 2.0, 3.0]);
    for z in 0..16 {
        for y in 0..16 {
            for x in 0..16 {
                t.voxels.push(([x, y, z], 0.75));
            }
        }
    }
    write_float_grids(vdb.join("tiles.vdb"), &[t]).unwrap();
    // Two grids (density and temperature), one a level set, and a vec3 grid.
    let mut a = GridSpec::fog("density", 0.2, [0.0; 3]);
    a.voxels = blob(6, 2.0);
    let mut b = GridSpec::fog("temperature", 0.2, [0.0; 3]);
    b.voxels = blob(6, 1500.0);
    let mut ls = GridSpec::fog("surface", 0.2, [0.0; 3]);
    ls.class = GridClass::LevelSet;
    ls.background = 0.6;
    ls.voxels = blob(4, -0.3);
    let mut v3 = GridSpec::fog("velocity", 0.2, [0.0; 3]);
    v3.as_vec3 = true;
    v3.voxels = vec![([0, 0, 0], 1.0)];
    write_float_grids(vdb.join("multi.vdb"), &[a.clone(), b.clone(), ls, v3]).unwrap();
    // An empty grid, and a grid with a negative voxel (clamped on load).
    write_float_grids(
        vdb.join("empty.vdb"),
        &[GridSpec::fog("density", 1.0, [0.0; 3])],
    )
    .unwrap();
    let mut neg = GridSpec::fog("density", 1.0, [0.0; 3]);
    neg.prune = false;
    neg.voxels = vec![([0, 0, 0], 0.5), ([1, 0, 0], -2.0), ([9, 0, 0], 1.0)];
    write_float_grids(vdb.join("negative.vdb"), &[neg]).unwrap();

    // glTF corpus: the grid file and scenes that exercise each field.
    write_float_grids(gltf.join("grid.vdb"), &[a, b]).unwrap();
    let scene = |medium: Value| {
        json!({
            "asset": {"version": "2.0"},
            "scene": 0,
            "scenes": [{"nodes": [0, 1]}],
            "nodes": [
                {"camera": 0, "translation": [0.0, 0.3, 3.0]},
                {"extensions": {"BRUME_medium_vdb": medium}}
            ],
            "cameras": [{"type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.01}}],
            "extensions": {"BRUME_environment": {"color": [1, 1, 1], "strength": 1}},
            "extensionsUsed": ["BRUME_medium_vdb", "BRUME_environment"]
        })
    };
    let media = [
        ("minimal", json!({"uri": "grid.vdb"})),
        (
            "scattering",
            json!({"uri": "grid.vdb", "densityScale": 4.0, "color": [0.9, 0.8, 0.7],
                   "absorptionColor": [0.1, 0.2, 0.3], "anisotropy": 0.6}),
        ),
        (
            "emissive",
            json!({"uri": "grid.vdb", "densityGrid": "density", "emissionGrid": "density",
                   "emissionStrength": 2.0, "emissionColor": [1.0, 0.5, 0.1],
                   "temperatureGrid": "temperature", "blackbodyIntensity": 1.0,
                   "blackbodyTint": [1.0, 0.9, 0.8], "temperatureScale": 1.0,
                   "temperatureOffset": 300.0}),
        ),
    ];
    for (name, m) in media {
        std::fs::write(
            gltf.join(format!("{name}.gltf")),
            serde_json::to_string_pretty(&scene(m)).unwrap(),
        )
        .unwrap();
    }
}
