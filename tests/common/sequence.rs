//! A frame sequence made from the example grids: the cloud scene reading `cloud_####.vdb`.
use std::path::{Path, PathBuf};

/// Writes `dir/seq.gltf`, the cloud scene with its medium read from `cloud_####.vdb` in `dir`,
/// and the files of `frames`: the cloud on odd frames, the smoke plume on even ones (links to
/// the example files, copies where links fail).
pub fn cloud_sequence(dir: &Path, frames: impl IntoIterator<Item = i32>) -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    std::fs::create_dir_all(dir).unwrap();
    for f in frames {
        let source = root
            .join("vdb")
            .join(if f % 2 == 0 { "smoke.vdb" } else { "cloud.vdb" });
        let file = dir.join(format!("cloud_{f:04}.vdb"));
        if std::fs::hard_link(&source, &file).is_err() {
            std::fs::copy(&source, &file).unwrap();
        }
    }
    let json = std::fs::read_to_string(root.join("cloud.gltf")).unwrap();
    assert!(json.contains("\"vdb/cloud.vdb\""));
    let scene = dir.join("seq.gltf");
    std::fs::write(
        &scene,
        json.replace("\"vdb/cloud.vdb\"", "\"cloud_####.vdb\""),
    )
    .unwrap();
    scene
}
