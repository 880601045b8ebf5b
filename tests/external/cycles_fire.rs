//! A real fire bake against Blender Cycles: tools/cycles/mantaflow_smoke.py `--fire` bakes a
//! small burning Mantaflow simulation headless (OpenVDB cache with `density`, `flame` and
//! `temperature`), and a glTF places its last frame over the example fire's floor. Cycles reads
//! each voxel's temperature for its blackbody (stochastic voxel lookups), so Brume agrees with
//! it pass by pass with `--blackbody voxels`, and its default model (the blackbody of the
//! interpolated temperature) differs where the temperature changes from voxel to voxel.
//! Needs a Python that can `import bpy`; without it the test prints a SKIPPED line and passes.
use crate::common;
use crate::common::external::{assert_ok, root, say, BpyRun};

use std::path::{Path, PathBuf};
use std::process::Command;

const FRAMES: &str = "24";

/// The example fire's floor, camera and sky with the bake's last frame as its medium: the
/// cache's z (Blender's up) turned to glTF's y, its 2 m domain centred over the floor.
fn fire_scene(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(root().join("scenes/fire.gltf")).unwrap();
    let mut doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    let vdb = dir.join(format!("cache/data/fluid_data_00{FRAMES}.vdb"));
    let h = std::f64::consts::FRAC_1_SQRT_2;
    doc["nodes"][1] = serde_json::json!({
        "name": "mantaflow_fire",
        "rotation": [-h, 0.0, 0.0, h],
        "translation": [-1.0, 0.0, 1.0],
        "extensions": {"BRUME_medium_vdb": {
            "uri": vdb.to_str().unwrap(), "densityGrid": "density", "densityScale": 4.0,
            "color": [0.3, 0.3, 0.3], "absorptionColor": [0.0, 0.0, 0.0],
            "emissionGrid": "flame", "emissionStrength": 4.0, "emissionColor": [1.0, 0.45, 0.1],
            "temperatureGrid": "temperature", "blackbodyIntensity": 1.0,
            "temperatureScale": 1000.0, "temperatureOffset": 0.0}}
    });
    doc["cameras"][0]["perspective"]["yfov"] = serde_json::json!(0.32);
    doc["nodes"][2]["translation"] = serde_json::json!([0.0, 1.0, 7.5]);
    doc["nodes"][2].as_object_mut().unwrap().remove("rotation");
    let scene = dir.join("mantaflow_fire.gltf");
    std::fs::write(&scene, serde_json::to_string(&doc).unwrap()).unwrap();
    scene
}

/// What `brume cycles --against` printed for light pass `pass`: (mean_rel_diff, blocks
/// failing, worst block z).
fn pass_line(stdout: &str, pass: &str) -> (f64, usize, f64) {
    let (rel, _, failed, max_z) = common::reference::pass_agreement(stdout, pass)
        .unwrap_or_else(|| panic!("pass {pass} is zero:\n{stdout}"));
    (rel, failed, max_z)
}

#[test]
fn a_mantaflow_fire_agrees_with_cycles_with_the_voxels_blackbody() {
    let Some(cx) = BpyRun::new("cycles_fire", "mantaflow_fire") else {
        return;
    };
    let o = Command::new(&cx.python)
        .arg(root().join("tools/cycles/mantaflow_smoke.py"))
        .arg(&cx.dir)
        .args(["--fire", "--resolution", "32", "--frames", FRAMES])
        .output()
        .unwrap();
    assert_ok(&o, "mantaflow_smoke.py --fire");
    let scene = fire_scene(&cx.dir);
    let size = ["--width", "32", "--height", "24"];
    for model in ["temperature", "voxels"] {
        let out = cx.path(&format!("brume_{model}.exr"));
        let mut args = vec![
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ];
        args.extend(["--spp", "4096", "--seed", "7", "--passes", "light"]);
        args.extend(["--blackbody", model]);
        args.extend(size);
        assert_ok(&cx.brume(&args), "brume render");
    }
    let cycles = cx.path("cycles.exr");
    let against = |model: &str, reuse: bool| {
        let brume = cx.path(&format!("brume_{model}.exr"));
        let mut args = vec![
            "cycles",
            scene.to_str().unwrap(),
            "-o",
            cycles.to_str().unwrap(),
        ];
        args.extend([
            "--spp", "256", "--runs", "4", "--seed", "1", "--passes", "light",
        ]);
        args.extend(size);
        args.extend(["--against", brume.to_str().unwrap()]);
        if reuse {
            args.push("--reuse");
        }
        let o = cx.brume(&args);
        assert_ok(&o, "brume cycles");
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    // Cycles' model: the beauty and every pass agree, the emission within 1 %.
    let voxels = against("voxels", false);
    common::reference::assert_agreement(&voxels);
    let z = common::render::sidak_z(1e-3, 3 * 12);
    for pass in ["emission", "volume.direct", "volume.indirect"] {
        let (_, _, max_z) = pass_line(&voxels, pass);
        assert!(
            max_z < z,
            "{pass}: block z {max_z} against {z:.2}:\n{voxels}"
        );
    }
    let (emission, _, _) = pass_line(&voxels, "emission");
    assert!(
        emission.abs() < 0.01,
        "emission differs by {emission}:\n{voxels}"
    );
    // The continuous field's model: Cycles' emission is brighter, beyond noise.
    let field = against("temperature", true);
    let (emission_field, failing, _) = pass_line(&field, "emission");
    assert!(
        emission_field > 0.02 && failing > 0,
        "the models should differ on a bake:\n{field}"
    );
    say(&format!(
        "cycles_fire: Mantaflow fire 32x24, --blackbody voxels:\n{voxels}\n\
         default (temperature) model:\n{field}"
    ));
}
