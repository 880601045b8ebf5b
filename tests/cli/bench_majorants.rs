//! `brume bench render --majorants-only` as a user runs it: the four modes and the floor on a
//! scene whose medium does not emit, no floor on one whose medium emits.
use std::process::Command;

/// The whitespace-separated cells of the table row of `scene`, `estimator` and `bounds`.
fn row(stdout: &str, scene: &str, estimator: &str, bounds: &str) -> Option<Vec<String>> {
    stdout
        .lines()
        .map(|l| l.split_whitespace().map(str::to_string).collect::<Vec<_>>())
        .find(|c| c.len() > 3 && c[0] == scene && c[1] == estimator && c[2] == bounds)
}

#[test]
fn the_floor_row_makes_no_collision_and_is_left_out_where_a_medium_emits() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let o = Command::new(env!("CARGO_BIN_EXE_brume"))
        .args(["bench", "render", "--majorants-only", "--runs", "2"])
        .args(["--width", "16", "--height", "12", "--spp", "2"])
        .arg(dir.join("smoke_tank.gltf"))
        .arg(dir.join("fire.gltf"))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stdout}\n{stderr}");
    for estimator in ["delta", "decomposition"] {
        for bounds in ["global", "leaf", "culled", "adaptive"] {
            for scene in ["smoke_tank.gltf", "fire.gltf"] {
                assert!(
                    row(&stdout, scene, estimator, bounds).is_some(),
                    "no {scene} {estimator} {bounds} row in\n{stdout}"
                );
            }
        }
        let floor = row(&stdout, "smoke_tank.gltf", estimator, "floor")
            .unwrap_or_else(|| panic!("no floor row in\n{stdout}"));
        // Columns: ns/sample 3, vs global 4, rounds 5, segs prim 6, segs shad 7, lookups 8,
        // emit look 9, real coll 10, lookups/real 11, var/px 12.
        let ns: f64 = floor[3].parse().unwrap();
        assert!(ns > 0.0 && ns.is_finite(), "{floor:?}");
        // A medium of a millionth of its density: the walks run, the collisions are gone.
        assert_eq!(floor[10], "0.000", "{floor:?}");
        assert!(floor[6].parse::<f64>().unwrap() > 0.0, "{floor:?}");
        assert_eq!(floor[12], "-", "{floor:?}");
        assert!(
            row(&stdout, "fire.gltf", estimator, "floor").is_none(),
            "the fire emits: no floor\n{stdout}"
        );
        assert!(
            stdout.lines().any(|l| l.contains("smoke_tank.gltf")
                && l.contains(estimator)
                && l.contains("1.2x needs")),
            "no floor note for {estimator} in\n{stdout}"
        );
    }
}
