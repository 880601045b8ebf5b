//! What makes two parts parts of one image: the settings that shape its pixels
//! ([`settings_key`]) and a content hash of the scene and every file it references
//! ([`scene_hash`]).
use std::path::Path;

use super::part::PartError;
use crate::film::FilmError;
use crate::scene::sequence;

/// The image-shaping settings as `key=value` words (everything but the sample range, region,
/// tile size, time limit and thread count, which do not change a pixel's samples).
pub fn settings_key(s: &crate::render::RenderSettings, camera: Option<&str>) -> String {
    let film = if s.film_transparent {
        " film=transparent"
    } else {
        ""
    };
    let passes = match s.pass_names().is_empty() {
        true => String::new(),
        false => format!(" passes={}", s.pass_names().join(",")),
    };
    let blackbody = match s.blackbody {
        crate::render::settings::BlackbodyModel::Temperature => "",
        crate::render::settings::BlackbodyModel::Voxels => " blackbody=voxels",
    };
    let volume_sampling = match s.volume_sampling {
        crate::render::VolumeSampling::Mis => String::new(),
        other => format!(" volume_sampling={}", other.name()),
    };
    let media_lights = if s.media_lights {
        ""
    } else {
        " media_lights=off"
    };
    let adaptive = s.noise_threshold.map_or(String::new(), |e| {
        format!(" noise_threshold={e} min_spp={}", s.min_spp)
    });
    format!(
        "estimator={} b={} m={} majorant={} shadow={:?} spectral={} absorption={} generic={} \
         sampler={} max_depth={} rr_depth={} rr_throughput={} max_pass_spp={} \
         max_collisions={} env_sampling={} light_selection={} camera={}{film}{passes}{adaptive}{blackbody}{volume_sampling}{media_lights}",
        s.estimator,
        s.b,
        s.m_or_default()
            .map_or("minorant".into(), |m| m.to_string()),
        s.majorant.name(),
        s.shadow,
        s.force_spectral,
        s.absorption.name(),
        s.generic,
        s.sampler.name(),
        s.max_depth,
        s.rr_depth,
        s.rr_throughput,
        s.max_pass_spp,
        s.max_collisions_per_path,
        s.env_sampling,
        s.light_selection.name(),
        camera.unwrap_or("-"),
    )
}

/// FNV-1a 64 (stable across builds and machines, unlike `std`'s hasher).
struct Fnv(u64);

impl Fnv {
    fn new() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
    fn eat(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= b as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
}

/// A content hash of a scene: FNV-1a 64 over the scene file and every file its JSON refers to
/// by a relative `uri` (buffers, images, OpenVDB grids, environment maps), in sorted order,
/// each preceded by its URI. Files that cannot be read are hashed by name only (the scene
/// loader reports them). A sequence's `uri` (a run of `#`) is read for `frame`, and the frame
/// is hashed too, so the parts of two frames never merge.
pub fn scene_hash(scene: &Path, frame: i32) -> Result<String, PartError> {
    let bytes = std::fs::read(scene).map_err(|e| FilmError::io("read", scene, e))?;
    let mut h = Fnv::new();
    h.eat(&bytes);
    // A .glb holds its JSON in the first chunk, after a 12-byte header and an 8-byte chunk
    // header; a .gltf is JSON.
    let json_bytes = if bytes.starts_with(b"glTF") && bytes.len() >= 20 {
        let len = u32::from_le_bytes([bytes[12], bytes[13], bytes[14], bytes[15]]) as usize;
        &bytes[20..(20 + len).min(bytes.len())]
    } else {
        &bytes[..]
    };
    let mut uris = Vec::new();
    if let Ok(json) = serde_json::from_slice::<serde_json::Value>(json_bytes) {
        collect_uris(&json, &mut uris);
    }
    uris.sort();
    uris.dedup();
    let base = scene.parent().unwrap_or(Path::new("."));
    if uris.iter().any(|(u, _)| sequence::is_sequence(u)) {
        h.eat(&frame.to_le_bytes());
    }
    for (uri, offset) in uris {
        h.eat(uri.as_bytes());
        h.eat(&[0]);
        let uri = sequence::for_frame(&uri, frame.saturating_add(offset));
        // Streamed: a referenced VDB can be larger than memory allows to hold twice.
        if let Ok(mut f) = std::fs::File::open(base.join(&uri)) {
            use std::io::Read;
            let mut buf = vec![0u8; 1 << 20];
            loop {
                match f.read(&mut buf) {
                    Ok(0) | Err(_) => break,
                    Ok(n) => h.eat(&buf[..n]),
                }
            }
        }
    }
    Ok(format!("{:016x}", h.0))
}

/// Every relative `uri` under `v`, with the `frameOffset` beside it (a medium sequence's; 0
/// elsewhere).
fn collect_uris(v: &serde_json::Value, out: &mut Vec<(String, i32)>) {
    match v {
        serde_json::Value::Object(map) => {
            let offset = map
                .get("frameOffset")
                .and_then(|o| o.as_i64())
                .map_or(0, |o| {
                    o.clamp(-sequence::MAX_FRAME_OFFSET, sequence::MAX_FRAME_OFFSET) as i32
                });
            for (k, v) in map {
                match v {
                    serde_json::Value::String(s) if k == "uri" && !s.starts_with("data:") => {
                        out.push((s.clone(), offset))
                    }
                    _ => collect_uris(v, out),
                }
            }
        }
        serde_json::Value::Array(a) => a.iter().for_each(|v| collect_uris(v, out)),
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sequence's hash reads the file its `frameOffset` names for the frame, not the one
    /// numbered like the frame.
    #[test]
    fn a_sequence_hash_follows_its_frame_offset() {
        let d = std::env::temp_dir().join(format!("brume-key-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        let scene = d.join("s.gltf");
        let medium = r#"{"BRUME_medium_vdb": {"uri": "m_####.vdb", "frameOffset": 10}}"#;
        let json = format!(r#"{{"nodes": [{{"extensions": {medium}}}]}}"#);
        std::fs::write(&scene, json).unwrap();
        let hash = |own: &str, other: &str| {
            std::fs::write(d.join("m_0011.vdb"), own).unwrap();
            std::fs::write(d.join("m_0001.vdb"), other).unwrap();
            scene_hash(&scene, 1).unwrap()
        };
        let base = hash("a", "b");
        assert_eq!(base, hash("a", "c"), "frame 1 does not read file 1");
        assert_ne!(base, hash("d", "b"), "frame 1 reads file 11");
        std::fs::remove_dir_all(&d).ok();
    }
}
