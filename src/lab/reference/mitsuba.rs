//! `brume mitsuba`: render a Brume scene with Mitsuba 3 (the `mitsuba` Python wheel), a second
//! reference renderer independent of Cycles, and optionally compare with a Brume render.
//!
//! Unlike `brume cycles`, whose script re-reads the glTF with Blender's importer, this command
//! loads the scene with Brume's own loader and hands Mitsuba what Brume renders: each VDB
//! medium's density as a `.vol` grid written from Brume's converted grid
//! (`crate::volume::mitsuba_vol`, voxel-centre aligned), the meshes as world-space PLY files,
//! and a JSON description of camera, lights, environment and materials with Brume's mappings
//! (Principled Volume coefficients, light units) already applied. `tools/mitsuba/
//! brume_to_mitsuba.py` only builds Mitsuba's scene dictionary from it and renders `--runs`
//! seeds; the runs are merged as for Cycles (`super::reference`).
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use glam::{Mat4, Vec3};
use serde_json::{json, Value};

use crate::film::AttrValue;
use crate::integrator::bsdf::Principled;
use crate::render::settings::DEFAULT_MAX_DEPTH;
use crate::scene::lights::{LIGHT_DIRECTIONAL, LIGHT_POINT, LIGHT_SPOT};
use crate::scene::{BoundsSource, Material, Scene, VdbMediumDesc, NO_INDEX};
use crate::volume::mitsuba_vol::vol_from_grid;

use super::{seconds_list, Driver, PythonTool, ReferenceRun};

/// A Python with mitsuba: `BRUME_MITSUBA_PYTHON`, then `tools/mitsuba/.venv` next to the
/// working directory or the source tree.
pub const MITSUBA: PythonTool = PythonTool {
    var: "BRUME_MITSUBA_PYTHON",
    venv: "tools/mitsuba/.venv/bin/python",
    module: "mitsuba",
    path_python: false,
    hint: "no Python with Mitsuba 3 found: run tools/mitsuba/setup.sh (venv tools/mitsuba/.venv \
           with `pip install mitsuba`), or set BRUME_MITSUBA_PYTHON to a python that can \
           `import mitsuba`",
};

#[derive(Args, Debug)]
pub struct MitsubaArgs {
    #[command(flatten)]
    pub run: ReferenceRun,
    /// Mitsuba variant (default: llvm_ad_rgb when it loads, else scalar_rgb).
    #[arg(long)]
    pub variant: Option<String>,
    /// Map opaque surfaces to Mitsuba's own `diffuse` (base * (1 - metallic)) instead of
    /// Brume's Lambert + GGX model re-implemented as a Python BSDF: faster, without the GGX lobe.
    #[arg(long)]
    pub lambert_only: bool,
    /// Keep the translated scene (JSON, .vol, .ply) in this folder instead of a temporary one.
    #[arg(long)]
    pub keep: Option<PathBuf>,
}

/// Mitsuba 3 through its Python package.
const DRIVER: Driver = Driver {
    name: "Mitsuba",
    python: MITSUBA,
    script_var: "BRUME_MITSUBA_SCRIPT",
    script: "tools/mitsuba/brume_to_mitsuba.py",
};

pub fn run(args: &MitsubaArgs) -> Result<()> {
    DRIVER.run(&args.run, args.keep.as_deref(), |python, script, dir| {
        let started = Instant::now();
        // Scene errors already name the file and the JSON pointer.
        let scene = crate::scene::load(&args.run.scene)?;
        translate_and_render(args, &scene, python, script, dir, started)
    })
}

fn translate_and_render(
    args: &MitsubaArgs,
    scene: &Scene,
    python: &Path,
    script: &Path,
    dir: &Path,
    started: Instant,
) -> Result<()> {
    let description = describe(scene, args, dir)?;
    let json_path = dir.join("scene.json");
    std::fs::write(&json_path, serde_json::to_string_pretty(&description)?)
        .with_context(|| format!("writing {}", json_path.display()))?;
    let prepare_seconds = started.elapsed().as_secs_f64();

    let mut cmd = Command::new(python);
    cmd.arg(script)
        .arg(&json_path)
        .arg("-o")
        .arg(dir.join("mitsuba.exr"));
    if let Some(v) = &args.variant {
        cmd.args(["--variant", v]);
    }
    let (out, r) = DRIVER.render(&args.run, &mut cmd)?;
    // The script's notes (a variant fallback) matter even when it succeeds.
    for line in String::from_utf8_lossy(&out.stderr).lines() {
        if line.starts_with("note:") {
            eprintln!("mitsuba: {line}");
        }
    }
    let stdout = String::from_utf8_lossy(&out.stdout);
    let field = |name: &str| {
        stdout
            .lines()
            .find_map(|l| l.strip_prefix(name).map(|v| v.trim().to_string()))
    };
    let variant = field("variant ").unwrap_or_else(|| "?".into());
    let build_seconds: f64 = field("build_seconds ")
        .and_then(|s| s.parse().ok())
        .unwrap_or(f64::NAN);
    let mut meta = r.meta;
    meta.set(
        "brume:renderer",
        AttrValue::Text(format!("mitsuba ({variant})")),
    )
    .set(
        "brume:mitsuba_seconds_per_run",
        AttrValue::Text(seconds_list(&r.seconds)),
    );
    let summary = format!(
        "mitsuba ({variant}): {} run(s) x {} spp, {}x{}, render {:.2} s (per run {}), \
         translation {:.2} s, Mitsuba scene set-up {:.2} s, wall {:.2} s",
        args.run.runs,
        args.run.spp,
        args.run.width,
        args.run.height,
        r.total,
        seconds_list(&r.seconds),
        prepare_seconds,
        build_seconds,
        started.elapsed().as_secs_f64()
    );
    args.run.finish(&r.images, &[], meta, &summary)
}

/// Row-major 4x4 rows of a glam (column-major) matrix, as Mitsuba's `ScalarTransform4f`
/// takes them.
fn rows(m: &Mat4) -> Value {
    json!((0..4).map(|r| m.row(r).to_array()).collect::<Vec<_>>())
}

/// The JSON the script reads, writing the `.vol` and `.ply` files it names into `dir`.
fn describe(scene: &Scene, args: &MitsubaArgs, dir: &Path) -> Result<Value> {
    let file = scene.source.display();
    let cam = &scene.camera;
    if scene.inside_medium(cam.position()) {
        // Mitsuba would need the sensor's own `medium`; not mapped.
        bail!("{file}: the camera is inside a medium, which brume mitsuba does not map");
    }
    if scene.uses_textures() {
        // Not mapped yet; rendering the factors alone would be a silent wrong answer.
        bail!("{file}: base-colour and emissive textures are not mapped to Mitsuba (brume cycles maps them)");
    }
    let camera = json!({
        "origin": cam.position().to_array(),
        "target": (cam.position() + cam.forward()).to_array(),
        "up": cam.up().to_array(),
        "yfov_degrees": cam.yfov.to_degrees(),
        "near_clip": cam.znear,
    });
    let lights = describe_lights(scene)?;
    if scene.environment.map.is_some() {
        // A reference without the map would disagree for a reason that is not Brume's.
        bail!(
            "{file}: /extensions/BRUME_environment/uri: the Mitsuba converter does not map \
             environment maps yet; compare this scene with `brume cycles`"
        );
    }
    let vdb_media = scene
        .vdb_media
        .iter()
        .enumerate()
        .map(|(i, m)| describe_vdb_medium(scene, i, m, dir))
        .collect::<Result<Vec<_>>>()?;

    let mut meshes = Vec::new();
    let mut notes = Vec::new();
    for (k, inst) in scene.instances.iter().enumerate() {
        meshes.push(describe_mesh(scene, args, k, inst, dir, &mut notes)?);
    }
    notes.sort();
    notes.dedup();
    for n in &notes {
        eprintln!("mitsuba: note: {file}: {n}");
    }

    let env = scene.environment.radiance;
    Ok(json!({
        "scene": scene.source,
        "width": args.run.width,
        "height": args.run.height,
        "spp": args.run.spp,
        "seed": args.run.seed,
        "runs": args.run.runs,
        "threads": args.run.threads,
        // Brume counts scattering events; Mitsuba counts path segments.
        "max_depth": args
            .run
            .max_depth
            .or(scene.render.max_depth)
            .unwrap_or(DEFAULT_MAX_DEPTH)
            .saturating_add(1),
        "camera": camera,
        "lights": lights,
        "environment": env.iter().any(|&c| c > 0.0).then_some(env),
        "vdb_media": vdb_media,
        "meshes": meshes,
    }))
}

/// The scene's punctual lights in the script's terms; a kind without a Mitsuba emitter is an
/// error, since leaving it out would bias the reference.
fn describe_lights(scene: &Scene) -> Result<Vec<Value>> {
    let file = scene.source.display();
    let mut lights = Vec::new();
    for l in &scene.lights {
        lights.push(match l.kind {
            LIGHT_POINT => json!({"type": "point", "position": l.position,
                                  "intensity": l.intensity}),
            LIGHT_SPOT => json!({"type": "spot", "position": l.position,
                                 "direction": l.direction, "intensity": l.intensity,
                                 "cos_inner": l.cos_inner, "cos_outer": l.cos_outer}),
            LIGHT_DIRECTIONAL => json!({"type": "directional", "direction": l.direction,
                                        "irradiance": l.intensity}),
            k => bail!("{file}: light kind {k} has no Mitsuba mapping"),
        });
    }
    Ok(lights)
}

/// Single-scattering albedo `sigma_s / sigma_t` per channel, 0 where nothing is extinguished.
fn albedo(sigma_s: [f32; 3], sigma_t: [f32; 3]) -> [f32; 3] {
    [0, 1, 2].map(|c| {
        if sigma_t[c] > 0.0 {
            sigma_s[c] / sigma_t[c]
        } else {
            0.0
        }
    })
}

/// VDB medium `i` as a `heterogeneous` medium: writes its extinction grid as `medium{i}.vol`
/// into `dir` and returns its entry, refusing what Mitsuba's `volpath` cannot render.
fn describe_vdb_medium(scene: &Scene, i: usize, m: &VdbMediumDesc, dir: &Path) -> Result<Value> {
    let at = format!("{}: {}", scene.source.display(), m.pointer);
    if m.emits() {
        bail!(
            "{at}: emitting media (emission or blackbody) are not mapped to Mitsuba: its \
             `volpath` integrator has no volume emission in the released variants"
        );
    }
    if m.bounds_source == BoundsSource::Mesh {
        bail!(
            "{at}: a VDB medium bounded by a mesh (`mesh`) is not mapped to Mitsuba; \
             only media bounded by their grid"
        );
    }
    let sigma_t = m.sigma_t_per_density();
    let sigma_s = m.sigma_s_per_density();
    // A single channel when extinction is grey; else per-channel extinction grids, since
    // Mitsuba's `heterogeneous` scales its grid by one scalar.
    let grey = sigma_t.iter().all(|&s| s == sigma_t[0]);
    let scales: Vec<f32> = if grey {
        vec![sigma_t[0]]
    } else {
        sigma_t.to_vec()
    };
    let grid = &m.grids[0];
    let vol = vol_from_grid(&grid.volume.grid, &scales).map_err(|e| {
        anyhow!(
            "{at}: {} grid '{}' cannot be written for Mitsuba: {e}",
            grid.path.display(),
            grid.name
        )
    })?;
    let vol_path = dir.join(format!("medium{i}.vol"));
    vol.write(&vol_path)
        .with_context(|| format!("writing {}", vol_path.display()))?;
    Ok(json!({
        "vol": vol_path,
        "channels": scales.len(),
        "to_world": rows(&m.world_from_medium),
        "box_min": vol.bbox_min,
        "box_max": vol.bbox_max,
        "albedo": albedo(sigma_s, sigma_t),
        "g": m.anisotropy,
        "phase": mitsuba_phase(m.phase, m.anisotropy, &at)?,
    }))
}

/// A medium's phase function as Mitsuba 3 plugins: `hg`, `blendphase` of two `hg` lobes,
/// `rayleigh`. Mitsuba has no Draine or Mie phase: those media are refused, naming the medium.
fn mitsuba_phase(
    phase: Option<crate::volume::phases::Phase>,
    anisotropy: f32,
    at: &str,
) -> Result<serde_json::Value> {
    use crate::volume::phases::Phase;
    let hg = |g: f32| json!({"type": "hg", "g": g});
    Ok(match phase.unwrap_or(Phase::hg(anisotropy)) {
        Phase::HenyeyGreenstein(h) => hg(h.g),
        // Mitsuba's blendphase is (1 - weight) phase1 + weight phase2.
        Phase::TwoLobe { a, b, w } => {
            json!({"type": "blendphase", "weight": 1.0 - w, "phase1": hg(a.g), "phase2": hg(b.g)})
        }
        Phase::Rayleigh => json!({"type": "rayleigh"}),
        other => bail!(
            "{at}: Mitsuba 3 has no {} phase function (compare it with brume cycles)",
            other.name()
        ),
    })
}

/// Mesh instance `k` with its material: writes `mesh{k}.ply` into `dir` and returns its entry
/// (BSDF, area emission, interior medium); approximations are added to `notes`.
fn describe_mesh(
    scene: &Scene,
    args: &MitsubaArgs,
    k: usize,
    inst: &crate::scene::Instance,
    dir: &Path,
    notes: &mut Vec<String>,
) -> Result<Value> {
    let mat = &scene.materials[inst.material as usize];
    let name = scene.material_names[inst.material as usize]
        .clone()
        .unwrap_or_else(|| format!("material {}", inst.material));
    let ply = dir.join(format!("mesh{k}.ply"));
    let has_normals = write_ply(scene, inst, &ply)?;
    let mut m = json!({"ply": ply, "face_normals": !has_normals});
    m["bsdf"] = describe_bsdf(mat, &name, args.lambert_only, notes);
    if mat.emission.iter().any(|&e| e > 0.0) {
        m["emission"] = json!(mat.emission);
        if mat.flags & crate::scene::material::MATERIAL_DOUBLE_SIDED != 0 {
            notes.push(format!(
                "{name}: double-sided emission is mapped to Mitsuba's one-sided area light"
            ));
        }
    }
    if mat.interior_medium != NO_INDEX {
        let h = &scene.homogeneous_media[mat.interior_medium as usize];
        let sigma_t = h.sigma_t();
        let at = format!(
            "{}: {name}'s KHR_materials_volume medium",
            scene.source.display()
        );
        m["interior"] = json!({
            "sigma_t": sigma_t,
            "albedo": albedo(h.sigma_s, sigma_t),
            "phase": mitsuba_phase(Some(h.phase), 0.0, &at)?,
        });
    }
    Ok(m)
}

/// The surface BSDF of material `mat` (named `name` in `notes`): a null or smooth dielectric
/// for transmissive materials, else Mitsuba's `diffuse` (`lambert_only`) or Brume's own
/// opaque lobes with the numbers Brume samples.
fn describe_bsdf(mat: &Material, name: &str, lambert_only: bool, notes: &mut Vec<String>) -> Value {
    if mat.transmission > 0.0 {
        if (mat.ior - 1.0).abs() < 1e-6 {
            json!({"type": "null"})
        } else {
            if mat.base_color[..3].iter().any(|&c| c != 1.0) {
                notes.push(format!(
                    "{name}: dielectric base colour is not mapped (Mitsuba's is white)"
                ));
            }
            json!({"type": "dielectric", "ior": mat.ior})
        }
    } else if lambert_only {
        let kd = [0, 1, 2].map(|c| mat.base_color[c] * (1.0 - mat.metallic));
        notes.push(format!("{name}: Lambertian part only (--lambert-only)"));
        json!({"type": "diffuse", "reflectance": kd})
    } else {
        // Brume's own lobe parameters, so both sides use the same numbers.
        let p = Principled::new(
            Vec3::from_slice(&mat.base_color[..3]),
            mat.metallic,
            mat.roughness,
        );
        json!({"type": "brume_opaque", "kd": p.diffuse.to_array(),
               "f0": p.f0.to_array(), "alpha": p.alpha, "p_spec": p.p_spec})
    }
}

/// Writes instance `inst`'s world-space triangles as a binary PLY; returns whether it has
/// shading normals (all vertices with a non-zero normal).
fn write_ply(scene: &Scene, inst: &crate::scene::Instance, path: &Path) -> Result<bool> {
    use std::collections::HashMap;
    use std::io::Write;
    let tris = &scene.triangles()[inst.first_triangle as usize..][..inst.triangle_count as usize];
    let mut index: HashMap<u32, u32> = HashMap::new();
    let mut order = Vec::new();
    let faces: Vec<[u32; 3]> = tris
        .iter()
        .map(|t| {
            t.vertices.map(|v| {
                *index.entry(v).or_insert_with(|| {
                    order.push(v);
                    order.len() as u32 - 1
                })
            })
        })
        .collect();
    let verts: Vec<_> = order
        .iter()
        .map(|&v| scene.vertices()[v as usize])
        .collect();
    let has_normals = verts
        .iter()
        .all(|v| Vec3::from(v.normal).length_squared() > 0.0);
    let mut header = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\n\
         property float x\nproperty float y\nproperty float z\n",
        verts.len()
    );
    if has_normals {
        header.push_str("property float nx\nproperty float ny\nproperty float nz\n");
    }
    header.push_str(&format!(
        "element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        faces.len()
    ));
    let mut bytes = header.into_bytes();
    for v in &verts {
        let mut fl = v.position.to_vec();
        if has_normals {
            fl.extend_from_slice(&v.normal);
        }
        for f in fl {
            bytes.extend_from_slice(&f.to_le_bytes());
        }
    }
    for f in &faces {
        bytes.push(3);
        for &i in f {
            bytes.extend_from_slice(&(i as i32).to_le_bytes());
        }
    }
    let mut file =
        std::fs::File::create(path).with_context(|| format!("writing {}", path.display()))?;
    file.write_all(&bytes)
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(has_normals)
}
