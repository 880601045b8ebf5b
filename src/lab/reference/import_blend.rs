//! `brume import-blend scene.blend -o scene.gltf`: converts a Blender scene to a Brume glTF scene
//! headless, with Blender's own glTF exporter and the `brume_gltf` add-on (`tools/blender`,
//! docs/blender.md), run by the Python with bpy that `brume cycles` uses. The result is
//! then loaded as `brume render` would, so a scene Brume cannot read is reported at once.
use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{bail, Context, Result};
use clap::Args;

use super::cycles::BPY;
use super::{find_script, output_tail};

#[derive(Args, Debug)]
pub struct ImportBlendArgs {
    /// The Blender scene (.blend).
    pub blend: PathBuf,
    /// Output glTF: .gltf (with its .bin beside it) or .glb.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Copy the .vdb files (and an environment map) beside the output instead of referring to
    /// them by relative paths.
    #[arg(long)]
    pub copy_vdb: bool,
    /// Scene frame to export (VDB sequences, animated transforms); default: the saved frame.
    #[arg(long, allow_negative_numbers = true)]
    pub frame: Option<i32>,
    /// Another glTF-exporter add-on to enable as well (a package folder or a .py module).
    #[arg(long)]
    pub addon: Vec<PathBuf>,
}

/// The driver script: `BRUME_BLENDER_SCRIPT`, else `tools/blender/export_blend.py` in the
/// working directory or the source tree.
fn script_path() -> Result<PathBuf> {
    find_script("BRUME_BLENDER_SCRIPT", "tools/blender/export_blend.py")
}

fn check_paths(args: &ImportBlendArgs) -> Result<()> {
    if !args.blend.is_file() {
        bail!("{}: no such .blend file", args.blend.display());
    }
    let ext = |p: &Path| {
        p.extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
    };
    if ext(&args.blend).as_deref() != Some("blend") {
        bail!("{}: expected a .blend file", args.blend.display());
    }
    if !matches!(ext(&args.output).as_deref(), Some("gltf" | "glb")) {
        bail!(
            "{}: the output must end in .gltf or .glb",
            args.output.display()
        );
    }
    let dir = match args.output.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        bail!("{}: the output folder does not exist", dir.display());
    }
    Ok(())
}

pub fn run(args: &ImportBlendArgs) -> Result<()> {
    check_paths(args)?;
    let python = BPY.find()?;
    let script = script_path()?;
    let mut cmd = Command::new(&python);
    cmd.arg(&script)
        .arg(&args.blend)
        .arg("-o")
        .arg(&args.output);
    if args.copy_vdb {
        cmd.arg("--copy-vdb");
    }
    if let Some(f) = args.frame {
        cmd.arg(format!("--frame={f}"));
    }
    for a in &args.addon {
        cmd.arg("--addon").arg(a);
    }
    let out = cmd
        .output()
        .with_context(|| format!("running {}", python.display()))?;
    let stderr = String::from_utf8_lossy(&out.stderr);
    // The add-on's own lines; Blender's log and tracebacks stay out of the way.
    for line in stderr.lines() {
        if let Some(w) = line.strip_prefix("brume_gltf: warning: ") {
            eprintln!("import-blend: warning: {w}");
        }
    }
    if !out.status.success() {
        let reasons: Vec<&str> = stderr
            .lines()
            .filter_map(|l| l.strip_prefix("error: "))
            .collect();
        if reasons.is_empty() {
            bail!(
                "exporting {} failed ({}):\n{}",
                args.blend.display(),
                out.status,
                output_tail(&out, 20)
            );
        }
        bail!(
            "exporting {} failed; nothing written:\n  {}",
            args.blend.display(),
            reasons.join("\n  ")
        );
    }
    let scene = crate::scene::load(&args.output).with_context(|| {
        format!(
            "{} was written but Brume cannot read it",
            args.output.display()
        )
    })?;
    for w in &scene.warnings {
        eprintln!("import-blend: {}: {w}", args.output.display());
    }
    println!(
        "import-blend: wrote {} ({} medium(s), {} light(s), {} triangle(s))",
        args.output.display(),
        scene.vdb_media.len(),
        scene.lights.len(),
        scene.triangle_count()
    );
    Ok(())
}
