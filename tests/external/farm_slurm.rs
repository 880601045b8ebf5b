//! `brume farm slurm --submit` on a real single-node Slurm cluster (tools/slurm/cluster.sh:
//! Debian's slurm-wlm and munge, daemons started directly, stopped by PID when the test ends):
//! a 4-task array and its merge job produce the image a single process renders (to the last
//! rounding of the summation order, as tests/cli/farm_parts.rs defines it); each task's log shows
//! the threads of its SLURM_CPUS_PER_TASK; a task made to fail leaves the merge cancelled,
//! `brume farm` names it and prints the resubmit command, and running that command completes
//! the image; a 24-frame sequence (`--frames`) merges each frame to its `brume render --frames`
//! image. Prints `SKIPPED:` and why when Slurm cannot be installed or started.
use crate::common;
use crate::common::external::say;
use common::farm::assert_rounding_equal;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

use brume::farm::read_part;

const TASKS: u32 = 4;

/// The cluster, stopped (by the PIDs its start recorded) when dropped.
struct Cluster {
    dir: PathBuf,
    env: Vec<(String, String)>,
}

impl Cluster {
    fn script() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tools/slurm/cluster.sh")
    }

    fn start() -> Result<Cluster, String> {
        let dir = std::env::temp_dir().join(format!("brume-slurm-test-{}", std::process::id()));
        // Ports of our own, so a cluster someone runs on the default ports is left alone.
        let base = 20000 + (std::process::id() % 20000) as u16 * 2;
        let env = vec![
            ("BRUME_SLURM_DIR".to_string(), dir.display().to_string()),
            ("BRUME_SLURM_CTLD_PORT".to_string(), base.to_string()),
            ("BRUME_SLURMD_PORT".to_string(), (base + 1).to_string()),
        ];
        let o = Command::new("bash")
            .arg(Self::script())
            .arg("start")
            .envs(env.iter().cloned())
            .output()
            .map_err(|e| format!("cannot run tools/slurm/cluster.sh: {e}"))?;
        let cluster = Cluster { dir, env };
        if !o.status.success() {
            return Err(format!(
                "tools/slurm/cluster.sh start failed: {}",
                String::from_utf8_lossy(&o.stderr).trim()
            ));
        }
        Ok(cluster)
    }

    fn conf(&self) -> PathBuf {
        self.dir.join("slurm.conf")
    }

    fn command(&self, program: &str) -> Command {
        let mut c = Command::new(program);
        c.env("SLURM_CONF", self.conf())
            .env_remove("SLURM_CPUS_PER_TASK");
        c
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = Command::new("bash")
            .arg(Self::script())
            .arg("stop")
            .envs(self.env.iter().cloned())
            .status();
        // Logs stay for a failed test to be read; a passing one leaves nothing behind.
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.dir);
        }
    }
}

fn text(o: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

fn farm(cluster: &Cluster, out: &Path, dir: &Path) -> Output {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cloud.gltf");
    cluster
        .command(env!("CARGO_BIN_EXE_brume"))
        .args(["farm", "slurm", scene.to_str().unwrap(), "-o"])
        .arg(out)
        .args(["--spp", "16", "--tasks", &TASKS.to_string()])
        .args(["--cpus-per-task", "1", "--checkpoint", "1"])
        .arg("--dir")
        .arg(dir)
        .args(["--submit", "--wait", "--wait-timeout", "300"])
        .args(["--", "--width", "48", "--height", "32"])
        .output()
        .unwrap()
}

fn job_state(cluster: &Cluster, id: &str) -> String {
    let o = cluster
        .command("scontrol")
        .args(["-o", "show", "job", id])
        .output()
        .unwrap();
    let t = String::from_utf8_lossy(&o.stdout).into_owned();
    t.split_whitespace()
        .find_map(|w| w.strip_prefix("JobState="))
        .unwrap_or("UNKNOWN")
        .to_string()
}

#[test]
fn a_job_array_renders_the_single_process_image_and_a_failed_task_is_resubmitted() {
    let cluster = match Cluster::start() {
        Ok(c) => c,
        Err(why) => {
            say(&format!("SKIPPED: farm_slurm: {why}"));
            return;
        }
    };
    let work = cluster.dir.join("work");
    std::fs::create_dir_all(&work).unwrap();

    // The reference: one process, same settings.
    let single = work.join("single.exr");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cloud.gltf");
    let o = Command::new(env!("CARGO_BIN_EXE_brume"))
        .args(["render", scene.to_str().unwrap(), "-o"])
        .arg(&single)
        .args([
            "--spp",
            "16",
            "--width",
            "48",
            "--height",
            "32",
            "--backend",
            "cpu",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o).1);
    let single = read_part(&single).unwrap();

    // 1. The array and its merge.
    let final_exr = work.join("final.exr");
    let o = farm(&cluster, &final_exr, &work.join("ok.farm"));
    let (out, err) = text(&o);
    assert!(o.status.success(), "brume farm slurm: {out}\n{err}");
    let line = out
        .lines()
        .find(|l| l.starts_with("merged:"))
        .expect("a merged: line");
    say(&format!("farm_slurm: {TASKS} tasks; {line}"));
    let merged = read_part(&final_exr).unwrap();
    assert_rounding_equal(&merged.film, &single.film, "slurm 4 tasks");
    assert_eq!(merged.info.parts, TASKS);
    for i in 0..TASKS {
        let log = work.join(format!("ok.farm/logs/task-{i}.log"));
        let log = std::fs::read_to_string(&log).unwrap();
        assert!(
            log.contains("threads: 1 (from SLURM_CPUS_PER_TASK)"),
            "task {i} log:\n{log}"
        );
        say(&format!(
            "farm_slurm: task {i}: {}",
            log.lines().find(|l| l.starts_with("threads:")).unwrap()
        ));
    }

    // 2. A task that fails: its part path is taken by a folder, so its render cannot write.
    let dir = work.join("fail.farm");
    std::fs::create_dir_all(dir.join("parts/part-2.exr")).unwrap();
    let final2 = work.join("final2.exr");
    let t0 = Instant::now();
    let o = farm(&cluster, &final2, &dir);
    let (out, err) = text(&o);
    say(&format!(
        "farm_slurm: failing run reported: {}",
        format!("{out}{err}").trim()
    ));
    assert!(!o.status.success(), "a failed task went unnoticed");
    assert!(err.contains("task 2 FAILED"), "{err}");
    assert!(!final2.exists());
    let jobs = std::fs::read_to_string(dir.join("jobs.txt")).unwrap();
    let merge_job = jobs
        .lines()
        .find_map(|l| l.strip_prefix("merge "))
        .unwrap()
        .to_string();
    assert_eq!(job_state(&cluster, &merge_job), "CANCELLED");
    let resubmit = err
        .lines()
        .map(str::trim)
        .find(|l| l.starts_with("A=$(sbatch"))
        .expect("a resubmit command");
    assert!(resubmit.contains("--array=2 "), "{resubmit}");

    // 3. Fix the cause, run the printed command, wait for its merge.
    std::fs::remove_dir(dir.join("parts/part-2.exr")).unwrap();
    let o = cluster
        .command("bash")
        .args(["-c", resubmit])
        .output()
        .unwrap();
    let (out, err) = text(&o);
    assert!(o.status.success(), "{out}{err}");
    let new_merge = out
        .split_whitespace()
        .last()
        .expect("sbatch prints the job id")
        .to_string();
    let state = loop {
        let s = job_state(&cluster, &new_merge);
        if ["COMPLETED", "FAILED", "CANCELLED", "TIMEOUT"].contains(&s.as_str()) {
            break s;
        }
        assert!(t0.elapsed() < Duration::from_secs(300), "merge job {s}");
        std::thread::sleep(Duration::from_millis(300));
    };
    assert_eq!(state, "COMPLETED");
    let merged2 = read_part(&final2).unwrap();
    assert_rounding_equal(&merged2.film, &single.film, "slurm after resubmit");
    say(&format!(
        "farm_slurm: the array with a failing task 2, its resubmit alone and the merge: {:.1} s",
        t0.elapsed().as_secs_f64()
    ));

    // 4. A 24-frame sequence: one task per frame, one merge per frame, each frame equal to
    // that frame of `brume render --frames`.
    sequence_on_the_farm(&cluster, &work.join("sequence"));
}

const FRAMES: i32 = 24;

fn sequence_on_the_farm(cluster: &Cluster, dir: &Path) {
    let scene = common::sequence::cloud_sequence(dir, 1..=FRAMES);
    let size = ["--spp", "2", "--width", "16", "--height", "12"];
    let o = Command::new(env!("CARGO_BIN_EXE_brume"))
        .args(["render", scene.to_str().unwrap(), "-o"])
        .arg(dir.join("single_####.exr"))
        .args(["--frames", "1..24", "--backend", "cpu"])
        .args(size)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o).1);
    let t0 = Instant::now();
    let o = cluster
        .command(env!("CARGO_BIN_EXE_brume"))
        .args(["farm", "slurm", scene.to_str().unwrap(), "-o"])
        .arg(dir.join("farm_####.exr"))
        .args(["--spp", "2", "--tasks", "1", "--frames", "1..24"])
        .args(["--cpus-per-task", "1", "--checkpoint", "60"])
        .args(["--submit", "--wait", "--wait-timeout", "300"])
        .args(["--", "--width", "16", "--height", "12"])
        .output()
        .unwrap();
    let (out, err) = text(&o);
    assert!(
        o.status.success(),
        "brume farm slurm --frames: {out}\n{err}"
    );
    for f in 1..=FRAMES {
        let farm = read_part(&dir.join(format!("farm_{f:04}.exr"))).unwrap();
        let single = read_part(&dir.join(format!("single_{f:04}.exr"))).unwrap();
        assert_rounding_equal(&farm.film, &single.film, &format!("frame {f}"));
    }
    say(&format!(
        "farm_slurm: {FRAMES} frames, 1 task each, every frame equal to its --frames render: \
         {:.1} s from sbatch to the last merge",
        t0.elapsed().as_secs_f64()
    ));
}
