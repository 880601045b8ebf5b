//! Reading a `.gltf`/`.glb` file into a validated `gltf::Document` plus its buffers.
//!
//! Brume does not use the `gltf` crate's `import` feature: it would pull in an image decoder
//! with every codec, and its errors do not say where in the document a buffer went wrong.
//! Instead this module checks `extensionsRequired` against what Brume understands (the gltf
//! crate would reject Brume's own extensions), lets gltf-json validate indices and enums, and
//! loads buffers itself, checking each against its declared `byteLength`.
use std::path::{Path, PathBuf};

use serde_json::Value;

use super::error::{path_to_pointer, Ctx, SceneError};

/// Extensions Brume honours, so a file may list them in `extensionsRequired`.
pub const SUPPORTED_EXTENSIONS: &[&str] = &[
    super::gpu_instancing::EXT_MESH_GPU_INSTANCING,
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    super::BRUME_ENVIRONMENT,
    super::BRUME_MEDIUM_VDB,
    super::BRUME_MATERIALS_VOLUME_SCATTERING,
];

/// A parsed, validated glTF document with its buffers in memory.
pub struct LoadedDocument {
    pub doc: gltf::Document,
    /// Buffer contents by buffer index, each exactly `byteLength` long.
    pub buffers: Vec<Vec<u8>>,
    /// Directory relative URIs resolve against.
    pub base_dir: PathBuf,
}

/// Reads and validates `path`.
pub fn read(ctx: &mut Ctx, path: &Path) -> Result<LoadedDocument, SceneError> {
    let bytes = std::fs::read(path).map_err(|source| SceneError::Io {
        file: ctx.file.clone(),
        pointer: String::new(),
        what: "the glTF file".into(),
        source,
    })?;
    let parse_err = |message: String| SceneError::Parse {
        file: ctx.file.clone(),
        message,
    };

    // A GLB container holds the JSON chunk and an optional binary chunk (buffer 0).
    let (json_bytes, blob): (Vec<u8>, Option<Vec<u8>>) = if bytes.starts_with(b"glTF") {
        let glb = gltf::binary::Glb::from_slice(&bytes)
            .map_err(|e| parse_err(format!("GLB container: {e}")))?;
        (glb.json.into_owned(), glb.bin.map(|b| b.into_owned()))
    } else {
        (bytes, None)
    };
    let mut value: Value =
        serde_json::from_slice(&json_bytes).map_err(|e| parse_err(format!("JSON: {e}")))?;

    check_required_extensions(ctx, &mut value)?;

    let root = <gltf::json::Root as serde::Deserialize>::deserialize(&value)
        .map_err(|e| parse_err(format!("glTF schema: {e}")))?;
    let doc = gltf::Document::from_json(root).map_err(|e| match e {
        gltf::Error::Validation(errors) => {
            let (path, err) = &errors[0];
            let more = if errors.len() > 1 {
                format!(" (and {} more)", errors.len() - 1)
            } else {
                String::new()
            };
            let pointer = path_to_pointer(path.as_str());
            let what = match err {
                gltf::json::validation::Error::IndexOutOfBounds => out_of_range(&value, &pointer),
                other => other.to_string(),
            };
            ctx.invalid(pointer, format!("{what}{more}"))
        }
        other => parse_err(other.to_string()),
    })?;

    let base_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let buffers = load_buffers(ctx, &doc, blob, &base_dir)?;
    check_views(ctx, &doc)?;
    Ok(LoadedDocument {
        doc,
        buffers,
        base_dir,
    })
}

/// What is wrong with the index at `pointer` that gltf-json found out of range: its value and
/// the length of the array it indexes, where the pointer's last names say which array.
fn out_of_range(value: &Value, pointer: &str) -> String {
    let index = value.pointer(pointer).map_or("?".into(), Value::to_string);
    let mut names = pointer.rsplit('/').filter(|s| s.parse::<u64>().is_err());
    let array = match (names.next(), names.next()) {
        (Some("mesh"), _) => "meshes",
        (Some("camera"), _) => "cameras",
        (Some("material"), _) => "materials",
        (Some("skin"), _) => "skins",
        (Some("children" | "nodes" | "node"), _) => "nodes",
        (Some("indices"), _) | (_, Some("attributes" | "targets")) => "accessors",
        (Some("input" | "output" | "inverseBindMatrices"), _) => "accessors",
        (Some("bufferView"), _) => "bufferViews",
        (Some("buffer"), _) => "buffers",
        (Some("scene"), _) => "scenes",
        (Some("sampler"), _) if !pointer.starts_with("/animations") => "samplers",
        (Some("index"), _) => "textures",
        (Some("source"), _) => "images",
        _ => "",
    };
    match value.get(array).and_then(Value::as_array) {
        Some(items) if !array.is_empty() => format!(
            "index {index} is out of range: the file has {} {array}",
            items.len()
        ),
        _ if !array.is_empty() => format!("index {index} is out of range: the file has no {array}"),
        _ => format!("index {index} is out of range"),
    }
}

/// Rejects required extensions Brume does not implement, then removes the ones it does from
/// the list so gltf-json (which knows nothing of `BRUME_*`) accepts the document.
fn check_required_extensions(ctx: &Ctx, value: &mut Value) -> Result<(), SceneError> {
    let Some(list) = value.get_mut("extensionsRequired") else {
        return Ok(());
    };
    let Some(arr) = list.as_array_mut() else {
        return Err(ctx.invalid("/extensionsRequired", "expected an array of strings"));
    };
    for (i, ext) in arr.iter().enumerate() {
        let name = ext
            .as_str()
            .ok_or_else(|| ctx.invalid(format!("/extensionsRequired/{i}"), "expected a string"))?;
        if !SUPPORTED_EXTENSIONS.contains(&name) {
            return Err(ctx.invalid(
                format!("/extensionsRequired/{i}"),
                format!(
                    "required extension {name} is not supported by Brume (supported: {})",
                    SUPPORTED_EXTENSIONS.join(", ")
                ),
            ));
        }
    }
    arr.clear();
    Ok(())
}

/// Loads every buffer: the GLB binary chunk, a base64 `data:` URI or a file next to the glTF.
fn load_buffers(
    ctx: &mut Ctx,
    doc: &gltf::Document,
    mut blob: Option<Vec<u8>>,
    base: &Path,
) -> Result<Vec<Vec<u8>>, SceneError> {
    let mut out = Vec::new();
    for buffer in doc.buffers() {
        let i = buffer.index();
        let declared = buffer.length();
        let (mut data, glb) = match buffer.source() {
            gltf::buffer::Source::Bin => {
                let data = blob.take().ok_or_else(|| {
                    ctx.invalid(
                        format!("/buffers/{i}"),
                        "buffer has no uri but the file has no GLB binary chunk",
                    )
                })?;
                (data, true)
            }
            gltf::buffer::Source::Uri(uri) => (
                read_uri(ctx, uri, base, &format!("/buffers/{i}/uri"), "buffer")?,
                false,
            ),
        };
        if data.len() < declared {
            return Err(ctx.invalid(
                format!("/buffers/{i}/byteLength"),
                format!(
                    "byteLength is {declared} but the buffer holds only {} bytes",
                    data.len()
                ),
            ));
        }
        // The GLB chunk may carry up to 3 bytes of padding; anything longer is suspicious.
        if data.len() > declared && !(glb && data.len() - declared <= 3) {
            ctx.warn(
                format!("/buffers/{i}/byteLength"),
                format!(
                    "byteLength is {declared} but the buffer holds {} bytes; the rest is ignored",
                    data.len()
                ),
            );
        }
        data.truncate(declared);
        out.push(data);
    }
    Ok(out)
}

/// Reads an external file or a base64 `data:` URI.
pub fn read_uri(
    ctx: &Ctx,
    uri: &str,
    base: &Path,
    pointer: &str,
    what: &str,
) -> Result<Vec<u8>, SceneError> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let Some((_, payload)) = rest.split_once(";base64,") else {
            return Err(ctx.invalid(pointer, "only base64 data URIs are supported"));
        };
        return decode_base64(payload)
            .map_err(|e| ctx.invalid(pointer, format!("bad base64 data: {e}")));
    }
    let path = resolve_uri(ctx, uri, base, pointer)?;
    std::fs::read(&path).map_err(|source| SceneError::Io {
        file: ctx.file.clone(),
        pointer: pointer.to_string(),
        what: format!("{what} {}", path.display()),
        source,
    })
}

/// Resolves a relative URI (percent-encoding decoded) against the glTF file's directory.
pub fn resolve_uri(
    ctx: &Ctx,
    uri: &str,
    base: &Path,
    pointer: &str,
) -> Result<PathBuf, SceneError> {
    if uri.contains("://") || uri.starts_with("data:") {
        return Err(ctx.invalid(pointer, format!("URI {uri:?} is not a relative file path")));
    }
    let decoded = percent_decode(uri)
        .ok_or_else(|| ctx.invalid(pointer, format!("URI {uri:?} has bad percent-encoding")))?;
    Ok(base.join(decoded))
}

fn percent_decode(s: &str) -> Option<String> {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = s.get(i + 1..i + 3)?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

/// Standard base64 (RFC 4648) with optional padding; whitespace is not allowed in glTF.
pub fn decode_base64(s: &str) -> Result<Vec<u8>, String> {
    fn sextet(c: u8) -> Option<u32> {
        Some(match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' => 62,
            b'/' => 63,
            _ => return None,
        } as u32)
    }
    let s = s.trim_end_matches('=').as_bytes();
    if s.len() % 4 == 1 {
        return Err("truncated base64 data".into());
    }
    let mut out = Vec::with_capacity(s.len() * 3 / 4);
    for chunk in s.chunks(4) {
        let mut acc = 0u32;
        for (k, &c) in chunk.iter().enumerate() {
            let v = sextet(c).ok_or_else(|| format!("invalid base64 character {:?}", c as char))?;
            acc |= v << (18 - 6 * k);
        }
        let n = chunk.len() * 6 / 8;
        for k in 0..n {
            out.push((acc >> (16 - 8 * k)) as u8);
        }
    }
    Ok(out)
}

/// Buffer views must lie inside their buffers (gltf-json does not check byte ranges, and the
/// accessor readers would panic on a short slice).
fn check_views(ctx: &Ctx, doc: &gltf::Document) -> Result<(), SceneError> {
    for view in doc.views() {
        let end = view.offset().checked_add(view.length());
        let len = view.buffer().length();
        if !matches!(end, Some(e) if e <= len) {
            return Err(ctx.invalid(
                format!("/bufferViews/{}", view.index()),
                format!(
                    "byteOffset {} + byteLength {} exceeds buffer {} ({len} bytes)",
                    view.offset(),
                    view.length(),
                    view.buffer().index()
                ),
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_round_trips_known_vectors() {
        assert_eq!(decode_base64("").unwrap(), b"");
        assert_eq!(decode_base64("Zg==").unwrap(), b"f");
        assert_eq!(decode_base64("Zm8=").unwrap(), b"fo");
        assert_eq!(decode_base64("Zm9v").unwrap(), b"foo");
        assert_eq!(decode_base64("Zm9vYmFy").unwrap(), b"foobar");
        assert!(decode_base64("Zm9v!").is_err());
    }

    #[test]
    fn percent_decoding() {
        assert_eq!(percent_decode("a%20b.bin").unwrap(), "a b.bin");
        assert!(percent_decode("a%2").is_none());
    }
}
