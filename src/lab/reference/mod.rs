//! What the reference-renderer commands (`brume cycles`, `brume mitsuba`) share: merging
//! independent runs into one EXR laid out like Brume's (mean, variance of the mean across
//! runs, samples), reading the per-run report of their Python scripts, and the agreement
//! summary printed by `--against` (image mean relative difference and an 8x8 block z-test,
//! docs/comparing.md).
pub mod agreement;
pub mod cycles;
pub mod import_blend;
pub mod merge;
pub mod mitsuba;
pub mod passes;

pub use agreement::{compare, Agreement, AlphaAgreement};
pub use merge::merge_runs;

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{anyhow, bail, Context, Result};
use clap::Args;

use crate::film::exr_io::PASSES_ATTRIBUTE;
use crate::film::{read_exr, write_image_with, AttrValue, Image, Metadata};

/// One finished run reported by a translation script: a line
/// `render_seconds <run> <seconds> <exr path>` on its stdout.
pub struct RunReport {
    pub seconds: f64,
    pub image: Image,
    /// The run's EXR, for layers beyond the beauty (a reference's passes).
    pub path: PathBuf,
}

/// The options every reference-renderer command (`brume cycles`, `brume mitsuba`) takes.
#[derive(Args, Debug)]
pub struct ReferenceRun {
    /// The Brume scene (.gltf or .glb).
    pub scene: PathBuf,
    /// Output EXR (beauty RGBA; `variance.*` when --runs > 1; `samples.Y`).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Samples per pixel of each run.
    #[arg(long, default_value_t = 64)]
    pub spp: u32,
    #[arg(long, default_value_t = 320)]
    pub width: u32,
    #[arg(long, default_value_t = 240)]
    pub height: u32,
    /// Independent renders (seeds seed..seed+runs-1), averaged; their spread gives the
    /// variance layer, so use at least 4 for a block z-test.
    #[arg(long, default_value_t = 1)]
    pub runs: u32,
    #[arg(long, default_value_t = 0)]
    pub seed: u32,
    /// The reference renderer's threads (default: all cores).
    #[arg(long)]
    pub threads: Option<u32>,
    /// Brume's maximum number of scattering events (mapped to the renderer's own depth;
    /// default: the scene's `BRUME_render` maxDepth, else Brume's default 256, as `brume
    /// render`).
    #[arg(long)]
    pub max_depth: Option<u32>,
    /// Compare with this Brume EXR (needs its variance layer) and print the agreement.
    #[arg(long)]
    pub against: Option<PathBuf>,
    /// Do not render: compare the existing --output with --against.
    #[arg(long, requires = "against")]
    pub reuse: bool,
}

impl ReferenceRun {
    /// Checks the counts, then with `--reuse` compares the existing `--output` with
    /// `--against` and prints the agreement: `true` when that is all there is to do.
    pub fn check_or_reuse(&self) -> Result<bool> {
        if self.runs == 0 || self.spp == 0 {
            bail!("--runs and --spp must be at least 1");
        }
        if self.width == 0 || self.height == 0 {
            bail!("--width and --height must be at least 1");
        }
        if !self.reuse {
            return Ok(false);
        }
        let against = self
            .against
            .as_ref()
            .expect("clap: --reuse requires --against");
        print_agreement(against, &self.output)?;
        Ok(true)
    }
}

/// Where a reference renderer's Python is found: `var` (an error if it cannot `import
/// module`), then `venv` next to the working directory, then the same in the source tree, then
/// `python3` on the PATH when `path_python`; `hint` says how to get one.
pub struct PythonTool {
    pub var: &'static str,
    pub venv: &'static str,
    pub module: &'static str,
    pub path_python: bool,
    pub hint: &'static str,
}

impl PythonTool {
    /// The first Python that imports the module.
    pub fn find(&self) -> Result<PathBuf> {
        let module = self.module;
        let imports = |python: &Path| {
            Command::new(python)
                .args(["-c", &format!("import {module}")])
                .output()
                .is_ok_and(|o| o.status.success())
        };
        if let Some(p) = std::env::var_os(self.var) {
            let p = PathBuf::from(p);
            if imports(&p) {
                return Ok(p);
            }
            bail!("{}={} cannot `import {module}`", self.var, p.display());
        }
        let venv = Path::new(self.venv);
        let mut candidates = vec![
            venv.to_path_buf(),
            Path::new(env!("CARGO_MANIFEST_DIR")).join(venv),
        ];
        if self.path_python {
            candidates.push(PathBuf::from("python3"));
        }
        candidates
            .into_iter()
            .find(|p| imports(p))
            .ok_or_else(|| anyhow!(self.hint))
    }
}

/// A reference renderer's driver: the Python it runs and the translation script it runs
/// there (`script_var`, else `script` in the working directory or the source tree).
pub struct Driver {
    /// The renderer's name in messages ("Cycles"); in lower case, in metadata keys and the
    /// scratch folder's name.
    pub name: &'static str,
    pub python: PythonTool,
    pub script_var: &'static str,
    pub script: &'static str,
}

/// A reference renderer's finished runs: their images, seconds and the metadata every merged
/// reference EXR carries.
pub struct Rendered {
    pub images: Vec<Image>,
    /// The runs' EXRs, in order.
    pub paths: Vec<PathBuf>,
    pub seconds: Vec<f64>,
    /// The sum of `seconds`.
    pub total: f64,
    pub meta: Metadata,
}

impl Driver {
    /// After `run`'s checks, runs `work` with the Python, the script and a scratch folder
    /// (`keep`, else a temporary one removed afterwards); nothing more when `--reuse` made the
    /// run a comparison of existing images, already printed.
    pub fn run(
        &self,
        run: &ReferenceRun,
        keep: Option<&Path>,
        work: impl FnOnce(&Path, &Path, &Path) -> Result<()>,
    ) -> Result<()> {
        if run.check_or_reuse()? {
            return Ok(());
        }
        let python = self.python.find()?;
        let script = find_script(self.script_var, self.script)?;
        let scratch = self.name.to_lowercase();
        in_scratch(&scratch, keep, |dir| work(&python, &script, dir))
    }

    /// Runs the translation script (`cmd`) and reads the runs it reports; the caller adds
    /// `brume:renderer`, which may depend on what the script printed.
    pub fn render(
        &self,
        run: &ReferenceRun,
        cmd: &mut Command,
    ) -> Result<(std::process::Output, Rendered)> {
        let renderer = self.name;
        let out = cmd
            .output()
            .with_context(|| format!("running {}", cmd.get_program().to_string_lossy()))?;
        if !out.status.success() {
            bail!(
                "{renderer} failed on {} ({}):\n{}",
                run.scene.display(),
                out.status,
                output_tail(&out, 20)
            );
        }
        let runs = read_runs(&String::from_utf8_lossy(&out.stdout), run.runs, renderer)?;
        let seconds: Vec<f64> = runs.iter().map(|r| r.seconds).collect();
        let paths: Vec<PathBuf> = runs.iter().map(|r| r.path.clone()).collect();
        let images: Vec<Image> = runs.into_iter().map(|r| r.image).collect();
        let total: f64 = seconds.iter().sum();
        let key = renderer.to_lowercase();
        let mut meta = Metadata::new();
        meta.set("brume:spp", AttrValue::Int((run.spp * run.runs) as i32))
            .set(format!("brume:{key}_runs"), AttrValue::Int(run.runs as i32))
            .set("brume:render_seconds", AttrValue::Double(total))
            .set(
                "brume:scene",
                AttrValue::Text(run.scene.display().to_string()),
            );
        let rendered = Rendered {
            images,
            paths,
            seconds,
            total,
            meta,
        };
        Ok((out, rendered))
    }
}

impl ReferenceRun {
    /// Merges the runs into `--output` with their merged `passes` as layers, prints `summary`
    /// and, with `--against`, the agreement with that Brume image.
    pub fn finish(
        &self,
        images: &[Image],
        passes: &[passes::PassImage],
        mut meta: Metadata,
        summary: &str,
    ) -> Result<()> {
        let (extra, names) = passes::pass_channels(passes);
        if !passes.is_empty() {
            meta.set(PASSES_ATTRIBUTE, AttrValue::Text(names));
        }
        let merged = merge_runs(images, self.spp, meta)?;
        write_image_with(&self.output, &merged, extra)?;
        eprintln!("{summary}");
        if let Some(brume_path) = &self.against {
            print_agreement(brume_path, &self.output)?;
        }
        Ok(())
    }
}

/// Prints the agreement of reference `output` with Brume render `against`: the beauty's, then
/// each light pass both hold ([`passes::compare_passes`]).
fn print_agreement(against: &Path, output: &Path) -> Result<()> {
    let (brume, reference) = (read_exr(against)?, read_exr(output)?);
    println!("{}", compare(&brume, &reference, 8, 0.001)?);
    let brume_passes = passes::read_passes(against, &brume.attributes)?;
    let reference_passes = passes::read_passes(output, &reference.attributes)?;
    for line in passes::compare_passes(&brume_passes, &reference_passes)? {
        println!("{line}");
    }
    Ok(())
}

/// Runs `work` in a scratch folder: `keep`, or `brume-NAME-PID` in the temporary folder, which
/// is removed afterwards whether the work succeeded or not (what it holds has been read back).
pub fn in_scratch<T>(
    name: &str,
    keep: Option<&Path>,
    work: impl FnOnce(&Path) -> Result<T>,
) -> Result<T> {
    let dir = match keep {
        Some(d) => d.to_path_buf(),
        None => std::env::temp_dir().join(format!("brume-{name}-{}", std::process::id())),
    };
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let result = work(&dir);
    if keep.is_none() {
        let _ = std::fs::remove_dir_all(&dir);
    }
    result
}

/// A translation script: `$env_var`, else `rel` in the working directory or the source tree.
pub fn find_script(env_var: &str, rel: &str) -> Result<PathBuf> {
    if let Some(p) = std::env::var_os(env_var) {
        return Ok(PathBuf::from(p));
    }
    let rel = Path::new(rel);
    [
        rel.to_path_buf(),
        Path::new(env!("CARGO_MANIFEST_DIR")).join(rel),
    ]
    .into_iter()
    .find(|p| p.is_file())
    .ok_or_else(|| anyhow!("{} not found", rel.display()))
}

/// The runs a script reported, in order; an error unless there are exactly `runs` of them.
/// `renderer` names the renderer in messages.
pub fn read_runs(stdout: &str, runs: u32, renderer: &str) -> Result<Vec<RunReport>> {
    let mut out = Vec::new();
    for line in stdout.lines() {
        let f: Vec<&str> = line.split_whitespace().collect();
        if f.len() == 4 && f[0] == "render_seconds" {
            let path = PathBuf::from(f[3]);
            let image = read_exr(&path)
                .with_context(|| format!("reading {renderer} output {}", path.display()))?;
            out.push(RunReport {
                seconds: f[2].parse::<f64>().unwrap_or(f64::NAN),
                image,
                path,
            });
        }
    }
    if out.len() != runs as usize {
        bail!(
            "expected {runs} {renderer} images, the script reported {}",
            out.len()
        );
    }
    Ok(out)
}

/// `s` seconds per run, as `1.23 4.56`.
pub fn seconds_list(seconds: &[f64]) -> String {
    seconds
        .iter()
        .map(|s| format!("{s:.2}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// The last `n` lines of a failed script's stdout and stderr, for the error message.
pub fn output_tail(out: &std::process::Output, n: usize) -> String {
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    let lines: Vec<&str> = stdout.lines().chain(stderr.lines()).collect();
    lines[lines.len().saturating_sub(n)..].join("\n")
}
