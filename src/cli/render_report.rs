//! What `brume render` prints: the accelerator and the plan before it renders, the totals
//! after.
use std::path::Path;

use brume::backend::cpu::RenderOutput;
use brume::film::TileTotals;
use brume::render::{RenderScene, RenderSettings};

/// Builds the CPU's accelerator (`--accel`; none where only the GPU renders, `gpu_only`), says
/// which one renders and why (a warning where auto's Embree could not be built), and what the
/// geometry costs (triangles stored and instanced, memory, timings).
pub fn report_accel(
    scene: &mut brume::scene::Scene,
    asked: brume::render::settings::Accel,
    gpu_only: bool,
) -> anyhow::Result<()> {
    use brume::render::settings::Accel;
    if gpu_only {
        eprintln!("accel: the GPU's BVH (--backend gpu)");
        eprintln!("{}", scene.geometry_stats().report(&scene.timings));
        return Ok(());
    }
    let used = scene.use_accel(asked)?;
    let n = scene.triangle_count();
    let threshold = brume::accel::EMBREE_FROM_TRIANGLES;
    let why = if let Some(e) = &used.fallback {
        eprintln!("warning: --accel auto: Embree could not be built ({e}); the BVH renders");
        format!("auto: Embree failed, {n} static triangles")
    } else if scene.moving_meshes.is_some() && asked != Accel::Bvh {
        "the scene's meshes move: Embree holds static triangles only".to_string()
    } else if let Some(i) = &scene.instanced {
        let stored = "each primitive stored once";
        match (&scene.embree, asked) {
            (Some(_), Accel::Auto) => format!(
                "auto: {} placements of {n} triangles from {threshold} on; {stored}",
                i.placements()
            ),
            (Some(_), _) => format!("--accel embree, {} placements; {stored}", i.placements()),
            (None, _) => format!(
                "two-level: {} placements, {n} triangles; {stored}",
                i.placements()
            ),
        }
    } else if asked == Accel::Auto && used.accel == Accel::Embree {
        format!("auto: {n} static triangles, from {threshold} on")
    } else if asked == Accel::Auto {
        format!("auto: {n} triangles, below {threshold}")
    } else {
        format!("--accel {}, {n} triangles", asked.name())
    };
    match &scene.embree {
        Some(e) => eprintln!(
            "accel: embree ({why}; built in {:.1} ms, {:.1} KiB)",
            e.build_seconds() * 1e3,
            e.memory_bytes() as f64 / 1024.0
        ),
        None => eprintln!("accel: bvh ({why})"),
    }
    eprintln!("{}", scene.geometry_stats().report(&scene.timings));
    Ok(())
}

/// What the render will simulate and how: the scene's effects, the CPU path's variant and
/// estimator, and the walk each VDB medium's flights take under the majorant mode
/// (`WalkPlan::of`): what "majorant adaptive" chose for this scene, named as `--majorant`
/// names them. Overlapping media merge their free flights' segments (`WalkPlan::merged`);
/// shadow rays stay per medium.
pub fn report_plan(
    scene: &brume::scene::Scene,
    rs: &RenderScene,
    settings: &RenderSettings,
    features: brume::render::FeatureFlags,
) {
    eprintln!("scene effects: {}", scene.effects().names().join(", "));
    eprintln!(
        "cpu path: {} ({}), estimator {}, majorant {}, b {}, m {}",
        features.name(),
        if settings.generic {
            "generic, forced"
        } else if features.overlapping {
            // tile::specialised: the mixture is compiled into the generic variant only.
            "generic: the mixture of overlapping media runs in the generic variant"
        } else {
            "specialised"
        },
        settings.estimator,
        settings.majorant.name(),
        settings.b,
        settings
            .m_or_default()
            .map_or("per-leaf minorant".to_string(), |m| m.to_string()),
    );
    for (k, m) in rs.vdb.iter().enumerate() {
        let plan = m.walk(settings.majorant);
        let free = if rs.features.overlapping {
            plan.merged
        } else {
            plan.free
        };
        eprintln!(
            "medium {k} walks: free flights {}, shadow rays {}",
            free.name(),
            plan.shadow.name()
        );
    }
}

/// The render's totals: samples and speed, work per sample, adaptive sampling's savings, and
/// warnings where the image is biased or paths were cut short.
pub fn report_totals(output: &Path, settings: &RenderSettings, out: &RenderOutput, t: &TileTotals) {
    let samples = t.counters.samples.max(1) as f64;
    // Passes of this run (a part's pass indices start where its range does).
    let passes = out
        .records
        .iter()
        .map(|r| r.pass)
        .collect::<std::collections::BTreeSet<_>>()
        .len();
    println!(
        "{}: {} spp in {:.2} s ({:.0} samples/s{}), {} tiles x {} passes",
        output.display(),
        out.spp,
        out.seconds,
        t.counters.samples as f64 / out.seconds.max(1e-9),
        if out.interrupted {
            ", stopped early"
        } else {
            ""
        },
        out.records.len() / passes.max(1),
        passes,
    );
    if let Some(e) = settings.noise_threshold {
        let cap = settings.spp;
        let counts: Vec<u32> = out.film.pixels().iter().map(|p| p.count).collect();
        let taken = counts.iter().filter(|&&c| c > 0).count().max(1);
        let stopped = counts.iter().filter(|&&c| c > 0 && c < cap).count();
        println!(
            "adaptive: noise threshold {e}: {stopped} of {taken} pixels stopped before {cap} spp; \
             {:.1} spp a pixel on average",
            counts.iter().map(|&c| c as f64).sum::<f64>() / taken as f64
        );
    }
    println!(
        "totals: samples {} density_lookups {} null_collisions {} real_collisions {} shadow_lookups {} emission_lookups {} majorant_segments {} shadow_segments {} path_length_sum {} guard_fired {} majorant_violations {}",
        t.counters.samples, t.counters.density_lookups, t.counters.null_collisions, t.counters.real_collisions, t.counters.shadow_lookups, t.counters.emission_lookups, t.counters.majorant_segments, t.counters.shadow_segments, t.counters.path_length_sum, t.counters.guard_fired, t.counters.majorant_violations
    );
    println!(
        "per sample: {:.2} lookups, {:.2} null / {:.2} real collisions, path length {:.2}",
        t.counters.density_lookups as f64 / samples,
        t.counters.null_collisions as f64 / samples,
        t.counters.real_collisions as f64 / samples,
        t.counters.path_length_sum as f64 / samples
    );
    println!(
        "walk per sample: primary {:.2} segments / {:.2} lookups, shadow {:.2} segments / {:.2} lookups",
        (t.counters.majorant_segments - t.counters.shadow_segments) as f64 / samples,
        (t.counters.density_lookups - t.counters.shadow_lookups) as f64 / samples,
        t.counters.shadow_segments as f64 / samples,
        t.counters.shadow_lookups as f64 / samples,
    );
    if t.counters.majorant_violations > 0 {
        eprintln!(
            "warning: {} density lookups exceeded their majorant: this {} image is BIASED (use weighted-delta, or b >= 1)",
            t.counters.majorant_violations, settings.estimator
        );
    }
    if t.counters.guard_fired > 0 {
        eprintln!(
            "warning: the collision guard ended {} paths early (see guard_fired in the tile log)",
            t.counters.guard_fired
        );
    }
}
