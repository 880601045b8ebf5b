//! Scratch folders of a test process: all under one root in the system's temporary folder,
//! `brume-test-<test binary>-<pid>`, which is removed when the process exits. If any test of
//! the process panicked, the root is kept for inspection and its path printed instead.
//!
//! Tests run as threads of one process, in parallel, and libtest has no teardown hook; so the
//! root is removed by a C `atexit` handler (which runs after libtest's last test, on success
//! and on failure alike) and failures are noticed by a panic hook, chained to the one before.
//! A test that catches a panic of its own on purpose also keeps the files; that only costs
//! disk space.
//!
//! Included by path (`#[path = ".../common/scratch.rs"]`) in test crates that do not use
//! `common`, and by the `ffi` crate's tests, so it depends on nothing but `std`.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::OnceLock;

static ROOT: OnceLock<PathBuf> = OnceLock::new();
static PANICKED: AtomicBool = AtomicBool::new(false);

extern "C" {
    // From the C library every Rust program on Linux links; not worth a crate for one call.
    fn atexit(callback: extern "C" fn()) -> std::ffi::c_int;
}

extern "C" fn remove_root() {
    let Some(root) = ROOT.get() else { return };
    if PANICKED.load(Ordering::SeqCst) {
        eprintln!(
            "a test panicked: its scratch files are kept in {}",
            root.display()
        );
    } else {
        let _ = std::fs::remove_dir_all(root);
    }
}

/// This process's scratch root, created (empty) on first use.
pub fn root() -> &'static Path {
    ROOT.get_or_init(|| {
        // `render_cli-0123abcdef` -> `render_cli`: the test binary, without cargo's hash.
        let exe = std::env::current_exe()
            .ok()
            .and_then(|p| p.file_stem().map(|s| s.to_string_lossy().into_owned()))
            .unwrap_or_default();
        let name = exe.rsplit_once('-').map_or(exe.as_str(), |(n, _)| n);
        let root = std::env::temp_dir().join(format!("brume-test-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        std::fs::create_dir_all(&root)
            .unwrap_or_else(|e| panic!("cannot create {}: {e}", root.display()));
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            PANICKED.store(true, Ordering::SeqCst);
            previous(info)
        }));
        // SAFETY: registers a plain function with no arguments; it only reads statics.
        unsafe { atexit(remove_root) };
        root
    })
}

/// A fresh, empty folder `name` under the root (emptied if an earlier call made it).
pub fn dir(name: &str) -> PathBuf {
    let d = root().join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap_or_else(|e| panic!("cannot create {}: {e}", d.display()));
    d
}

/// The path of a file `name` directly under the root (tests that write a few files side by
/// side give them distinct names).
pub fn file(name: &str) -> PathBuf {
    root().join(name)
}
