//! Atomic file output: a reader sees either the old file or the complete new one, never a
//! half-written file, even if the process dies mid-write.
//!
//! The data goes to a temporary file in the destination's directory (a rename is only atomic
//! within one file system), named `.NAME.tmp-PID-N` (N counts writes within the process, so two
//! threads writing the same path do not share a temporary file). It is fsynced, then renamed
//! over the destination, then the directory is fsynced so the rename itself survives a crash.
//! On any failure the temporary file is removed and the destination is left as it was.
use super::error::FilmError;
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

static NEXT_TEMP: AtomicU64 = AtomicU64::new(0);

/// A file being written that becomes visible under its final name only at [`commit`].
/// Dropping it uncommitted removes the temporary file.
///
/// [`commit`]: AtomicFile::commit
#[derive(Debug)]
pub struct AtomicFile {
    final_path: PathBuf,
    temp_path: PathBuf,
    /// `None` once committed.
    file: Option<File>,
}

impl AtomicFile {
    /// Creates the temporary file next to `path`.
    pub fn create(path: impl AsRef<Path>) -> Result<Self, FilmError> {
        let final_path = path.as_ref().to_path_buf();
        let name = final_path
            .file_name()
            .ok_or_else(|| FilmError::InvalidInput {
                path: final_path.clone(),
                reason: "the path does not name a file".into(),
            })?;
        let temp_name = format!(
            ".{}.tmp-{}-{}",
            name.to_string_lossy(),
            std::process::id(),
            NEXT_TEMP.fetch_add(1, Ordering::Relaxed)
        );
        let temp_path = final_path.with_file_name(temp_name);
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&temp_path)
            .map_err(|e| FilmError::io("create", &final_path, e))?;
        Ok(Self {
            final_path,
            temp_path,
            file: Some(file),
        })
    }

    /// The file to write into.
    pub fn file(&mut self) -> &mut File {
        self.file
            .as_mut()
            .expect("an AtomicFile is only used before commit")
    }

    /// The destination path.
    pub fn path(&self) -> &Path {
        &self.final_path
    }

    /// Flushes the data to disk and renames the temporary file into place.
    pub fn commit(mut self) -> Result<(), FilmError> {
        let file = self.file.take().expect("commit runs once");
        let synced = file.sync_all();
        drop(file);
        synced.map_err(|e| FilmError::io("sync", &self.final_path, e))?;
        std::fs::rename(&self.temp_path, &self.final_path)
            .map_err(|e| FilmError::io("rename into place", &self.final_path, e))?;
        // The rename is done; from here the temporary file no longer exists.
        self.temp_path = PathBuf::new();
        sync_parent_dir(&self.final_path);
        Ok(())
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if !self.temp_path.as_os_str().is_empty() {
            self.file = None;
            // Best effort: the caller is already returning the error that brought us here.
            let _ = std::fs::remove_file(&self.temp_path);
        }
    }
}

/// Makes a completed rename durable. Best effort: some file systems refuse to fsync a
/// directory, and the data itself is already safe.
fn sync_parent_dir(path: &Path) {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
}

/// Checks, before any work is spent, that [`write_atomically`] could put a file at `path`:
/// its folder exists, `path` is not a folder, and a file can be created beside it (which
/// catches a read-only file system and missing permissions). Nothing is left behind.
pub fn check_writable(path: impl AsRef<Path>) -> Result<(), FilmError> {
    let path = path.as_ref();
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let refuse = |reason: String| FilmError::InvalidInput {
        path: path.to_path_buf(),
        reason,
    };
    if !dir.is_dir() {
        return Err(refuse(format!(
            "the folder {} does not exist",
            dir.display()
        )));
    }
    if path.is_dir() {
        return Err(refuse("it is a folder".into()));
    }
    AtomicFile::create(path).map(drop).map_err(|e| match e {
        FilmError::Io { source, .. } => refuse(format!(
            "the folder {} cannot be written: {source}",
            dir.display()
        )),
        e => e,
    })
}

/// Writes `path` atomically: `write` fills the temporary file, which then replaces `path`.
/// If `write` fails, the temporary file is removed and `path` is untouched.
pub fn write_atomically(
    path: impl AsRef<Path>,
    write: impl FnOnce(&mut File) -> Result<(), FilmError>,
) -> Result<(), FilmError> {
    let mut out = AtomicFile::create(path)?;
    write(out.file())?;
    out.file()
        .flush()
        .map_err(|e| FilmError::io("write", &out.final_path, e))?;
    out.commit()
}
