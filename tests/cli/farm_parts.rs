//! Farm parts in process: random sample-range (and region) splits of a render merged back equal
//! the single render to the last rounding of the f64 summation order; a resumed checkpoint
//! equals the uninterrupted render bit for bit; merging merges is associative to the same
//! rounding. (`tests/cli/farm_cli.rs` runs the same through the `brume` command.)
use crate::common;
use common::farm::assert_rounding_equal;
use common::render::*;

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use brume::backend::cpu::{self, RenderOutput, Resume};
use brume::farm::{self, Coverage, PartInfo};
use brume::film::{read_exr, write_exr_with_state, Metadata};
use brume::render::light_groups::LightGroups;
use brume::render::{RenderScene, RenderSettings, SamplerKind};
use proptest::prelude::*;

const W: u32 = 24;
const H: u32 = 16;

fn settings(sampler: SamplerKind) -> RenderSettings {
    RenderSettings {
        width: W,
        height: H,
        spp: 0,
        sampler,
        // Small passes, so a range of a few samples crosses several of them.
        max_pass_spp: 4,
        seed: 7,
        // The light passes and light groups travel with the beauty: kept in the Sobol renders.
        light_passes: sampler == SamplerKind::Sobol,
        light_groups: match sampler {
            SamplerKind::Sobol => LightGroups::of(&load_scene("cloud.gltf")).unwrap().names,
            _ => Vec::new(),
        },
        ..RenderSettings::default()
    }
}

fn render_range(
    rs: &RenderScene,
    base: &RenderSettings,
    (start, end): (u32, u32),
    region: Option<[u32; 4]>,
    resume: Option<Resume>,
) -> RenderOutput {
    let s = RenderSettings {
        sample_start: start,
        spp: end,
        region,
        ..base.clone()
    };
    cpu::render_resumed(
        rs,
        &s,
        resume,
        &AtomicBool::new(false),
        &|_, _, _| {},
        &mut |_| {},
    )
}

/// The header `brume render` gives a part of samples `range` (and `region`) rendered as `out`.
fn part_meta(
    base: &RenderSettings,
    out: &RenderOutput,
    range: (u32, u32),
    region: Option<[u32; 4]>,
) -> Metadata {
    let mut meta = Metadata::new();
    PartInfo {
        scene_hash: "test".into(),
        settings: farm::settings_key(base, None),
        seed: base.seed.to_string(),
        version: env!("CARGO_PKG_VERSION").into(),
        width: W,
        height: H,
        coverage: vec![Coverage {
            start: range.0,
            end: range.0 + out.spp,
            region: region.unwrap_or([0, 0, W, H]),
        }],
        target: Some(range),
        seconds: out.seconds,
        parts: 1,
    }
    .write_into(&mut meta);
    meta
}

/// Writes a part as `brume render` does: state channels plus the part header.
fn write_part(
    path: &Path,
    base: &RenderSettings,
    out: &RenderOutput,
    range: (u32, u32),
    region: Option<[u32; 4]>,
) {
    write_exr_with_state(path, &out.film, &part_meta(base, out, range, region)).unwrap();
}

/// Cuts `[0, n)` at the sorted `cuts` (duplicates give empty ranges).
fn ranges(n: u32, cuts: &[u32]) -> Vec<(u32, u32)> {
    let mut c: Vec<u32> = cuts.iter().map(|&v| v % (n + 1)).collect();
    c.sort();
    let mut out = Vec::new();
    let mut prev = 0;
    for v in c.into_iter().chain([n]) {
        out.push((prev, v));
        prev = v;
    }
    out
}

fn check_split(sampler: SamplerKind, n: u32, cuts: &[u32], region_cut: Option<u32>, case: &str) {
    let scene = load_scene("cloud.gltf");
    let rs = RenderScene::new(&scene, false).unwrap();
    let base = settings(sampler);
    let single = render_range(&rs, &base, (0, n), None, None);
    let regions: Vec<Option<[u32; 4]>> = match region_cut {
        Some(y) => vec![Some([0, 0, W, y]), Some([0, y, W, H])],
        None => vec![None],
    };
    let mut paths = Vec::new();
    for (k, range) in ranges(n, cuts).into_iter().enumerate() {
        for (j, region) in regions.iter().enumerate() {
            let out = render_range(&rs, &base, range, *region, None);
            assert_eq!(out.spp, range.1 - range.0);
            let p = common::scratch::file(&format!("{case}-{k}-{j}.exr"));
            write_part(&p, &base, &out, range, *region);
            paths.push(p);
        }
    }
    // Order on the command line does not matter: the merge folds in sample order.
    paths.reverse();
    let (film, meta) = farm::merge_files(&paths).unwrap();
    assert_rounding_equal(&film, &single.film, case);
    let coverage = match region_cut {
        None => format!("0..{n}@0,0,{W},{H}"),
        Some(y) => format!("0..{n}@0,0,{W},{y};0..{n}@0,{y},{W},{H}"),
    };
    assert_eq!(meta.text("brume:coverage"), Some(coverage.as_str()));
    for p in paths {
        std::fs::remove_file(p).unwrap();
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 32, ..ProptestConfig::default() })]

    /// Any set of disjoint ranges covering [0, n), including one-sample and empty ones, with
    /// either sampler and optionally split in two regions as well.
    #[test]
    fn random_splits_merge_to_the_single_render(
        n in 1u32..24,
        cuts in proptest::collection::vec(0u32..64, 0..6),
        sobol in any::<bool>(),
        region_cut in proptest::option::of(1u32..H),
    ) {
        let sampler = if sobol { SamplerKind::Sobol } else { SamplerKind::Independent };
        check_split(sampler, n, &cuts, region_cut, &format!("split-{n}-{}", cuts.len()));
    }
}

#[test]
fn one_sample_parts_and_empty_parts_merge() {
    // Every sample its own part, plus empty ranges between.
    let cuts: Vec<u32> = (1..9).flat_map(|v| [v, v]).collect();
    check_split(SamplerKind::Sobol, 9, &cuts, None, "singles");
}

#[test]
fn a_resumed_checkpoint_is_the_uninterrupted_render_bit_for_bit() {
    let scene = load_scene("cloud.gltf");
    let rs = RenderScene::new(&scene, false).unwrap();
    for sampler in [SamplerKind::Sobol, SamplerKind::Independent] {
        let base = settings(sampler);
        for (start, reached, end) in [(0, 4, 19), (0, 1, 9), (3, 8, 21), (5, 5, 12)] {
            let full = render_range(&rs, &base, (start, end), None, None);
            // A checkpoint is written at a pass boundary: the render of [start, reached).
            let ckpt = render_range(&rs, &base, (start, reached), None, None);
            let p = common::scratch::file(&format!("ckpt-{start}-{reached}.exr"));
            write_part(&p, &base, &ckpt, (start, end), None);
            let back = farm::read_part(&p).unwrap();
            assert_eq!(back.film, ckpt.film, "the state round-trips exactly");
            let resumed = render_range(
                &rs,
                &base,
                (start, end),
                None,
                Some(Resume {
                    film: back.film,
                    reached,
                }),
            );
            assert_eq!(resumed.spp, end - start);
            assert!(
                resumed.film == full.film,
                "{sampler:?} {start}..{reached}..{end}: not bit for bit"
            );
            std::fs::remove_file(p).unwrap();
        }
    }
}

#[test]
fn merging_merges_is_associative() {
    let scene = load_scene("cloud.gltf");
    let rs = RenderScene::new(&scene, false).unwrap();
    let base = settings(SamplerKind::Sobol);
    let single = render_range(&rs, &base, (0, 14), None, None);
    let parts: Vec<PathBuf> = [(0, 3), (3, 9), (9, 14)]
        .into_iter()
        .enumerate()
        .map(|(k, r)| {
            let p = common::scratch::file(&format!("assoc-{k}.exr"));
            write_part(&p, &base, &render_range(&rs, &base, r, None, None), r, None);
            p
        })
        .collect();
    let all = farm::merge_files(&parts).unwrap().0;
    let (ab, meta_ab) = farm::merge_files(&parts[1..]).unwrap();
    let bc = common::scratch::file("assoc-bc.exr");
    write_exr_with_state(&bc, &ab, &meta_ab).unwrap();
    let nested = farm::merge_files(&[bc.clone(), parts[0].clone()]).unwrap();
    assert_rounding_equal(&all, &single.film, "a+b+c");
    assert_rounding_equal(&nested.0, &all, "a+(b+c)");
    assert_eq!(nested.1.text("brume:coverage"), Some("0..14@0,0,24,16"));
    assert_eq!(
        nested.1.get("brume:parts"),
        Some(&brume::film::AttrValue::Int(3))
    );
    // The merged file is an ordinary Brume EXR too.
    let img = read_exr(&bc).unwrap();
    assert!(img.samples.unwrap().iter().all(|&n| n == 11.0));
}

/// Writes an adaptive render's part: [`write_part`] with the noise threshold in the header, as
/// `brume render --noise-threshold` writes it (its pixels may hold fewer samples than the
/// coverage).
fn write_adaptive_part(
    path: &Path,
    base: &RenderSettings,
    out: &RenderOutput,
    range: (u32, u32),
    region: Option<[u32; 4]>,
) {
    let mut meta = part_meta(base, out, range, region);
    meta.set(
        brume::farm::context::NOISE_THRESHOLD_ATTRIBUTE,
        brume::film::AttrValue::Float(base.noise_threshold.unwrap()),
    );
    write_exr_with_state(path, &out.film, &meta).unwrap();
}

/// Adaptive sampling decides from each pixel's own statistics at pass boundaries: the same
/// render again, a resumed checkpoint and a merge of region parts all equal the single render.
#[test]
fn adaptive_renders_repeat_resume_and_merge_by_region_exactly() {
    let scene = load_scene("cloud.gltf");
    let rs = RenderScene::new(&scene, false).unwrap();
    let base = RenderSettings {
        noise_threshold: Some(0.05),
        min_spp: 8,
        ..settings(SamplerKind::Sobol)
    };
    let n = 96;
    let single = render_range(&rs, &base, (0, n), None, None);
    let counts: Vec<u32> = single.film.pixels().iter().map(|p| p.count).collect();
    let stopped = counts.iter().filter(|&&c| c < n).count();
    println!(
        "adaptive: {stopped} of {} pixels stopped before {n} spp, fewest samples {}",
        counts.len(),
        counts.iter().min().unwrap()
    );
    assert!(counts.iter().all(|&c| c >= 8) && stopped > 0 && stopped < counts.len());
    assert!(render_range(&rs, &base, (0, n), None, None).film == single.film);
    // A checkpoint at the pass boundary 24, resumed.
    let ckpt = render_range(&rs, &base, (0, 24), None, None);
    let p = common::scratch::file("adaptive-ckpt.exr");
    write_adaptive_part(&p, &base, &ckpt, (0, n), None);
    let back = farm::read_part(&p).unwrap();
    let resume = Resume {
        film: back.film,
        reached: 24,
    };
    let resumed = render_range(&rs, &base, (0, n), None, Some(resume));
    assert!(resumed.film == single.film, "resumed: not bit for bit");
    // Two region parts, merged.
    let paths: Vec<PathBuf> = [[0, 0, W, 5], [0, 5, W, H]]
        .into_iter()
        .enumerate()
        .map(|(k, region)| {
            let out = render_range(&rs, &base, (0, n), Some(region), None);
            let p = common::scratch::file(&format!("adaptive-region-{k}.exr"));
            write_adaptive_part(&p, &base, &out, (0, n), Some(region));
            p
        })
        .collect();
    let (film, _) = farm::merge_files(&paths).unwrap();
    assert_rounding_equal(&film, &single.film, "adaptive regions");
}
