//! Checks on how the `brume` command refuses bad input: the exit status, the message naming
//! the file and saying why, and nothing half-written left behind.
use std::path::{Path, PathBuf};
use std::process::Output;

/// Asserts a refusal: non-zero exit, an `error:` line naming `culprit` and saying `why`, and
/// no panic. `what` labels the case in messages.
pub fn assert_refused(o: &Output, culprit: &Path, why: &str, what: &str) {
    let err = String::from_utf8_lossy(&o.stderr);
    println!("{what}: {}", err.lines().last().unwrap_or("").trim());
    assert!(!o.status.success(), "{what}: accepted\n{err}");
    assert!(
        err.contains(&culprit.display().to_string()),
        "{what}: the message does not name {}: {err}",
        culprit.display()
    );
    assert!(err.contains(why), "{what}: no {why:?} in {err}");
    assert!(!err.contains("panicked"), "{what}: {err}");
}

/// Temporary files an atomic write left in `d` (there must be none after any failure).
pub fn temporaries(d: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.file_name().unwrap().to_string_lossy().contains(".tmp-"))
        .collect()
}

/// Runs `brume render SCENE -o OUT` with `fixed` then `extra` arguments.
pub fn render_to(scene: &Path, out: &Path, fixed: &[&str], extra: &[&str]) -> Output {
    let mut args = vec![
        "render",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ];
    args.extend(fixed);
    args.extend(extra);
    std::process::Command::new(env!("CARGO_BIN_EXE_brume"))
        .args(&args)
        .output()
        .unwrap()
}
