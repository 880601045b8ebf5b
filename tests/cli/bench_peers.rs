//! `brume bench peers` as a user runs it: a table with Brume's row, a peer that cannot run
//! skipped with a one-line reason, and the table written to `--out`/peers.md.
use std::process::Command;

#[test]
fn the_table_has_brumes_row_and_skips_a_missing_peer_in_one_line() {
    let out = std::env::temp_dir().join(format!("brume-bench-peers-{}", std::process::id()));
    let scene = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/plume_sun.gltf");
    let o = Command::new(env!("CARGO_BIN_EXE_brume"))
        .args(["bench", "peers"])
        .arg(&scene)
        .args(["--width", "16", "--height", "12", "--spp", "2"])
        .args(["--renderers", "brume,brume-spectral,cycles"])
        .arg("--out")
        .arg(&out)
        // A Python that cannot import bpy: Cycles must be skipped, whatever is installed.
        .env("BRUME_BPY_PYTHON", "/nonexistent/python")
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stdout}\n{stderr}");
    let row = |name: &str| {
        stdout
            .lines()
            .find(|l| l.starts_with(&format!("| plume_sun.gltf | {name} |")))
            .unwrap_or_else(|| panic!("no {name} row in\n{stdout}"))
            .to_string()
    };
    for name in ["brume", "brume-spectral"] {
        let line = row(name);
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        // seconds, per-pixel variance, efficiency and mean are positive numbers.
        for k in [3, 5, 7, 10] {
            let v: f64 = cells[k]
                .parse()
                .unwrap_or_else(|_| panic!("{name}: {:?}", cells));
            assert!(v > 0.0 && v.is_finite(), "{name}: {cells:?}");
        }
        // The variance's share in the worst 0.1 % of pixel values: a percentage.
        let top: f64 = cells[6]
            .strip_suffix(" %")
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("{name}: {cells:?}"));
        assert!((0.0..=100.0).contains(&top), "{name}: {cells:?}");
    }
    let skip = stdout
        .lines()
        .find(|l| l.starts_with("- cycles: skipped ("))
        .unwrap_or_else(|| panic!("no skip line in\n{stdout}"));
    assert!(skip.contains("BRUME_BPY_PYTHON"), "{skip}");
    let md = std::fs::read_to_string(out.join("peers.md")).unwrap();
    assert_eq!(md, stdout);
    for f in [
        "brume-seed0.exr",
        "brume-seed1.exr",
        "brume-spectral-seed0.exr",
    ] {
        assert!(out.join("plume_sun").join(f).is_file(), "{f}");
    }
    let _ = std::fs::remove_dir_all(&out);
}
