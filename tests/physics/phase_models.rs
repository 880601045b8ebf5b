//! The phase functions a medium can have (`volume::phases`): each one's sampling against its
//! density by chi-square, its normalisation by quadrature, the sample's pdf against the
//! density, the density against an independent f64 formula, and the Mie fit's parameters
//! continuous across its ranges.
use brume::sampling::chi2::{chi2_test, integrate, sidak, SphereHistogram};
use brume::sampling::Rng;
use brume::volume::phases::{Draine, Phase};
use glam::{DVec3, Vec2, Vec3};

fn cases() -> Vec<(&'static str, Phase)> {
    use brume::volume::phase::HenyeyGreenstein as Hg;
    vec![
        ("hg 0.5", Phase::hg(0.5)),
        (
            "two-lobe 0.8 / -0.3, 0.7",
            Phase::TwoLobe {
                a: Hg::new(0.8),
                b: Hg::new(-0.3),
                w: 0.7,
            },
        ),
        ("draine 0.6, alpha 1", Phase::Draine(Draine::new(0.6, 1.0))),
        (
            "draine 0.3, alpha 250",
            Phase::Draine(Draine::new(0.3, 250.0)),
        ),
        (
            "draine -0.4, alpha -0.8",
            Phase::Draine(Draine::new(-0.4, -0.8)),
        ),
        ("mie 0.05 um", Phase::mie(0.05).unwrap()),
        ("mie 1 um", Phase::mie(1.0).unwrap()),
        ("mie 3 um", Phase::mie(3.0).unwrap()),
        ("mie 10 um", Phase::mie(10.0).unwrap()),
        ("rayleigh", Phase::Rayleigh),
    ]
}

/// The direction at scattering cosine `mu` and azimuth `phi` around `-wo`.
fn direction(wo: DVec3, mu: f64, phi: f64) -> DVec3 {
    let (t, b) = wo.any_orthonormal_pair();
    let s = (1.0 - mu * mu).max(0.0).sqrt();
    -wo * mu + (t * phi.cos() + b * phi.sin()) * s
}

#[test]
fn every_phase_function_samples_its_density() {
    let level = sidak(0.01, cases().len());
    let wo = Vec3::new(0.3, -0.5, 0.8).normalize();
    let n = 400_000u32;
    for (name, phase) in cases() {
        let mut h = SphereHistogram::new(20, 40);
        let mut worst_pdf = 0f32;
        for i in 0..n {
            let mut rng = Rng::new(i, 0, 303);
            let u = rng.uniform_vec2();
            let s = phase.sample(wo, u, &mut || rng.uniform_vec2());
            let p = phase.p(wo, s.wi);
            worst_pdf = worst_pdf.max((s.pdf - p).abs() / p.max(1e-30));
            h.add(s.wi);
        }
        assert!(
            worst_pdf < 1e-5,
            "{name}: the sample's pdf is not its density ({worst_pdf})"
        );
        // The histogram's bins are in world coordinates (z up): the density at a world
        // direction is the phase function's at that direction.
        let pdf = |cos: f64, phi: f64| {
            let s = (1.0 - cos * cos).max(0.0).sqrt();
            let wi = Vec3::new((s * phi.cos()) as f32, (s * phi.sin()) as f32, cos as f32);
            phase.p(wo, wi) as f64
        };
        let expected = h.expected(n as f64, &pdf, 1e-6);
        let t = chi2_test(&h.counts, &expected, 5.0);
        println!(
            "{name}: chi2 {:.1} dof {} p {:.4}",
            t.statistic, t.dof, t.p_value
        );
        assert!(t.p_value >= level, "{name}: {t:?}");
    }
}

#[test]
fn every_phase_function_is_normalised() {
    let wo = DVec3::new(0.0, 0.6, -0.8);
    for (name, phase) in cases() {
        let p = |mu: f64| {
            let wi = direction(wo, mu, 0.7).as_vec3();
            phase.p(wo.as_vec3(), wi) as f64
        };
        let total = 2.0 * std::f64::consts::PI * integrate(&p, -1.0, 1.0, 1e-8);
        println!("{name}: integral {total:.6}");
        assert!((total - 1.0).abs() < 1e-3, "{name}: {total}");
    }
}

/// Draine's and Rayleigh's densities against their formulas in f64.
#[test]
fn densities_match_their_formulas() {
    let wo = DVec3::new(0.0, 0.0, 1.0);
    let pi4 = 4.0 * std::f64::consts::PI;
    let draine = |g: f64, a: f64, mu: f64| {
        let hg = (1.0 - g * g) / (pi4 * (1.0 + g * g - 2.0 * g * mu).powf(1.5));
        hg * (1.0 + a * mu * mu) / (1.0 + a * (1.0 + 2.0 * g * g) / 3.0)
    };
    for mu in [-0.95, -0.3, 0.0, 0.4, 0.9] {
        let wi = direction(wo, mu, 0.0).as_vec3();
        let d = Phase::Draine(Draine::new(0.6, 1.5)).p(wo.as_vec3(), wi) as f64;
        let r = Phase::Rayleigh.p(wo.as_vec3(), wi) as f64;
        assert!(
            (d / draine(0.6, 1.5, mu) - 1.0).abs() < 1e-4,
            "draine at {mu}"
        );
        let rayleigh = 3.0 * (1.0 + mu * mu) / (4.0 * pi4);
        assert!((r / rayleigh - 1.0).abs() < 1e-5, "rayleigh at {mu}");
    }
}

/// The Mie fit: forward peaks of cloud droplets (mean cosine about 0.85 for 10-20 um), its
/// four pieces meeting at 0.1, 1.5 and 5 um (the published fits agree there to a few
/// percent), and diameters outside (0, 50] refused.
#[test]
fn the_mie_fit_is_a_cloud_phase_across_its_ranges() {
    let mean_cosine = |phase: &Phase| {
        let wo = DVec3::new(0.0, 0.0, 1.0);
        let f = |mu: f64| {
            let wi = direction(wo, mu, 0.0).as_vec3();
            mu * phase.p(wo.as_vec3(), wi) as f64
        };
        2.0 * std::f64::consts::PI * integrate(&f, -1.0, 1.0, 1e-8)
    };
    for d in [10.0, 20.0] {
        let g = mean_cosine(&Phase::mie(d).unwrap());
        println!("mie {d} um: mean cosine {g:.4}");
        assert!((0.8..0.9).contains(&g), "{d}: {g}");
    }
    for edge in [0.1f32, 1.5, 5.0] {
        let (below, above) = (
            Phase::mie(edge * (1.0 - 1e-4)).unwrap(),
            Phase::mie(edge * (1.0 + 1e-4)).unwrap(),
        );
        let (gb, ga) = (mean_cosine(&below), mean_cosine(&above));
        println!("mie at {edge} um: mean cosine {gb:.4} below, {ga:.4} above");
        assert!((gb - ga).abs() < 0.05, "{edge}: {gb} against {ga}");
    }
    assert!(Phase::mie(0.0).is_none() && Phase::mie(60.0).is_none());
    let _ = Vec2::ZERO;
}

/// `BRUME_medium_vdb.phase` as a scene writes it reaches the medium.
#[test]
fn a_scene_names_its_phase_function() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("scenes/furnace.gltf")).unwrap();
    let mut doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    let ext = &mut doc["nodes"][1]["extensions"]["BRUME_medium_vdb"];
    let uri = root.join("scenes").join(ext["uri"].as_str().unwrap());
    ext["uri"] = uri.to_str().unwrap().into();
    let dir = std::env::temp_dir().join(format!("brume-phase-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (json, expected) in [
        (
            serde_json::json!({"type": "mie", "diameter": 20.0}),
            Phase::mie(20.0).unwrap(),
        ),
        (serde_json::json!({"type": "rayleigh"}), Phase::Rayleigh),
        (
            serde_json::json!({"type": "draine", "g": 0.2, "alpha": 0.5}),
            Phase::Draine(Draine::new(0.2, 0.5)),
        ),
    ] {
        doc["nodes"][1]["extensions"]["BRUME_medium_vdb"]["phase"] = json;
        let path = dir.join("furnace.gltf");
        std::fs::write(&path, doc.to_string()).unwrap();
        let scene = brume::scene::load(&path).unwrap();
        assert_eq!(scene.vdb_media[0].phase, Some(expected));
    }
    let _ = std::fs::remove_dir_all(&dir);
}
