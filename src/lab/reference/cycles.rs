//! `brume cycles`: render a Brume scene with Blender Cycles (bpy, Blender as a Python module)
//! for comparison, and optionally compare the result with a Brume render.
//!
//! The scene translation lives in `tools/cycles/brume_to_cycles.py`; this command finds a
//! Python that can `import bpy`, runs the script for `--runs` independent seeds, and merges
//! them into one EXR laid out like Brume's (beauty, `variance.R/G/B` = variance of the pixel
//! mean estimated across the runs, `samples.Y`). With `--against brume.exr` it prints the image
//! mean relative difference and an 8x8 block z-test (docs/comparing.md).
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::Result;
use clap::Args;

use crate::film::{AttrValue, Metadata};

use super::{passes, seconds_list, Driver, PythonTool, ReferenceRun};

/// A Python with bpy: `BRUME_BPY_PYTHON`, then `tools/cycles/.venv` (next to the working
/// directory or the source tree), then `python3` on the PATH.
pub const BPY: PythonTool = PythonTool {
    var: "BRUME_BPY_PYTHON",
    venv: "tools/cycles/.venv/bin/python",
    module: "bpy",
    path_python: true,
    hint: "no Python with bpy found: run tools/cycles/ci.sh (Python 3.11 venv tools/cycles/.venv \
           with `pip install bpy==5.0.1`), or set BRUME_BPY_PYTHON to a python that can `import \
           bpy`",
};

#[derive(Args, Debug)]
pub struct CyclesArgs {
    #[command(flatten)]
    pub run: ReferenceRun,
    /// Also save the Blender scene built from the glTF (.blend), for inspection.
    #[arg(long)]
    pub save_blend: Option<PathBuf>,
    /// opaque or transparent, as `brume render --film` (Cycles' Film > Transparent; default:
    /// the scene's BRUME_render filmTransparent, else opaque).
    #[arg(long, value_parser = ["opaque", "transparent"])]
    pub film: Option<String>,
    /// light: also render Cycles' light passes, written as Brume's (`emission`, `background`,
    /// `volume.direct`, ...; docs/comparing.md) with their variance; `--against` then compares
    /// each with the Brume render's (`brume render --passes light`).
    #[arg(long, value_parser = ["beauty", "light"], default_value = "beauty")]
    pub passes: String,
}

/// Cycles through Blender's Python module.
const DRIVER: Driver = Driver {
    name: "Cycles",
    python: BPY,
    script_var: "BRUME_CYCLES_SCRIPT",
    script: "tools/cycles/brume_to_cycles.py",
};

pub fn run(args: &CyclesArgs) -> Result<()> {
    // The per-run images are read back into the merged output.
    DRIVER.run(&args.run, None, |python, script, tmp| {
        render_in(args, python, script, tmp)
    })
}

/// Runs Cycles with its per-run images in `tmp`, merges them into the output and reports.
fn render_in(args: &CyclesArgs, python: &Path, script: &Path, tmp: &Path) -> Result<()> {
    let stem = tmp.join("cycles.exr");
    let mut cmd = Command::new(python);
    cmd.arg(script)
        .arg(&args.run.scene)
        .arg("-o")
        .arg(&stem)
        .args(["--spp", &args.run.spp.to_string()])
        .args(["--width", &args.run.width.to_string()])
        .args(["--height", &args.run.height.to_string()])
        .args(["--seed", &args.run.seed.to_string()])
        .args(["--runs", &args.run.runs.to_string()]);
    // Without one, the script takes the scene's own depth as `brume render` does.
    if let Some(d) = args.run.max_depth {
        cmd.args(["--max-depth", &d.to_string()]);
    }
    if let Some(t) = args.run.threads {
        cmd.args(["--threads", &t.to_string()]);
    }
    if let Some(f) = &args.film {
        cmd.args(["--film", f]);
    }
    if args.passes == "light" {
        cmd.args(["--passes", "light"]);
    }
    if let Some(b) = &args.save_blend {
        cmd.arg("--save-blend").arg(b);
    }
    let started = Instant::now();
    let (_, r) = DRIVER.render(&args.run, &mut cmd)?;
    let mut meta = r.meta;
    meta.set("brume:renderer", AttrValue::Text("cycles (bpy 5.0)".into()));
    if let Some(t) = r
        .images
        .iter()
        .map(|i| CyclesTimes::from_metadata(&i.attributes))
        .collect::<Option<Vec<_>>>()
    {
        let sum = |f: fn(&CyclesTimes) -> f64| t.iter().map(f).sum::<f64>();
        meta.set("brume:seconds", AttrValue::Double(sum(|t| t.total)))
            .set(
                "brume:cycles_setup_seconds",
                AttrValue::Double(sum(|t| t.total - t.render)),
            )
            .set(
                "brume:cycles_path_tracing_seconds",
                AttrValue::Double(sum(|t| t.render)),
            )
            .set(
                "brume:cycles_sync_seconds",
                AttrValue::Double(sum(|t| t.sync)),
            );
    }
    let summary = format!(
        "cycles: {} run(s) x {} spp, {}x{}, render {:.2} s (per run {}), wall {:.2} s",
        args.run.runs,
        args.run.spp,
        args.run.width,
        args.run.height,
        r.total,
        seconds_list(&r.seconds),
        started.elapsed().as_secs_f64()
    );
    let passes = if args.passes == "light" {
        let runs = r
            .paths
            .iter()
            .map(|p| passes::cycles_light_passes(p))
            .collect::<Result<Vec<_>>>()?;
        let size = (args.run.width as usize, args.run.height as usize);
        passes::merge_pass_runs(&runs, size, args.run.spp)?
    } else {
        Vec::new()
    };
    args.run.finish(&r.images, &passes, meta, &summary)
}

/// The timings Cycles writes into each render's EXR (`cycles.<view layer>.total_time`,
/// `render_time`, `synchronization_time`, as `[HH:]MM:SS.cc`), in seconds. `total` runs from
/// the start of the render session: scene and device update (BVH, volume octree, images) and
/// then path tracing (`render`); `sync` is Blender's conversion of its data to Cycles, timed
/// separately.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CyclesTimes {
    pub total: f64,
    pub render: f64,
    pub sync: f64,
}

impl CyclesTimes {
    pub fn from_metadata(meta: &Metadata) -> Option<Self> {
        let field = |name: &str| {
            meta.iter()
                .find(|(k, _)| k.starts_with("cycles.") && k.ends_with(name))
                .and_then(|(_, v)| match v {
                    AttrValue::Text(t) => parse_cycles_time(t),
                    _ => None,
                })
        };
        Some(CyclesTimes {
            total: field(".total_time")?,
            render: field(".render_time")?,
            sync: field(".synchronization_time").unwrap_or(0.0),
        })
    }
}

/// Blender's `[[HH:]MM:]SS.ff` time stamps in seconds.
pub fn parse_cycles_time(t: &str) -> Option<f64> {
    t.trim().split(':').try_fold(0.0, |acc, part| {
        Some(acc * 60.0 + part.parse::<f64>().ok()?)
    })
}
