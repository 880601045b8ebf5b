//! Brume against Blender Cycles on the cloud scene (docs/CYCLES.md): the image means agree
//! within 1 % and no 8x8 block fails a z-test at 99.9 %. Needs a Python that can `import bpy`
//! (tools/cycles/ci.sh installs one); without it the test says so on stderr and passes.
//! Seeds are fixed on both sides, so the outcome is deterministic.
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

fn bpy_python() -> Option<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let candidates = std::env::var_os("BRUME_BPY_PYTHON")
        .map(PathBuf::from)
        .into_iter()
        .chain([
            root.join("tools/cycles/.venv/bin/python"),
            PathBuf::from("python3"),
        ]);
    for p in candidates {
        let ok = Command::new(&p)
            .args(["-c", "import bpy"])
            .output()
            .is_ok_and(|o| o.status.success());
        if ok {
            return Some(p);
        }
    }
    None
}

/// Written straight to the process's stderr: libtest's capture only hooks `eprintln!`, so a
/// skip stays visible in a passing run.
fn say(msg: &str) {
    let _ = writeln!(std::io::stderr(), "{msg}");
}

#[test]
fn cloud_agrees_with_cycles() {
    let Some(python) = bpy_python() else {
        say("SKIPPED cycles_compare: no Python with bpy (run tools/cycles/ci.sh to install bpy 5.0.1)");
        return;
    };
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = std::env::temp_dir().join(format!("brume-cycles-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = root.join("scenes/cloud.gltf");
    let (brume_exr, cycles_exr) = (dir.join("brume.exr"), dir.join("cycles.exr"));
    let size = ["--width", "32", "--height", "24"];
    let exe = env!("CARGO_BIN_EXE_brume");

    let st = Command::new(exe)
        .arg("render")
        .arg(&scene)
        .arg("-o")
        .arg(&brume_exr)
        .args(["--spp", "256", "--seed", "7"])
        .args(size)
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );

    let out = Command::new(exe)
        .arg("cycles")
        .arg(&scene)
        .arg("-o")
        .arg(&cycles_exr)
        .args(["--spp", "32", "--runs", "4", "--seed", "1"])
        .args(size)
        .arg("--against")
        .arg(&brume_exr)
        .env("BRUME_BPY_PYTHON", &python)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    say(&format!("cycles_compare: cloud 32x24: {}", stdout.trim()));
    let field = |name: &str| -> String {
        let words: Vec<&str> = stdout.split_whitespace().collect();
        let i = words.iter().position(|w| *w == name).expect(name);
        words[i + 1].to_string()
    };
    let rel: f64 = field("mean_rel_diff").parse().unwrap();
    let failed = field("blocks_failed");
    let (bad, total) = failed.split_once('/').unwrap();
    let (bad, total): (usize, usize) = (bad.parse().unwrap(), total.parse().unwrap());
    assert!(rel.abs() < 0.01, "image means differ by {rel}");
    assert!(
        bad as f64 <= 0.01 * total as f64,
        "{bad} of {total} blocks fail"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
