//! What the tests against other programs share: finding a Python that can `import bpy`, and
//! printing figures and skips where a passing run still shows them.
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

/// A Python that can `import bpy`: `BRUME_BPY_PYTHON`, the venv `tools/cycles/ci.sh` makes,
/// or `python3`; `None` when none can.
pub fn bpy_python() -> Option<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let candidates = std::env::var_os("BRUME_BPY_PYTHON")
        .map(PathBuf::from)
        .into_iter()
        .chain([
            root.join("tools/cycles/.venv/bin/python"),
            PathBuf::from("python3"),
        ]);
    candidates.into_iter().find(|p| {
        Command::new(p)
            .args(["-c", "import bpy"])
            .output()
            .is_ok_and(|o| o.status.success())
    })
}

/// Written straight to the process's stderr: libtest's capture only hooks `eprintln!` and
/// `println!`, so a figure or a skip stays visible in a passing run.
pub fn say(msg: &str) {
    let _ = writeln!(std::io::stderr(), "{msg}");
}
