//! `brume merge`: partial renders of one image (sample ranges, regions, farm tasks) into one.
use std::path::PathBuf;

use anyhow::{anyhow, Context, Result};
use clap::Args;

use brume::farm::merge_files;
use brume::film::write_exr_with_state;

#[derive(Args, Debug)]
pub struct MergeArgs {
    /// Parts written by `brume render --samples/--region` (or earlier merges).
    #[arg(required = true)]
    pub parts: Vec<PathBuf>,
    /// The merged EXR (written atomically, only when every part is accepted).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Refuse unless every pixel of the merge holds exactly this many samples (the whole
    /// image is there: no part missing, none a checkpoint of an unfinished task).
    #[arg(long)]
    pub spp: Option<u32>,
}

pub fn run(args: &MergeArgs) -> Result<()> {
    if let Some(p) = args.parts.iter().find(|p| **p == args.output) {
        return Err(anyhow!(
            "{}: the output is also a part; write the merge elsewhere",
            p.display()
        ));
    }
    let start = std::time::Instant::now();
    let (film, meta) = merge_files(&args.parts)?;
    if let Some(spp) = args.spp {
        if let Some((i, p)) = film
            .pixels()
            .iter()
            .enumerate()
            .find(|(_, p)| p.count != spp)
        {
            let w = film.width() as usize;
            return Err(anyhow!(
                "{}: incomplete: pixel ({}, {}) holds {} samples, --spp asks for {spp} \
                 (coverage {}); nothing written",
                args.output.display(),
                i % w,
                i / w,
                p.count,
                meta.text("brume:coverage").unwrap_or("")
            ));
        }
    }
    write_exr_with_state(&args.output, &film, &meta)
        .with_context(|| format!("writing {}", args.output.display()))?;
    println!(
        "{}: merged {} parts ({} samples per pixel at most, coverage {}) in {:.2} s",
        args.output.display(),
        args.parts.len(),
        film.pixels().iter().map(|p| p.count).max().unwrap_or(0),
        meta.text("brume:coverage").unwrap_or(""),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}
