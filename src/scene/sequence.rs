//! Frame sequences. A file name with a run of `#` (`smoke_####.vdb`) names one file per frame:
//! the run is replaced by the frame number, zero-padded to the run's length, as Blender writes
//! its caches (`-005` for frame -5 with four `#`, a longer number as it is).
use std::path::{Path, PathBuf};

use super::error::{Ctx, SceneError};
use super::BRUME_MEDIUM_VDB;

/// The last run of `#` in `s`: its start (a byte offset) and length.
pub fn hash_run(s: &str) -> Option<(usize, usize)> {
    let end = s.rfind('#')? + 1;
    let start = s[..end].trim_end_matches('#').len();
    Some((start, end - start))
}

/// Largest `|frameOffset|` of a medium sequence.
pub const MAX_FRAME_OFFSET: i64 = 1_000_000;

/// Whether `s` names a sequence (holds a `#`).
pub fn is_sequence(s: &str) -> bool {
    hash_run(s).is_some()
}

/// `s` with its last run of `#` replaced by `frame`; `s` itself when it has none.
pub fn for_frame(s: &str, frame: i32) -> String {
    match hash_run(s) {
        Some((start, len)) => format!("{}{frame:0len$}{}", &s[..start], &s[start + len..]),
        None => s.to_string(),
    }
}

/// `path` with the last run of `#` in its file name replaced by `frame`.
pub fn path_for_frame(path: &Path, frame: i32) -> PathBuf {
    match path.file_name().and_then(|n| n.to_str()) {
        Some(name) if is_sequence(name) => path.with_file_name(for_frame(name, frame)),
        _ => path.to_path_buf(),
    }
}

/// What `--frames` asks for: frames `A..B`, or the scene's own `BRUME_render.frameRange`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameChoice {
    Range(i32, i32),
    Scene,
}

impl FrameChoice {
    /// `A..B`, `N`, or `scene`.
    pub fn parse(s: &str) -> Result<FrameChoice, String> {
        if s.trim() == "scene" {
            return Ok(FrameChoice::Scene);
        }
        parse_frames(s)
            .map(|(a, b)| FrameChoice::Range(a, b))
            .map_err(|e| format!("{e}, or scene (the scene's BRUME_render frameRange)"))
    }

    /// The frames asked for, reading the scene at `path` for [`FrameChoice::Scene`].
    pub fn resolve(self, path: &Path) -> Result<(i32, i32), SceneError> {
        match self {
            FrameChoice::Range(a, b) => Ok((a, b)),
            FrameChoice::Scene => {
                let mut ctx = Ctx::new(path);
                let loaded = super::document::read(&mut ctx, path)?;
                let render = super::render_settings::read_render_settings(&mut ctx, &loaded.doc)?;
                render.frame_range.ok_or_else(|| {
                    ctx.invalid(
                        "/extensions/BRUME_render",
                        "--frames scene: the scene has no frameRange",
                    )
                })
            }
        }
    }
}

/// Frames `A..B` (both included, as a Blender frame range) or a single frame `N`.
pub fn parse_frames(s: &str) -> Result<(i32, i32), String> {
    let bad = || format!("{s:?} is not a frame range A..B (both included) or a frame N");
    let (a, b) = match s.split_once("..") {
        Some((a, b)) => (a.trim(), b.trim()),
        None => (s.trim(), s.trim()),
    };
    let a: i32 = a.parse().map_err(|_| bad())?;
    let b: i32 = b.parse().map_err(|_| bad())?;
    if b < a {
        return Err(format!(
            "frame range {a}..{b} is empty: it ends before it starts"
        ));
    }
    Ok((a, b))
}

/// Checks that every medium file of the scene at `path` exists for every frame of `a..=b`: a
/// missing one is an error naming the frame and the file, before anything is rendered.
pub fn check_files(path: &Path, a: i32, b: i32) -> Result<(), SceneError> {
    let mut ctx = Ctx::new(path);
    let loaded = super::document::read(&mut ctx, path)?;
    for node in loaded.doc.nodes() {
        let uri = node
            .extension_value(BRUME_MEDIUM_VDB)
            .and_then(|v| v.get("uri"))
            .and_then(|u| u.as_str());
        let Some(uri) = uri.filter(|u| is_sequence(u)) else {
            continue;
        };
        let pointer = format!("/nodes/{}/extensions/{BRUME_MEDIUM_VDB}/uri", node.index());
        // A malformed offset is the scene loader's to report; here it only shifts the files.
        let offset = node
            .extension_value(BRUME_MEDIUM_VDB)
            .and_then(|v| v.get("frameOffset"))
            .and_then(|o| o.as_i64())
            .map_or(0, |o| o.clamp(-MAX_FRAME_OFFSET, MAX_FRAME_OFFSET) as i32);
        for frame in a..=b {
            let file = super::document::resolve_uri(
                &ctx,
                &for_frame(uri, frame.saturating_add(offset)),
                &loaded.base_dir,
                &pointer,
            )?;
            if !file.is_file() {
                return Err(ctx.invalid(
                    pointer,
                    format!(
                        "frame {frame}: {} (from {uri:?}) does not exist",
                        file.display()
                    ),
                ));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_last_run_is_padded_to_its_length() {
        assert_eq!(for_frame("smoke_####.vdb", 7), "smoke_0007.vdb");
        assert_eq!(for_frame("smoke_####.vdb", 12345), "smoke_12345.vdb");
        assert_eq!(for_frame("smoke_####.vdb", -5), "smoke_-005.vdb");
        assert_eq!(for_frame("a#/b_##.vdb", 3), "a#/b_03.vdb");
        assert_eq!(for_frame("still.vdb", 3), "still.vdb");
        assert_eq!(hash_run("x_#.vdb"), Some((2, 1)));
        assert_eq!(
            path_for_frame(Path::new("/r#/out_###.exr"), 24),
            Path::new("/r#/out_024.exr")
        );
    }

    #[test]
    fn frame_ranges_include_both_ends() {
        assert_eq!(parse_frames("1..24"), Ok((1, 24)));
        assert_eq!(parse_frames("12"), Ok((12, 12)));
        assert_eq!(parse_frames("-2..2"), Ok((-2, 2)));
        assert!(parse_frames("5..1").unwrap_err().contains("empty"));
        assert!(parse_frames("a..b").is_err());
    }
}
