//! `brume study` end to end: on the white furnace (scenes/furnace.gltf), whose exact image is
//! 1 everywhere, the reference has no noise of its own, so the measured RMSE is the render's
//! and must fall like t^(-1/2) for unbiased estimators; on the plume under a sky, fixed
//! against adaptive sampling.
use std::path::PathBuf;
use std::process::Command;

use brume::film::{read_exr, write_image, Image, Metadata};
use brume::render::{Estimator, MajorantMode, RenderScene, RenderSettings};
use brume::study::report::{loglog_slope, read_csv, time_to_rmse};
use brume::study::run::{default_sweep, StudyConfig};
use brume::study::{render_config, AdaptiveSampling, Checkpoint};

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

    // Adaptive sampling: `noise=E`, `min-spp=N` defaulting to `brume render`'s.
    let c = StudyConfig::parse("delta:leaf:noise=0.02").unwrap();
    assert_eq!(c.label, "delta leaf noise=0.02");
    let a = c.adaptive_sampling.unwrap();
    assert_eq!(a, AdaptiveSampling::new(0.02));
    assert_eq!(a.min_spp, RenderSettings::default().min_spp);
    let settings = c.settings(&RenderSettings::default());
    assert_eq!(
        (settings.noise_threshold, settings.min_spp),
        (Some(0.02), a.min_spp)
    );
    let c = StudyConfig::parse("weighted-delta:noise=0.01:min-spp=8:b=0.5:local").unwrap();
    assert_eq!(
        c.label,
        "weighted-delta b=0.5 adaptive noise=0.01 min-spp=8"
    );
    assert_eq!(StudyConfig::from_label(&c.label).unwrap(), c);
    assert_eq!(
        c.fixed(),
        StudyConfig::parse("weighted-delta:b=0.5:local").unwrap()
    );
    assert_eq!(c.family(), "weighted-delta b=0.5 noise=0.01 min-spp=8");
    assert_eq!(
        StudyConfig::parse("delta")
            .unwrap()
            .settings(&RenderSettings::default())
            .noise_threshold,
        None
    );
    for bad in [
        "delta:noise=0",
        "delta:noise=x",
        "delta:min-spp=8",
        "delta:noise=0.1:min-spp=0",
    ] {
        assert!(StudyConfig::parse(bad).is_err(), "{bad}");
    }
}

/// Per-channel z of the image mean of `film` against `reference`. The standard error of an
/// adaptive pixel's mean is not taken from its own samples (a pixel stops when they happen
/// to look quiet) but from the reference's variance of a sample of the same estimator over
/// the pixel's sample count.
fn image_mean_z(film: &brume::film::Film, reference: &Image) -> [f64; 3] {
    let var = reference.variance.as_ref().expect("reference variance");
    let count = reference.samples.as_ref().expect("reference sample counts");
    let mut z = [0.0; 3];
    for (c, z) in z.iter_mut().enumerate() {
        let (mut diff, mut v) = (0.0, 0.0);
        for (i, p) in film.pixels().iter().enumerate() {
            let v_ref = var[i][c] as f64;
            diff += p.mean[c] - reference.rgb[i][c] as f64;
            v += v_ref + v_ref * count[i] as f64 / p.count as f64;
        }
        *z = diff / v.sqrt().max(1e-30);
    }
    z
}

/// Checkpoint sample counts of a render of `n` pixels: what the tiles rendered (`samples`)
/// is what the pixels hold (`mean_spp`), between `min(spp, min_spp)` and `spp` a pixel, and
/// exactly `spp` a pixel with fixed sampling.
fn check_counts(rows: &[&Checkpoint], n: u64, min_spp: Option<u32>) {
    for (i, p) in rows.iter().enumerate() {
        let at = format!("{} at {} spp", p.config, p.spp);
        assert!(
            (p.mean_spp * n as f64 - p.samples as f64).abs() < 0.01,
            "{at}"
        );
        assert!(p.samples <= p.spp as u64 * n, "{at}");
        let floor = min_spp.map_or(p.spp, |m| m.min(p.spp)) as u64 * n;
        assert!(p.samples >= floor, "{at}");
        if i > 0 {
            let q = rows[i - 1];
            assert!(
                p.spp > q.spp && p.samples >= q.samples && p.seconds >= q.seconds,
                "{at}"
            );
        }
    }
}

#[test]
fn study_compares_fixed_and_adaptive_sampling() {
    let dir = out_dir("adaptive");
    let (w, h, budget) = (32u32, 24u32, 0.3);
    let n = (w * h) as u64;
    let (ok, out, err) = brume(
        &[
            "study",
            &scene("plume_sky.gltf"),
            "--out",
            dir.to_str().unwrap(),
            "--budget",
            &budget.to_string(),
            "--width",
            &w.to_string(),
            "--height",
            &h.to_string(),
            "--reference-spp",
            "1024",
            "--config",
            "delta:leaf",
            "--config",
            "delta:leaf:noise=0.02",
        ],
        &[("BRUME_FONT", "none")],
    );
    assert!(ok, "{err}");
    assert!(
        out.contains("| delta leaf |") && out.contains("| delta leaf noise=0.02 |"),
        "{out}"
    );
    assert!(out.contains("fixed against adaptive sampling"), "{out}");
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    let gains = s["adaptive_gains"].as_array().unwrap();
    assert_eq!(gains.len(), 1, "{s}");
    let g = &gains[0];
    assert_eq!(
        (g["fixed"].as_str(), g["adaptive"].as_str()),
        (Some("delta leaf"), Some("delta leaf noise=0.02"))
    );
    // The default target is one every adaptive render reaches; the ratio is of the two times.
    let ta = g["adaptive_seconds"]
        .as_f64()
        .expect("adaptive reaches the default target");
    if let Some(tf) = g["fixed_seconds"].as_f64() {
        assert!((g["ratio"].as_f64().unwrap() - tf / ta).abs() <= 1e-9 * tf / ta);
        assert!(out.contains("fixed / adaptive time = "), "{out}");
    }
    let adaptive_summary = &s["configs"][1];
    assert_eq!(
        adaptive_summary["config"]["adaptive_sampling"]["min_spp"],
        16
    );

    let points = read_csv(&dir.join("checkpoints.csv")).unwrap();
    let rows =
        |label: &str| -> Vec<&Checkpoint> { points.iter().filter(|p| p.config == label).collect() };
    let (fixed, adaptive) = (rows("delta leaf"), rows("delta leaf noise=0.02"));
    assert!(fixed.len() >= 3 && adaptive.len() >= 3, "{points:?}");
    check_counts(&fixed, n, None);
    assert!(fixed.iter().all(|p| p.samples == p.spp as u64 * n));
    check_counts(&adaptive, n, Some(16));

    // The adaptive configuration again through the library, long enough for every pixel to
    // stop: its image mean against the study's reference, and its film against its
    // checkpoints.
    let reference = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .find(|p| {
            p.file_name()
                .unwrap()
                .to_string_lossy()
                .starts_with("reference-plume_sky-")
        })
        .expect("the cached reference");
    let reference = read_exr(&reference).unwrap();
    let scene_data = brume::scene::load(std::path::Path::new(&scene("plume_sky.gltf"))).unwrap();
    let rs = RenderScene::new(&scene_data, false).unwrap();
    let base = RenderSettings {
        width: w,
        height: h,
        ..RenderSettings::default()
    };
    let cfg = StudyConfig::parse("delta:leaf:noise=0.02").unwrap();
    let seed = adaptive[0].seed;
    let (again, film) = render_config(&rs, &base, &cfg, 600.0, 0, seed, &reference);
    let last = again.last().unwrap();
    let counts: Vec<u32> = film.pixels().iter().map(|p| p.count).collect();
    assert_eq!(counts.iter().map(|&c| c as u64).sum::<u64>(), last.samples);
    assert!(counts.iter().all(|&c| (16..=last.spp).contains(&c)));
    let stopped = counts.iter().filter(|&&c| c < last.spp).count();
    assert!(stopped > 0, "no pixel stopped before {} spp", last.spp);
    check_counts(&again.iter().collect::<Vec<_>>(), n, Some(16));
    // The study's row ended the same way unless the budget came first: then it is the same
    // render, checkpoint for checkpoint.
    let study_last = adaptive.last().unwrap();
    if study_last.seconds < budget {
        assert_eq!(adaptive.len(), again.len());
        for (a, b) in adaptive.iter().zip(&again) {
            assert_eq!((a.spp, a.samples), (b.spp, b.samples));
            assert!(
                (a.rmse - b.rmse).abs() <= 1e-7 * b.rmse,
                "{} {}",
                a.rmse,
                b.rmse
            );
        }
    }
    // A pixel whose running mean happens to sit high against its noise stops sooner, which
    // lifts the image mean a little: over 40 seeds of this render z is 1.4 +- 0.8 (0.03 % of
    // the mean; none with min-spp=64). |z| < 4 on each channel leaves room for that and noise.
    let z = image_mean_z(&film, &reference);
    println!(
        "adaptive: {:.1} spp a pixel (at most {}), {stopped} of {n} pixels stopped early, image mean z {z:.2?}",
        last.mean_spp, last.spp
    );
    assert!(z.iter().all(|z| z.abs() < 4.0), "image mean z {z:?}");
    std::fs::remove_dir_all(&dir).ok();
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
        mean_spp: 1.0,
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
