//! `brume compare A.exr B.exr`: error norms and z-tests of an image against a reference.
use std::path::{Path, PathBuf};

use anyhow::{anyhow, Context, Result};
use clap::Args;

use brume::film::{read_exr, write_image, Image};
use brume::study::compare::{compare, difference_image, false_colour, CompareOptions, ZTest};
use brume::study::plot::write_rgb8_png;
use brume::study::report::sig;

#[derive(Args, Debug)]
pub struct CompareArgs {
    /// Image under test (float RGB(A) EXR; a `variance.*` layer enables the z-tests).
    pub a: PathBuf,
    /// Reference image (same size). Differences are A - B; relative errors divide by B.
    pub b: PathBuf,
    /// Print the comparison as JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Write the difference A - B as an EXR (with variance var A + var B where known).
    #[arg(long)]
    pub diff: Option<PathBuf>,
    /// Write a false-colour PNG of the difference (blue: A darker, red: A brighter; scaled to
    /// the 99th percentile of |A - B|).
    #[arg(long)]
    pub diff_png: Option<PathBuf>,
    /// Block side of the block z-test, in pixels.
    #[arg(long, default_value_t = 8)]
    pub blocks: usize,
    /// Family-wise significance level of the z-tests.
    #[arg(long, default_value_t = 1e-3)]
    pub alpha: f64,
}

fn read(path: &Path, which: &str) -> Result<Image> {
    read_exr(path).with_context(|| format!("reading image {which}"))
}

pub fn run(args: &CompareArgs) -> Result<()> {
    let a = read(&args.a, "A")?;
    let b = read(&args.b, "B")?;
    if (a.width, a.height) != (b.width, b.height) {
        return Err(anyhow!(
            "cannot compare images of different sizes: {} is {}x{}, {} is {}x{}",
            args.a.display(),
            a.width,
            a.height,
            args.b.display(),
            b.width,
            b.height
        ));
    }
    let opts = CompareOptions {
        block: args.blocks,
        alpha: args.alpha,
    };
    let c = compare(&a, &b, &opts)
        .with_context(|| format!("comparing {} with {}", args.a.display(), args.b.display()))?;
    if args.diff.is_some() || args.diff_png.is_some() {
        let d = difference_image(&a, &b)?;
        if let Some(p) = &args.diff {
            write_image(p, &d)?;
        }
        if let Some(p) = &args.diff_png {
            let (px, _scale) = false_colour(&d);
            write_rgb8_png(p, d.width as u32, d.height as u32, &px).map_err(|e| anyhow!(e))?;
        }
    }
    if args.json {
        let mut v = serde_json::to_value(&c)?;
        v["a"] = args.a.display().to_string().into();
        v["b"] = args.b.display().to_string().into();
        println!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(());
    }
    let ch = |v: [f64; 3]| format!("R {}  G {}  B {}", sig(v[0]), sig(v[1]), sig(v[2]));
    println!(
        "A = {}  B = {}  ({}x{}, variance from: {})",
        args.a.display(),
        args.b.display(),
        c.width,
        c.height,
        c.variance_from
    );
    if c.nonfinite_pixels > 0 {
        println!("non-finite pixels (left out): {}", c.nonfinite_pixels);
    }
    println!("RMSE            {}  all {}", ch(c.rmse), sig(c.rmse_all));
    println!(
        "relMSE          {}  all {}",
        ch(c.relmse),
        sig(c.relmse_all)
    );
    println!("mean |A-B|      {}", ch(c.mean_abs_diff));
    println!("mean A-B        {}", ch(c.mean_signed_diff));
    println!("mean A          {}", ch(c.mean_a));
    println!("mean B          {}", ch(c.mean_b));
    println!("(mean A - mean B) / mean B  {}", ch(c.mean_rel_diff));
    if let Some(z) = c.mean_z {
        println!("z of the mean difference    {}", ch(z));
    }
    let show = |name: &str, t: &Option<ZTest>| match t {
        None => println!("{name}: not run (neither image has a variance layer)"),
        Some(t) => println!(
            "{name}: {} ({} tests, {} skipped); Sidak |z| > {:.2}: {} fail ({:.3} %); \
             per test |z| > {:.2}: {} fail ({:.3} %, ~{:.3} % expected); worst |z| {}",
            if t.passed { "PASS" } else { "FAIL" },
            t.tests,
            t.skipped,
            t.z_sidak,
            t.failing_sidak,
            100.0 * t.fraction_failing_sidak,
            t.z_per_test,
            t.failing_per_test,
            100.0 * t.fraction_failing_per_test,
            100.0 * c.alpha,
            sig(t.worst_z)
        ),
    };
    show("per-pixel z-test", &c.pixel_test);
    show(&format!("{0}x{0} block z-test", c.block), &c.block_test);
    Ok(())
}
