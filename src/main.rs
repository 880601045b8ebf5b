//! The `brume` command line. Each subcommand lives in `src/cli/`; this file only parses.
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod cli;

#[derive(Parser)]
#[command(
    name = "brume",
    version,
    about = "Offline volumetric renderer for OpenVDB media in glTF scenes"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Print the facts of a .vdb file (grids, transforms, Brume layout, bound tightness) or of
    /// a glTF scene.
    Info {
        /// A .vdb, .gltf or .glb file.
        path: PathBuf,
        /// Skip the conversion to Brume's layout (faster for big .vdb files).
        #[arg(long)]
        no_layout: bool,
    },
    /// Render a scene to an EXR (GPU or CPU backend).
    Render(Box<cli::render::RenderArgs>),
    /// Merge partial renders of one image (sample ranges, regions, farm tasks) into one EXR.
    Merge(cli::merge::MergeArgs),
    /// Render one image on a cluster: `brume farm slurm` writes/submits a job array + merge.
    Farm {
        #[command(subcommand)]
        which: brume::farm::slurm::FarmWhich,
    },
    /// Render a scene with Blender Cycles (bpy) for comparison (tools/cycles, docs/comparing.md).
    Cycles(brume::lab::reference::cycles::CyclesArgs),
    /// Render a scene with Mitsuba 3 for comparison (tools/mitsuba, docs/comparing.md).
    Mitsuba(brume::lab::reference::mitsuba::MitsubaArgs),
    /// Convert a Blender scene (.blend) to a Brume glTF scene with the tools/blender add-on
    /// (bpy, as `brume cycles` finds it; docs/blender.md).
    ImportBlend(brume::lab::reference::import_blend::ImportBlendArgs),
    /// Compare an image with a reference: RMSE, relMSE, per-pixel and block z-tests.
    Compare(cli::compare::CompareArgs),
    /// Error against time for a sweep of estimator configurations (tables and plots).
    Study(cli::study::StudyArgs),
    /// Print performance figures (benchmarks, not tests).
    Bench {
        #[command(subcommand)]
        which: brume::lab::bench::Which,
    },
}

/// Mesa's Vulkan device-select layer opens a Wayland connection while the backend looks for a
/// GPU, and libwayland prints `error: XDG_RUNTIME_DIR is invalid or not set` on a headless
/// machine, which is no error of the render's. The layer only reorders GPUs for a desktop
/// session (Brume picks its adapter itself), so it is switched off unless the user asked for
/// it (`MESA_VK_DEVICE_SELECT`) or set its switch. Runs before any thread starts, since the
/// environment may not change while another thread reads it.
fn quiet_gpu_probe() {
    let headless = std::env::var_os("XDG_RUNTIME_DIR").is_none();
    let chosen = std::env::var_os("MESA_VK_DEVICE_SELECT").is_some()
        || std::env::var_os("NODEVICE_SELECT").is_some();
    if headless && !chosen {
        std::env::set_var("NODEVICE_SELECT", "1");
    }
}

fn main() -> ExitCode {
    // `brume info x.vdb | head` should end quietly, as other Unix tools do, not panic on the
    // closed pipe.
    // SAFETY: setting a signal disposition before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
        // A file-size limit (`ulimit -f`) should fail the write with EFBIG, which the writer
        // reports naming the file, not kill the process with SIGXFSZ and no message.
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
    quiet_gpu_probe();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Info { path, no_layout } => cli::info::run(&path, !no_layout),
        Command::Render(args) => cli::render::run(&args),
        Command::Merge(args) => cli::merge::run(&args),
        Command::Farm { which } => brume::farm::slurm::run(&which),
        Command::Cycles(args) => brume::lab::reference::cycles::run(&args),
        Command::Mitsuba(args) => brume::lab::reference::mitsuba::run(&args),
        Command::ImportBlend(args) => brume::lab::reference::import_blend::run(&args),
        Command::Compare(args) => cli::compare::run(&args),
        Command::Study(args) => cli::study::run(&args),
        Command::Bench { which } => brume::lab::bench::run(which),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", error_chain(&e));
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes on one line, as `{:#}` prints them, less each cause whose text
/// the line already holds (an error that quotes its source, as `cannot write X: File too
/// large` does, would otherwise say it twice).
fn error_chain(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if line.contains(&text) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    line
}
