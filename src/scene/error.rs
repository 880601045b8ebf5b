//! The one error type of scene loading. Every message names the glTF file and, where the fault
//! lies in the document, the JSON pointer (RFC 6901) of the offending value, so a user can jump
//! straight to it.
use std::fmt;
use std::path::{Path, PathBuf};

/// A scene that could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The glTF file (or a file it references) could not be read.
    #[error("{file}{}: cannot read {what}: {source}", at(pointer))]
    Io {
        file: PathBuf,
        pointer: String,
        what: String,
        #[source]
        source: std::io::Error,
    },
    /// The file is not syntactically valid JSON or GLB (the message carries line and column).
    #[error("{file}: not a valid glTF file: {message}")]
    Parse { file: PathBuf, message: String },
    /// The document is well-formed but a value at `pointer` is invalid or unsupported.
    #[error("{file}: {pointer}: {message}")]
    Invalid {
        file: PathBuf,
        pointer: String,
        message: String,
    },
}

/// `": /pointer"`, or nothing for whole-file errors.
fn at(pointer: &str) -> String {
    if pointer.is_empty() {
        String::new()
    } else {
        format!(": {pointer}")
    }
}

impl SceneError {
    /// The JSON pointer of the fault, empty for whole-file errors.
    pub fn pointer(&self) -> &str {
        match self {
            SceneError::Io { pointer, .. } | SceneError::Invalid { pointer, .. } => pointer,
            SceneError::Parse { .. } => "",
        }
    }

    /// The glTF file the error belongs to.
    pub fn file(&self) -> &Path {
        match self {
            SceneError::Io { file, .. }
            | SceneError::Parse { file, .. }
            | SceneError::Invalid { file, .. } => file,
        }
    }
}

/// Builds errors and warnings for one file; threaded through every loader stage.
#[derive(Debug)]
pub struct Ctx {
    /// The glTF file being loaded, as given by the caller.
    pub file: PathBuf,
    /// Non-fatal problems, each prefixed with its JSON pointer.
    pub warnings: Vec<String>,
}

impl Ctx {
    pub fn new(file: &Path) -> Self {
        Self {
            file: file.to_path_buf(),
            warnings: Vec::new(),
        }
    }

    /// An [`SceneError::Invalid`] at `pointer`.
    pub fn invalid(&self, pointer: impl Into<String>, message: impl fmt::Display) -> SceneError {
        SceneError::Invalid {
            file: self.file.clone(),
            pointer: pointer.into(),
            message: message.to_string(),
        }
    }

    /// Records a non-fatal problem at `pointer`.
    pub fn warn(&mut self, pointer: impl fmt::Display, message: impl fmt::Display) {
        self.warnings.push(format!("{pointer}: {message}"));
    }
}

/// Converts a gltf-json validation path (`meshes[0].primitives[1].attributes["POSITION"]`)
/// into a JSON pointer (`/meshes/0/primitives/1/attributes/POSITION`).
pub fn path_to_pointer(path: &str) -> String {
    let mut out = String::with_capacity(path.len() + 1);
    out.push('/');
    for c in path.chars() {
        match c {
            '.' | '[' => {
                if !out.ends_with('/') {
                    out.push('/')
                }
            }
            ']' | '"' => {}
            c => out.push(c),
        }
    }
    if out.len() > 1 && out.ends_with('/') {
        out.pop();
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validation_paths_become_pointers() {
        assert_eq!(
            path_to_pointer("meshes[0].primitives[1].attributes[\"POSITION\"]"),
            "/meshes/0/primitives/1/attributes/POSITION"
        );
        assert_eq!(path_to_pointer("nodes[3]"), "/nodes/3");
    }
}
