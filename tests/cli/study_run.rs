//! `brume study` end to end on the white furnace (scenes/furnace.gltf), whose exact image is
//! 1 everywhere: the reference has no noise of its own, so the measured RMSE is the render's
//! and must fall like t^(-1/2) for unbiased estimators.
use std::path::PathBuf;
use std::process::Command;

use brume::film::{write_image, Image, Metadata};
use brume::render::{Estimator, MajorantMode};
use brume::study::report::{loglog_slope, time_to_rmse};
use brume::study::run::{default_sweep, StudyConfig};
use brume::study::Checkpoint;

fn scene(name: &str) -> String {
    format!("{}/scenes/{name}", env!("CARGO_MANIFEST_DIR"))
}

fn out_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("brume-study-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn brume(args: &[&str], envs: &[(&str, &str)]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_brume"))
        .args(args)
        .envs(envs.iter().copied())
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn study_on_the_furnace_converges_at_the_monte_carlo_rate() {
    let dir = out_dir("furnace");
    let (w, h) = (32, 24);
    let ones = Image {
        width: w,
        height: h,
        rgb: vec![[1.0; 3]; w * h],
        alpha: None,
        variance: Some(vec![[0.0; 3]; w * h]),
        samples: None,
        attributes: Metadata::new(),
    };
    let reference = dir.join("ones.exr");
    write_image(&reference, &ones).unwrap();
    let (ok, out, err) = brume(
        &[
            "study",
            &scene("furnace.gltf"),
            "--out",
            dir.to_str().unwrap(),
            "--budget",
            "1.5",
            "--repeats",
            "3",
            "--reference",
            reference.to_str().unwrap(),
            "--config",
            "delta:local",
            "--config",
            "weighted-delta:b=1:global",
        ],
        &[],
    );
    assert!(ok, "{err}");
    assert!(out.contains("| delta adaptive |"), "{out}");
    for f in [
        "checkpoints.csv",
        "summary.md",
        "summary.json",
        "rmse_vs_time.png",
        "rmse_vs_time.svg",
        "efficiency.png",
        "efficiency.svg",
    ] {
        let p = dir.join(f);
        assert!(
            p.is_file() && std::fs::metadata(&p).unwrap().len() > 100,
            "{f}"
        );
    }
    let csv = std::fs::read_to_string(dir.join("checkpoints.csv")).unwrap();
    assert!(csv.starts_with("config,repeat,seed,spp,seconds,rmse,relmse,lookups"));
    // 2 configurations x 3 repeats, several passes each.
    assert!(csv.lines().count() > 2 * 3 * 5, "{csv}");
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    let configs = s["configs"].as_array().unwrap();
    assert_eq!(configs.len(), 2);
    for c in configs {
        let label = c["config"]["label"].as_str().unwrap();
        assert_eq!(c["repeats"], 3);
        // The error falls like t^(-1/2). Three repeats of one to two dozen passes each give
        // a slope standard error of a few hundredths; the bounds also absorb the per-sample
        // cost drifting as passes grow and the machine is shared.
        let slope = c["loglog_slope"].as_f64().unwrap();
        assert!((-0.8..=-0.25).contains(&slope), "{label}: slope {slope}");
        // Efficiency = 1 / (time x MSE), consistent with the other columns.
        let e = c["efficiency"].as_f64().unwrap();
        let tm = c["time_mse_mean"].as_f64().unwrap();
        assert!((e * tm - 1.0).abs() < 1e-9);
        assert!(c["rmse_mean"].as_f64().unwrap() < 0.1, "{label}");
    }
    let md = std::fs::read_to_string(dir.join("summary.md")).unwrap();
    assert!(md.contains("TTUV") && md.contains("independent of the"));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn rendered_reference_is_cached_and_plots_work_without_a_font() {
    let dir = out_dir("cache");
    let args = [
        "study",
        &scene("cloud.gltf"),
        "--out",
        dir.to_str().unwrap(),
        "--budget",
        "0.2",
        "--width",
        "24",
        "--height",
        "18",
        "--reference-spp",
        "32",
        "--config",
        "delta:local",
    ];
    let (ok, _, err) = brume(&args, &[("BRUME_FONT", "none")]);
    assert!(ok && err.contains("reference: rendering"), "{err}");
    let cached: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with("reference-cloud-") && n.ends_with("-24x18-32spp.exr"))
        .collect();
    assert_eq!(cached.len(), 1, "{cached:?}");
    let (ok, _, err) = brume(&args, &[("BRUME_FONT", "none")]);
    assert!(ok && err.contains("reference: cached"), "{err}");
    assert!(dir.join("rmse_vs_time.png").is_file() && dir.join("efficiency.png").is_file());

    // A reference of the wrong size and an unknown configuration are clear errors.
    let cached_path = dir.join(&cached[0]);
    let wrong = [
        &args[..4],
        &[
            "--width",
            "30",
            "--reference",
            cached_path.to_str().unwrap(),
        ],
    ]
    .concat();
    let (ok, _, err) = brume(&wrong, &[]);
    assert!(
        !ok && err.contains("24x18") && err.contains("30x18"),
        "{err}"
    );
    let (ok, _, err) = brume(
        &["study", &scene("cloud.gltf"), "--config", "fast-tracking"],
        &[],
    );
    assert!(!ok && err.contains("unknown estimator"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn default_sweep_and_config_syntax() {
    let sweep = default_sweep();
    // 10 global (4 b, 5 m, delta) + 6 per-leaf and 6 adaptive (4 b, one local-minorant
    // decomposition, delta).
    assert_eq!(sweep.len(), 22);
    let c = StudyConfig::parse("weighted-delta:b=0.75:leaf").unwrap();
    assert_eq!(
        (c.estimator, c.b, c.majorant),
        (Estimator::WeightedDelta, 0.75, MajorantMode::Leaf)
    );
    assert_eq!(c.label, "weighted-delta b=0.75 leaf");
    // "local" is the default mode's alias.
    let c = StudyConfig::parse("delta:local").unwrap();
    assert_eq!(
        (c.majorant, c.label.as_str()),
        (MajorantMode::Adaptive, "delta adaptive")
    );
    // m is unused with per-leaf majorants, b by analog estimators.
    assert_eq!(
        StudyConfig::parse("weighted-decomposition:m=0.03:local")
            .unwrap()
            .m,
        None
    );
    assert_eq!(
        StudyConfig::parse("delta:b=0.5").unwrap().label,
        "delta global"
    );
    assert!(StudyConfig::parse("weighted-delta:b=zero").is_err());
    assert!(StudyConfig::parse("weighted-delta:sideways").is_err());
}

fn cp(seconds: f64, rmse: f64) -> Checkpoint {
    Checkpoint {
        config: "x".into(),
        repeat: 0,
        seed: 0,
        spp: 1,
        seconds,
        rmse,
        relmse: 0.0,
        lookups: 0,
        samples: 0,
    }
}

#[test]
fn time_to_target_interpolates_in_log_log_and_slopes_fit() {
    // RMSE = t^(-1/2) exactly: reaching 0.5 takes exactly 4 s.
    let pts: Vec<Checkpoint> = [1.0, 2.0, 8.0, 16.0]
        .iter()
        .map(|&t: &f64| cp(t, t.powf(-0.5)))
        .collect();
    let refs: Vec<&Checkpoint> = pts.iter().collect();
    assert!((time_to_rmse(&refs, 0.5).unwrap() - 4.0).abs() < 1e-9);
    assert_eq!(time_to_rmse(&refs, 0.01), None);
    assert_eq!(time_to_rmse(&refs, 2.0), Some(1.0));
    let slope = loglog_slope(std::slice::from_ref(&refs), 0).unwrap();
    assert!((slope + 0.5).abs() < 1e-12);
}
