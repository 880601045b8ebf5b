//! `brume farm slurm`: one image as a Slurm job array (one sample range per task, each with
//! checkpoints and resume, so a requeued or preempted task continues) and a merge job that
//! runs only when every task succeeded (`afterok`, with `--kill-on-invalid-dep=yes` so a
//! failed task cancels it instead of leaving it pending forever).
//!
//! The scripts are plain sbatch files in a work folder; `--submit` runs them, `--wait`
//! follows the jobs with `scontrol -o show job` (sacct needs slurmdbd, which many clusters
//! and the test cluster do not run; `sbatch --wait` exits 0 even when the dependent job was
//! cancelled) and, when a task fails, says which and prints the commands that resubmit it
//! alone and then merge.
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use clap::{Args, Subcommand};

use crate::scene::sequence;

#[derive(Subcommand, Debug)]
pub enum FarmWhich {
    /// Write (and with --submit, submit) a Slurm job array and its merge job.
    Slurm(SlurmArgs),
}

#[derive(Args, Debug)]
pub struct SlurmArgs {
    /// The scene (.gltf or .glb); every task must see it at this path.
    pub scene: PathBuf,
    /// The merged image.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Samples per pixel of the final image.
    #[arg(long)]
    pub spp: u32,
    /// Number of array tasks (per frame); task i renders samples [i N / K, (i + 1) N / K).
    #[arg(long)]
    pub tasks: u32,
    /// Frames A..B (both included) of a sequence: --tasks array tasks per frame, and one merged
    /// image per frame, at --output with its run of `#` replaced by the frame. `scene`: the
    /// scene's BRUME_render frameRange.
    #[arg(long, value_name = "A..B", value_parser = crate::scene::sequence::FrameChoice::parse, allow_hyphen_values = true)]
    pub frames: Option<sequence::FrameChoice>,
    /// Slurm partition (default: the cluster's default).
    #[arg(long)]
    pub partition: Option<String>,
    /// Time limit of each task (Slurm's format, e.g. 2:00:00).
    #[arg(long)]
    pub time: Option<String>,
    /// CPUs per task; each task's render uses exactly these threads.
    #[arg(long, default_value_t = 1)]
    pub cpus_per_task: u32,
    /// Seconds between checkpoints of each task's part.
    #[arg(long, default_value_t = 300.0)]
    pub checkpoint: f64,
    /// Work folder for scripts, parts and logs (default: OUTPUT without .exr, plus .farm).
    #[arg(long)]
    pub dir: Option<PathBuf>,
    /// Submit with sbatch (else only write the scripts and print how to submit them).
    #[arg(long)]
    pub submit: bool,
    /// With --submit: wait for the merge, then report (failed tasks and how to resubmit).
    #[arg(long, requires = "submit")]
    pub wait: bool,
    /// Seconds --wait waits at most.
    #[arg(long, default_value_t = 86400.0)]
    pub wait_timeout: f64,
    /// Further `brume render` options for every task (after `--`), e.g. -- --width 2048.
    #[arg(last = true)]
    pub render_args: Vec<String>,
}

pub fn run(which: &FarmWhich) -> Result<()> {
    match which {
        FarmWhich::Slurm(args) => slurm(args),
    }
}

/// Single-quotes a word for bash.
fn quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', r"'\''"))
}

fn absolute(p: &Path) -> Result<PathBuf> {
    Ok(if p.is_absolute() {
        p.to_path_buf()
    } else {
        std::env::current_dir()?.join(p)
    })
}

/// Sample ranges of `tasks` contiguous parts of `[0, spp)`.
pub fn task_ranges(spp: u32, tasks: u32) -> Vec<(u32, u32)> {
    (0..tasks as u64)
        .map(|i| {
            let a = i * spp as u64 / tasks as u64;
            let b = (i + 1) * spp as u64 / tasks as u64;
            (a as u32, b as u32)
        })
        .collect()
}

/// The files `brume farm slurm` writes.
struct FarmFiles {
    dir: PathBuf,
    render: PathBuf,
    merge: PathBuf,
}

/// What both scripts are written from: the checked arguments, made absolute.
struct Plan<'a> {
    args: &'a SlurmArgs,
    scene: PathBuf,
    output: PathBuf,
    dir: PathBuf,
    brume: PathBuf,
    /// The frames of a sequence; empty without --frames.
    frames: Vec<i32>,
    /// `#!/bin/bash` and the #SBATCH lines both jobs share.
    header: String,
}

impl<'a> Plan<'a> {
    /// Checks the arguments (and, with --frames, every frame's files) and makes paths absolute.
    fn new(args: &'a SlurmArgs) -> Result<Self> {
        if args.tasks == 0 || args.spp == 0 {
            bail!("--tasks and --spp must be at least 1");
        }
        if args.tasks > args.spp {
            bail!(
                "--tasks {} is more than --spp {}: some tasks would render nothing",
                args.tasks,
                args.spp
            );
        }
        if args.cpus_per_task == 0 {
            bail!("--cpus-per-task must be at least 1");
        }
        let adaptive = args
            .render_args
            .iter()
            .any(|a| a == "--noise-threshold" || a.starts_with("--noise-threshold="));
        if adaptive && args.tasks > 1 {
            bail!(
                "--noise-threshold with --tasks {}: the tasks split the samples, and a task \
                 starting after sample 0 cannot know which pixels the samples before it stopped; \
                 use --tasks 1 (one task a frame)",
                args.tasks
            );
        }
        if !(args.checkpoint > 0.0 && args.checkpoint.is_finite()) {
            bail!("--checkpoint must be a positive number of seconds");
        }
        let scene = absolute(&args.scene)?;
        if !scene.is_file() {
            bail!("{}: no such scene file", scene.display());
        }
        let output = absolute(&args.output)?;
        let range = args.frames.map(|f| f.resolve(&scene)).transpose()?;
        let frames: Vec<i32> = range.map_or(Vec::new(), |(a, b)| (a..=b).collect());
        if let Some((a, b)) = range {
            let name = output
                .file_name()
                .and_then(|n| n.to_str())
                .unwrap_or_default();
            if b > a && !sequence::is_sequence(name) {
                bail!(
                    "--frames {a}..{b} merges {} images: put a run of # for the frame number \
                     in {} (such as out_####.exr)",
                    frames.len(),
                    output.display()
                );
            }
            sequence::check_files(&scene, a, b)?;
        }
        let dir = match &args.dir {
            Some(d) => absolute(d)?,
            None => output.with_extension("farm"),
        };
        let mut header = String::from("#!/bin/bash\n");
        if let Some(p) = &args.partition {
            header += &format!("#SBATCH --partition={p}\n");
        }
        if let Some(t) = &args.time {
            header += &format!("#SBATCH --time={t}\n");
        }
        Ok(Plan {
            args,
            scene,
            output,
            dir,
            brume: std::env::current_exe().context("finding the brume executable")?,
            frames,
            header,
        })
    }

    /// Each frame to merge: `None` for the one image without --frames.
    fn frame_list(&self) -> Vec<Option<i32>> {
        match self.frames.is_empty() {
            true => vec![None],
            false => self.frames.iter().map(|&f| Some(f)).collect(),
        }
    }

    /// The part that sample range `r` of `frame` renders into.
    fn part(&self, frame: Option<i32>, r: u32) -> PathBuf {
        let parts = self.dir.join("parts");
        match frame {
            None => parts.join(format!("part-{r}.exr")),
            Some(f) => parts.join(format!("frame-{f}-part-{r}.exr")),
        }
    }

    /// The array job: task i renders sample range i % tasks of frame i / tasks.
    fn render_script(&self) -> String {
        let args = self.args;
        let tasks = args.tasks;
        let (frame_lines, frame_arg, part_name, frame_note) = if self.frames.is_empty() {
            (String::new(), "", r#"part-"$r".exr"#, "")
        } else {
            let list: Vec<String> = self.frames.iter().map(|f| f.to_string()).collect();
            (
                format!(
                    "FRAMES=({})\nf=\"${{FRAMES[$((i / {tasks}))]}}\"\n",
                    list.join(" ")
                ),
                r#" --frame "$f""#,
                r#"frame-"$f"-part-"$r".exr"#,
                ", frame $f",
            )
        };
        let ranges: Vec<String> = task_ranges(args.spp, tasks)
            .iter()
            .map(|(a, b)| format!("{a}..{b}"))
            .collect();
        let extra: Vec<String> = args.render_args.iter().map(|a| quote(a)).collect();
        format!(
            r#"{header}#SBATCH --job-name=brume-render
#SBATCH --array=0-{last}
#SBATCH --cpus-per-task={cpus}
#SBATCH --output={logs_raw}/task-%a.log
#SBATCH --requeue
# Written by `brume farm slurm`: task i renders sample range RANGES[i % {tasks}] of every pixel
# (of frame FRAMES[i / {tasks}] of a sequence) into its own part, checkpointing every {ckpt} s
# and on SIGTERM; a requeued or resubmitted task resumes its part. Brume sizes its thread pool
# from SLURM_CPUS_PER_TASK.
set -euo pipefail
RANGES=({ranges})
i="$SLURM_ARRAY_TASK_ID"
r=$((i % {tasks}))
{frame_lines}part={parts}/{part_name}
resume=()
if [ -f "$part" ]; then resume=(--resume "$part"); fi
echo "brume farm: task $i, samples ${{RANGES[$r]}}{frame_note}, $SLURM_CPUS_PER_TASK CPUs on $(hostname)"
exec {brume} render {scene} -o "$part" --samples "${{RANGES[$r]}}"{frame_arg} --checkpoint {ckpt} --backend cpu "${{resume[@]}}" {extra}
"#,
            header = self.header,
            last = self.frame_list().len() as u32 * tasks - 1,
            // sbatch reads #SBATCH lines without a shell: no quotes there.
            logs_raw = self.dir.join("logs").display(),
            cpus = args.cpus_per_task,
            ckpt = args.checkpoint,
            ranges = ranges.join(" "),
            parts = quote(&self.dir.join("parts").display().to_string()),
            brume = quote(&self.brume.display().to_string()),
            scene = quote(&self.scene.display().to_string()),
            extra = extra.join(" "),
        )
    }

    /// The merge job: one `brume merge` per frame.
    fn merge_script(&self) -> String {
        let merges: Vec<String> = self
            .frame_list()
            .into_iter()
            .map(|frame| {
                let parts: Vec<String> = (0..self.args.tasks)
                    .map(|r| quote(&self.part(frame, r).display().to_string()))
                    .collect();
                let out = frame.map_or(self.output.clone(), |f| {
                    sequence::path_for_frame(&self.output, f)
                });
                format!(
                    "{} merge {} -o {} --spp {}\n",
                    quote(&self.brume.display().to_string()),
                    parts.join(" "),
                    quote(&out.display().to_string()),
                    self.args.spp
                )
            })
            .collect();
        format!(
            r#"{header}#SBATCH --job-name=brume-merge
#SBATCH --cpus-per-task=1
#SBATCH --output={logs_raw}/merge.log
# Written by `brume farm slurm`: submit with --dependency=afterok:<array job>
# --kill-on-invalid-dep=yes, so it runs only when every task succeeded.
set -euo pipefail
{merges}"#,
            header = self.header,
            logs_raw = self.dir.join("logs").display(),
            merges = merges.concat(),
        )
    }
}

fn write_scripts(args: &SlurmArgs) -> Result<FarmFiles> {
    let plan = Plan::new(args)?;
    let dir = plan.dir.clone();
    std::fs::create_dir_all(dir.join("parts"))
        .and_then(|_| std::fs::create_dir_all(dir.join("logs")))
        .with_context(|| format!("creating {}", dir.display()))?;
    let files = FarmFiles {
        render: dir.join("render.sbatch"),
        merge: dir.join("merge.sbatch"),
        dir,
    };
    for (path, text) in [
        (&files.render, plan.render_script()),
        (&files.merge, plan.merge_script()),
    ] {
        crate::film::write_atomically(path, |f| {
            use std::io::Write;
            f.write_all(text.as_bytes())
                .map_err(|e| crate::film::FilmError::Io {
                    action: "write",
                    path: path.clone(),
                    source: e,
                })
        })?;
    }
    Ok(files)
}

/// `sbatch --parsable ARGS`, returning the job id.
fn sbatch(args: &[&str]) -> Result<String> {
    let out = Command::new("sbatch")
        .arg("--parsable")
        .args(args)
        .output()
        .context("running sbatch (is Slurm installed and SLURM_CONF set?)")?;
    if !out.status.success() {
        bail!(
            "sbatch {} failed: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    let text = String::from_utf8_lossy(&out.stdout);
    // --parsable prints "jobid" or "jobid;cluster".
    Ok(text.trim().split(';').next().unwrap_or("").to_string())
}

/// One line of `scontrol -o show job`: the fields a farm needs.
#[derive(Debug, Clone, PartialEq)]
pub struct JobLine {
    pub job_id: String,
    pub array_task: Option<String>,
    pub state: String,
    pub exit_code: String,
    pub reason: String,
}

/// Parses `scontrol -o show job` output (one job or array task per line, `Key=Value` words).
pub fn parse_scontrol(text: &str) -> Vec<JobLine> {
    text.lines()
        .filter(|l| l.contains("JobId="))
        .map(|l| {
            let field = |k: &str| {
                l.split_whitespace()
                    .find_map(|w| w.strip_prefix(k).and_then(|r| r.strip_prefix('=')))
                    .map(str::to_string)
            };
            JobLine {
                job_id: field("JobId").unwrap_or_default(),
                array_task: field("ArrayTaskId"),
                state: field("JobState").unwrap_or_default(),
                exit_code: field("ExitCode").unwrap_or_default(),
                reason: field("Reason").unwrap_or_default(),
            }
        })
        .collect()
}

fn show_job(id: &str) -> Result<Vec<JobLine>> {
    let out = Command::new("scontrol")
        .args(["-o", "show", "job", id])
        .output()
        .context("running scontrol")?;
    if !out.status.success() {
        bail!(
            "scontrol -o show job {id}: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    Ok(parse_scontrol(&String::from_utf8_lossy(&out.stdout)))
}

/// Whether a job state is final (a requeued task goes back to PENDING, so it is not).
fn is_final(state: &str) -> bool {
    matches!(
        state,
        "COMPLETED"
            | "FAILED"
            | "CANCELLED"
            | "TIMEOUT"
            | "NODE_FAIL"
            | "OUT_OF_MEMORY"
            | "BOOT_FAIL"
            | "DEADLINE"
    )
}

fn slurm(args: &SlurmArgs) -> Result<()> {
    let files = write_scripts(args)?;
    let render = files.render.display().to_string();
    let merge = files.merge.display().to_string();
    let frames = match args.frames {
        Some(f) => {
            let (a, b) = f.resolve(&args.scene)?;
            (b - a + 1) as u32
        }
        None => 1,
    };
    let tasks = frames * args.tasks;
    println!(
        "wrote {} ({tasks} tasks, {} CPUs each) and {}",
        render, args.cpus_per_task, merge
    );
    if !args.submit {
        println!("submit with:");
        println!(
            "  A=$(sbatch --parsable {}) && sbatch --dependency=afterok:$A --kill-on-invalid-dep=yes {}",
            quote(&render),
            quote(&merge)
        );
        return Ok(());
    }
    let t0 = Instant::now();
    let array = sbatch(&[&render])?;
    let dep = format!("--dependency=afterok:{array}");
    let merge_job = sbatch(&[&dep, "--kill-on-invalid-dep=yes", &merge])?;
    println!("submitted: array job {array} ({tasks} tasks), merge job {merge_job}");
    std::fs::write(
        files.dir.join("jobs.txt"),
        format!("array {array}\nmerge {merge_job}\n"),
    )
    .with_context(|| format!("writing {}", files.dir.join("jobs.txt").display()))?;
    if !args.wait {
        return Ok(());
    }
    let deadline = Duration::from_secs_f64(args.wait_timeout);
    let merge_state = loop {
        let m = show_job(&merge_job)?;
        let state = m.first().map(|j| j.state.clone()).unwrap_or_default();
        if is_final(&state) {
            break state;
        }
        if t0.elapsed() > deadline {
            bail!(
                "merge job {merge_job} still {state} after {:.0} s; jobs keep running",
                t0.elapsed().as_secs_f64()
            );
        }
        std::thread::sleep(Duration::from_millis(500));
    };
    if merge_state == "COMPLETED" {
        println!(
            "merged: {} ({frames} frame(s)) from {tasks} tasks; time from sbatch to merged EXR \
             {:.1} s",
            absolute(&args.output)?.display(),
            t0.elapsed().as_secs_f64()
        );
        return Ok(());
    }
    // Which tasks did not complete (once every task has ended), and how to finish the image.
    let tasks = loop {
        let tasks = show_job(&array)?;
        if tasks.iter().all(|t| is_final(&t.state)) || t0.elapsed() > deadline {
            break tasks;
        }
        std::thread::sleep(Duration::from_millis(500));
    };
    let failed: Vec<&JobLine> = tasks
        .iter()
        .filter(|t| t.state != "COMPLETED" && t.array_task.is_some())
        .collect();
    let mut msg = format!("the merge job {merge_job} ended {merge_state}; array job {array}:\n",);
    for t in &failed {
        let id = t.array_task.as_deref().unwrap_or("?");
        msg += &format!(
            "  task {id} {} (exit code {}, reason {}), log {}\n",
            t.state,
            t.exit_code,
            t.reason,
            files
                .dir
                .join("logs")
                .join(format!("task-{id}.log"))
                .display()
        );
    }
    let ids: Vec<&str> = failed
        .iter()
        .filter_map(|t| t.array_task.as_deref())
        .collect();
    msg += &format!(
        "resubmit the failed task(s) alone (each resumes its part), then merge:\n  \
         A=$(sbatch --parsable --array={} {}) && sbatch --dependency=afterok:$A --kill-on-invalid-dep=yes {}",
        ids.join(","),
        quote(&render),
        quote(&merge)
    );
    Err(anyhow!(msg))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_cover_the_samples_and_scontrol_lines_parse() {
        for (spp, k) in [(16, 4), (10, 3), (7, 7), (4096, 256)] {
            let r = task_ranges(spp, k);
            assert_eq!(r.len(), k as usize);
            assert_eq!(r[0].0, 0);
            assert_eq!(r.last().unwrap().1, spp);
            assert!(r.windows(2).all(|w| w[0].1 == w[1].0 && w[0].0 < w[0].1));
        }
        let text = "JobId=5 ArrayJobId=1 ArrayTaskId=2 JobName=x JobState=FAILED Reason=NonZeroExitCode Dependency=(null) ExitCode=1:0\n\
                    JobId=1 ArrayJobId=1 ArrayTaskId=3 JobState=COMPLETED Reason=None ExitCode=0:0\n";
        let j = parse_scontrol(text);
        assert_eq!(j.len(), 2);
        assert_eq!(j[0].array_task.as_deref(), Some("2"));
        assert_eq!(j[0].state, "FAILED");
        assert_eq!(j[0].exit_code, "1:0");
        assert_eq!(j[1].job_id, "1");
        assert_eq!(quote("a'b"), r"'a'\''b'");
    }
}
