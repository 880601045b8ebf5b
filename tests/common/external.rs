//! What the tests against other programs share: finding a Python that can `import bpy`, a
//! scratch folder to run it in, and printing figures and skips where a passing run still
//! shows them.
use std::ffi::OsStr;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The repository's root.
pub fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

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

/// A test run with a Python that has bpy: its scratch folder (removed when the test passes,
/// kept for inspection when it fails) and `brume` told to use that Python.
pub struct BpyRun {
    pub python: PathBuf,
    pub dir: PathBuf,
}

impl BpyRun {
    /// The run of test `test` in module `module`; `None`, after a SKIPPED line, where no Python
    /// can `import bpy`.
    pub fn new(module: &str, test: &str) -> Option<BpyRun> {
        let Some(python) = bpy_python() else {
            say(&format!(
                "SKIPPED {module}::{test}: no Python with bpy (run tools/cycles/ci.sh to install \
                 bpy 5.0.1)"
            ));
            return None;
        };
        let dir =
            std::env::temp_dir().join(format!("brume-{module}-{test}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Some(BpyRun { python, dir })
    }

    /// `name` in the scratch folder.
    pub fn path(&self, name: &str) -> PathBuf {
        self.dir.join(name)
    }

    /// `brume ARGS` with this Python.
    pub fn brume<S: AsRef<OsStr>>(&self, args: &[S]) -> Output {
        Command::new(env!("CARGO_BIN_EXE_brume"))
            .args(args)
            .env("BRUME_BPY_PYTHON", &self.python)
            .output()
            .unwrap()
    }
}

impl Drop for BpyRun {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.dir);
        }
    }
}

/// A command's stdout and stderr, for failure messages.
pub fn text(o: &Output) -> String {
    format!(
        "{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// Asserts that a command succeeded, showing its output where it did not.
pub fn assert_ok(o: &Output, what: &str) {
    assert!(o.status.success(), "{what} failed:\n{}", text(o));
}
