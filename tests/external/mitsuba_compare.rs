//! Brume against Mitsuba 3 (docs/comparing.md): the voxel-centre alignment
//! of the `.vol` grids `brume mitsuba` writes, checked through Mitsuba's own texture lookups,
//! and the cloud scene rendered by both (image means within 1 %, no more than 1 % of 8x8
//! blocks failing a z-test at 99.9 %). Needs a Python that can `import mitsuba`
//! (tools/mitsuba/setup.sh installs one); without it each test prints a visible SKIPPED line
//! and returns. Seeds are fixed on both sides, so the outcome is deterministic.
use crate::common;
use crate::common::external::say;

use std::path::{Path, PathBuf};
use std::process::Command;

use brume::math::DVec3;
use brume::volume::mitsuba_vol::vol_from_grid;
use brume::volume::SparseGrid;

fn mitsuba_python() -> Result<PathBuf, String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let p = std::env::var_os("BRUME_MITSUBA_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join("tools/mitsuba/.venv/bin/python"));
    let out = Command::new(&p)
        .args(["-c", "import mitsuba"])
        .output()
        .map_err(|e| format!("{}: {e} (run tools/mitsuba/setup.sh)", p.display()))?;
    if out.status.success() {
        Ok(p)
    } else {
        Err(format!(
            "{} cannot `import mitsuba` (run tools/mitsuba/setup.sh)",
            p.display()
        ))
    }
}

fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("brume-mitsuba-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A small grid at an odd offset, written as `brume mitsuba` writes it, read back
/// by Mitsuba's `gridvolume` (through the translation script's own `extinction_texture`, with
/// a non-trivial index-to-world map) at points inside, between and around the voxels: the
/// values match Brume's trilinear lookups at the same world points.
#[test]
fn vol_texels_align_with_brume_voxels() {
    let python = match mitsuba_python() {
        Ok(p) => p,
        Err(why) => {
            say(&format!("SKIPPED: mitsuba_compare alignment: {why}"));
            return;
        }
    };
    let dims = [5, 4, 3];
    let values: Vec<f32> = (0..60)
        .map(|i| ((i * 7) % 13) as f32 * 0.25 + 0.5)
        .collect();
    let (grid, _) = SparseGrid::from_dense(dims, [-3, 2, 10], &values, 0.0).unwrap();
    let scale = 3.0f32;
    let vol = vol_from_grid(&grid, &[scale]).unwrap();
    let dir = temp_dir("align");
    let vol_path = dir.join("grid.vol");
    vol.write(&vol_path).unwrap();
    // world = index * (0.5, 0.25, 2) + (1, -2, 3)
    let voxel = DVec3::new(0.5, 0.25, 2.0);
    let offset = DVec3::new(1.0, -2.0, 3.0);
    let to_world = [
        [voxel.x, 0.0, 0.0, offset.x],
        [0.0, voxel.y, 0.0, offset.y],
        [0.0, 0.0, voxel.z, offset.z],
        [0.0, 0.0, 0.0, 1.0],
    ];
    let mut points = Vec::new();
    for s in 0..300u64 {
        let h = |k: u64| ((s * 2654435761 + k * 40503) % 9973) as f64 / 9973.0;
        // Index space from 2 voxels outside the data to 2 beyond.
        let idx = DVec3::new(-5.0 + 9.0 * h(1), 0.0 + 8.0 * h(2), 8.0 + 7.0 * h(3));
        points.push(idx);
    }
    // Voxel centres and the faces of the written box too.
    points.extend([
        DVec3::new(-3.0, 2.0, 10.0),
        DVec3::new(1.0, 5.0, 12.0),
        DVec3::new(-4.5, 3.0, 11.0),
        DVec3::new(2.5, 3.0, 11.0),
    ]);
    let world: Vec<[f64; 3]> = points
        .iter()
        .map(|p| (*p * voxel + offset).to_array())
        .collect();
    let description = serde_json::json!({
        "vol": vol_path,
        "to_world": to_world,
        "box_min": vol.bbox_min,
        "box_max": vol.bbox_max,
        "points": world,
    });
    let json_path = dir.join("points.json");
    std::fs::write(&json_path, description.to_string()).unwrap();
    let tools = Path::new(env!("CARGO_MANIFEST_DIR")).join("tools/mitsuba");
    let code = "import json, sys\n\
        import mitsuba as mi\n\
        mi.set_variant('scalar_rgb')\n\
        sys.path.insert(0, sys.argv[1])\n\
        import brume_to_mitsuba as b\n\
        d = json.load(open(sys.argv[2]))\n\
        tex = mi.load_dict(b.extinction_texture(d))\n\
        for p in d['points']:\n\
        \x20   it = mi.Interaction3f()\n\
        \x20   it.p = mi.ScalarPoint3f(p)\n\
        \x20   print(repr(float(tex.eval_1(it))))\n";
    let out = Command::new(&python)
        .args(["-c", code])
        .arg(&tools)
        .arg(&json_path)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let got: Vec<f64> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| l.trim().parse().unwrap())
        .collect();
    assert_eq!(got.len(), points.len());
    let mut worst = 0f64;
    for (p, m) in points.iter().zip(&got) {
        let brume = scale as f64 * grid.sample_trilinear(*p) as f64;
        let err = (m - brume).abs();
        worst = worst.max(err);
        // Mitsuba computes texel coordinates in float32 through two transforms.
        assert!(
            err < 1e-4 * (1.0 + brume.abs()),
            "index point {p}: Mitsuba {m}, Brume {brume}"
        );
    }
    say(&format!(
        "mitsuba_compare: {} lookups, largest |Mitsuba - Brume| {worst:.2e}",
        got.len()
    ));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn cloud_agrees_with_mitsuba() {
    let python = match mitsuba_python() {
        Ok(p) => p,
        Err(why) => {
            say(&format!("SKIPPED: mitsuba_compare cloud: {why}"));
            return;
        }
    };
    let dir = temp_dir("cloud");
    let summary = common::reference::cloud_agrees_with(
        "mitsuba",
        "64",
        ("BRUME_MITSUBA_PYTHON", &python),
        &dir,
    );
    say(&format!("mitsuba_compare: cloud 32x24: {summary}"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// The two-lobe phase against Mitsuba 3's `blendphase` of two `hg` lobes, and Rayleigh against
/// its `rayleigh`, on the cloud; Draine and Mie, which Mitsuba lacks, are refused by name.
#[test]
fn blended_and_rayleigh_phases_agree_with_mitsuba() {
    let python = match mitsuba_python() {
        Ok(p) => p,
        Err(why) => {
            say(&format!("SKIPPED: mitsuba_compare phases: {why}"));
            return;
        }
    };
    let dir = temp_dir("phase");
    for (label, phase) in [
        (
            "two_lobe",
            serde_json::json!({"type": "two-lobe", "g1": 0.85, "g2": -0.3, "weight": 0.8}),
        ),
        ("rayleigh", serde_json::json!({"type": "rayleigh"})),
    ] {
        let scene = common::reference::cloud_with_phase(&dir, label, phase);
        let run = dir.join(label);
        std::fs::create_dir_all(&run).unwrap();
        let summary = common::reference::scene_agrees_with(
            scene.to_str().unwrap(),
            "mitsuba",
            "64",
            ("BRUME_MITSUBA_PYTHON", &python),
            &run,
        );
        say(&format!("mitsuba_compare: phase {label} 32x24: {summary}"));
    }
    let scene = common::reference::cloud_with_phase(
        &dir,
        "mie",
        serde_json::json!({"type": "mie", "diameter": 20.0}),
    );
    let o = Command::new(env!("CARGO_BIN_EXE_brume"))
        .args(["mitsuba", scene.to_str().unwrap(), "-o"])
        .arg(dir.join("no.exr"))
        .env("BRUME_MITSUBA_PYTHON", &python)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("no mie phase function"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
