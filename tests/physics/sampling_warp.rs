//! The chi-square harness itself (special functions, pooling, quadrature), then every warp and
//! the discrete chooser through it.

use brume::sampling::chi2::{
    chi2_sf, chi2_test, gamma_q, integrate, ln_gamma, sidak, SphereHistogram,
};
use brume::sampling::discrete::{discrete_pmf, sample_discrete};
use brume::sampling::warp::{self, Frame};
use brume::sampling::Rng;
use glam::Vec3;

fn close(a: f64, b: f64, tol: f64) {
    assert!((a - b).abs() <= tol, "{a} vs {b}");
}

#[test]
fn special_functions_match_tables() {
    close(ln_gamma(5.0), 24f64.ln(), 1e-12);
    close(ln_gamma(0.5), std::f64::consts::PI.sqrt().ln(), 1e-12);
    close(ln_gamma(100.0), 359.134_205_369_575_4, 1e-9);
    for x in [0.01, 0.5, 1.0, 3.0, 10.0, 50.0] {
        close(gamma_q(1.0, x), (-x).exp(), 1e-12);
    }
    // Chi-square critical values from standard tables.
    close(chi2_sf(3.841_458_820_694_124, 1), 0.05, 1e-9);
    close(chi2_sf(6.634_896_601_021_214, 1), 0.01, 1e-9);
    close(chi2_sf(18.307_038_053_275_146, 10), 0.05, 1e-9);
    close(chi2_sf(124.342_113_404_787_8, 100), 0.05, 1e-8);
    close(sidak(0.01, 1), 0.01, 1e-15);
    assert!(sidak(0.01, 10) < 0.01 / 9.9);
}

#[test]
fn chi2_test_pools_and_rejects() {
    // Exact counts: statistic 0, p = 1.
    let e = [10.0, 20.0, 1.0, 2.0, 3.0, 64.0];
    let t = chi2_test(&e, &e, 5.0);
    assert_eq!(t.statistic, 0.0);
    assert_eq!(t.p_value, 1.0);
    // 1 + 2 + 3 pool into one bin of 6: 4 bins, 3 dof.
    assert_eq!(t.dof, 3);
    // A sample where the pdf is zero fails outright.
    let t = chi2_test(&[1.0, 9.0], &[0.0, 10.0], 5.0);
    assert_eq!(t.p_value, 0.0);
    // A clearly wrong distribution is rejected.
    let t = chi2_test(&[600.0, 400.0], &[500.0, 500.0], 5.0);
    assert!(t.p_value < 1e-9, "{t:?}");
}

#[test]
fn adaptive_quadrature_finds_narrow_peaks() {
    close(integrate(&|x| x * x, 0.0, 1.0, 1e-12), 1.0 / 3.0, 1e-12);
    // A Lorentzian of width 1e-4 centred off the panel grid: integral ~ pi.
    let w = 1e-4;
    let f = |x: f64| w / ((x - 0.123_456).powi(2) + w * w);
    close(
        integrate(&f, -1.0, 1.0, 1e-9),
        std::f64::consts::PI - 2.0 * w * 0.5 / 0.876_544 - 2.0 * w * 0.5 / 1.123_456,
        1e-4,
    );
}

/// Chi-square of a direction sampler against its pdf over 20 x 40 (cos theta, phi) bins.
fn chi2_directions(
    name: &str,
    n: u32,
    alpha: f64,
    sample: impl Fn(&mut Rng) -> Vec3,
    pdf: impl Fn(Vec3) -> f64,
) {
    let mut h = SphereHistogram::new(20, 40);
    for i in 0..n {
        let mut rng = Rng::new(i, 0, 101);
        h.add(sample(&mut rng));
    }
    let pdf_cp = |mu: f64, phi: f64| {
        let s = (1.0 - mu * mu).max(0.0).sqrt();
        pdf(Vec3::new(
            (s * phi.cos()) as f32,
            (s * phi.sin()) as f32,
            mu as f32,
        ))
    };
    let expected = h.expected(n as f64, &pdf_cp, 1e-7);
    let t = chi2_test(&h.counts, &expected, 5.0);
    println!(
        "{name}: chi2 {:.1} dof {} p {:.4}",
        t.statistic, t.dof, t.p_value
    );
    assert!(t.p_value >= alpha, "{name}: {t:?}");
}

#[test]
fn warps_match_their_pdfs() {
    let alpha = sidak(0.01, 3);
    let n = 400_000;
    chi2_directions(
        "uniform sphere",
        n,
        alpha,
        |r| warp::uniform_sphere(r.uniform_vec2()),
        |_| warp::uniform_sphere_pdf() as f64,
    );
    chi2_directions(
        "uniform hemisphere",
        n,
        alpha,
        |r| warp::uniform_hemisphere(r.uniform_vec2()),
        |d| {
            if d.z >= 0.0 {
                warp::uniform_hemisphere_pdf() as f64
            } else {
                0.0
            }
        },
    );
    chi2_directions(
        "cosine hemisphere",
        n,
        alpha,
        |r| warp::cosine_hemisphere(r.uniform_vec2()),
        |d| warp::cosine_hemisphere_pdf(d.z) as f64,
    );
}

#[test]
fn frames_are_orthonormal() {
    let mut rng = Rng::new(0, 0, 3);
    let mut dirs: Vec<Vec3> = (0..10_000)
        .map(|_| warp::uniform_sphere(rng.uniform_vec2()))
        .collect();
    dirs.extend([
        Vec3::Z,
        -Vec3::Z,
        Vec3::X,
        -Vec3::Y,
        Vec3::new(0.0, 1e-8, -1.0).normalize(),
    ]);
    for n in dirs {
        let f = Frame::from_z(n);
        for (a, b) in [(f.x, f.y), (f.y, f.z), (f.x, f.z)] {
            assert!(a.dot(b).abs() < 1e-5, "{n}: {f:?}");
        }
        for v in [f.x, f.y, f.z] {
            assert!((v.length() - 1.0).abs() < 1e-5);
        }
        assert!(f.x.cross(f.y).dot(f.z) > 0.999, "right-handed");
        let v = Vec3::new(0.3, -0.2, 0.9);
        assert!((f.to_local(f.from_local(v)) - v).length() < 1e-5);
    }
}

#[test]
fn discrete_choice_and_remapped_uniform() {
    let w = [1.0, 0.0, 3.0, 2.0];
    let n = 600_000u32;
    let mut counts = [0.0f64; 4];
    // The remapped uniform of the chosen entry must itself be uniform: 10 bins per entry.
    let mut remap = vec![0.0f64; 40];
    let mut rng = Rng::new(0, 0, 4);
    for _ in 0..n {
        let s = sample_discrete(&w, rng.uniform_f32()).unwrap();
        assert!((s.pmf - discrete_pmf(&w, s.index)).abs() < 1e-7);
        counts[s.index] += 1.0;
        remap[s.index * 10 + ((s.u_remapped * 10.0) as usize).min(9)] += 1.0;
    }
    assert_eq!(counts[1], 0.0);
    let expected: Vec<f64> = w.iter().map(|x| n as f64 * *x as f64 / 6.0).collect();
    let alpha = sidak(0.01, 2);
    let t = chi2_test(&counts, &expected, 5.0);
    println!("discrete: {t:?}");
    assert!(t.p_value >= alpha);
    let exp_remap: Vec<f64> = (0..40).map(|i| expected[i / 10] / 10.0).collect();
    let t = chi2_test(&remap, &exp_remap, 5.0);
    println!("remapped: {t:?}");
    assert!(t.p_value >= alpha);
    assert!(sample_discrete(&[0.0, 0.0], 0.5).is_none());
    // u at the top never picks a zero-weight tail.
    assert_eq!(
        sample_discrete(&[1.0, 1.0, 0.0], 1.0 - f32::EPSILON / 2.0)
            .unwrap()
            .index,
        1
    );
}
