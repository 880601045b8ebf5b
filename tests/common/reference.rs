//! An example scene (the cloud, the two-grid fire) rendered by Brume and by a reference renderer (`brume cycles`, `brume mitsuba`),
//! compared by the command's own `--against` agreement: the image means within 1 % and at
//! most 1 % of the 8x8 blocks failing the block z-test. Shared by the reference tests.
use std::path::Path;
use std::process::Command;

/// [`scene_agrees_with`] on `scenes/cloud.gltf`.
pub fn cloud_agrees_with(
    peer: &str,
    peer_spp: &str,
    python_env: (&str, &Path),
    dir: &Path,
) -> String {
    scene_agrees_with("cloud.gltf", peer, peer_spp, python_env, dir)
}

/// As [`cloud_agrees_with`], for the example scene `name` (in `scenes/`).
pub fn scene_agrees_with(
    name: &str,
    peer: &str,
    peer_spp: &str,
    python_env: (&str, &Path),
    dir: &Path,
) -> String {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scene = root.join("scenes").join(name);
    let (brume_exr, peer_exr) = (dir.join("brume.exr"), dir.join(format!("{peer}.exr")));
    let size = ["--width", "32", "--height", "24"];
    let exe = env!("CARGO_BIN_EXE_brume");

    let st = Command::new(exe)
        .arg("render")
        .arg(&scene)
        .arg("-o")
        .arg(&brume_exr)
        .args(["--spp", "256", "--seed", "7"])
        .args(size)
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );

    let out = Command::new(exe)
        .arg(peer)
        .arg(&scene)
        .arg("-o")
        .arg(&peer_exr)
        .args(["--spp", peer_spp, "--runs", "4", "--seed", "1"])
        .args(size)
        .arg("--against")
        .arg(&brume_exr)
        .env(python_env.0, python_env.1)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let field = |name: &str| -> String {
        let words: Vec<&str> = stdout.split_whitespace().collect();
        let i = words.iter().position(|w| *w == name).expect(name);
        words[i + 1].to_string()
    };
    let rel: f64 = field("mean_rel_diff").parse().unwrap();
    let failed = field("blocks_failed");
    let (bad, total) = failed.split_once('/').unwrap();
    let (bad, total): (usize, usize) = (bad.parse().unwrap(), total.parse().unwrap());
    assert!(rel.abs() < 0.01, "image means differ by {rel}");
    assert!(
        bad as f64 <= 0.01 * total as f64,
        "{bad} of {total} blocks fail"
    );
    stdout.trim().to_string()
}

/// Asserts the agreement line that `brume cycles|mitsuba --against` printed (`stdout`): image
/// means within 1 % and at most 1 % of the blocks failing the block z-test. Returns the line.
pub fn assert_agreement(stdout: &str) -> String {
    let words: Vec<&str> = stdout.split_whitespace().collect();
    let field = |name: &str| -> &str {
        let i = words
            .iter()
            .position(|w| *w == name)
            .unwrap_or_else(|| panic!("no {name} in:\n{stdout}"));
        words[i + 1]
    };
    let rel: f64 = field("mean_rel_diff").parse().unwrap();
    let (bad, total) = field("blocks_failed").split_once('/').unwrap();
    let (bad, total): (usize, usize) = (bad.parse().unwrap(), total.parse().unwrap());
    assert!(rel.abs() < 0.01, "image means differ by {rel}:\n{stdout}");
    assert!(
        bad as f64 <= 0.01 * total as f64,
        "{bad} of {total} blocks fail:\n{stdout}"
    );
    stdout.trim().to_string()
}
