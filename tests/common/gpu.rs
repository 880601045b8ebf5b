//! The GPU context for the `gpu_*` tests: SKIP (with a visible line) only when no adapter
//! exists at all; any other failure to use the GPU fails the test.
use brume::backend::gpu::GpuContext;

pub fn gpu_or_skip(test: &str) -> Option<GpuContext> {
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        // Silences Mesa's warnings about a missing runtime directory.
        let dir = std::env::temp_dir().join(format!("brume-xdg-{}", std::process::id()));
        let _ = std::fs::create_dir_all(&dir);
        std::env::set_var("XDG_RUNTIME_DIR", dir);
    }
    match GpuContext::new() {
        Ok(ctx) => {
            println!("{test}: {}", ctx.describe());
            Some(ctx)
        }
        Err(e) if e.no_adapter => {
            eprintln!("SKIP: no GPU adapter: {}", e.reason);
            None
        }
        Err(e) => panic!("{test}: GPU adapter present but unusable: {}", e.reason),
    }
}
