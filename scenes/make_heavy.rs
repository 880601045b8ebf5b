//! Writes the heavy example scene: the plume (`scenes/vdb/plume.vdb`, as in `plume_sun.gltf`)
//! over a displaced terrain strewn with instances of a few rock and tree meshes, under a sun and
//! a sky. It measures what production geometry costs: load and build time, memory and rays per
//! second on millions of triangles, most of them instanced.
//!
//! ```sh
//! cargo run --release --example make_heavy -- out/heavy.gltf              # about 6.2M triangles
//! cargo run --release --example make_heavy -- out/small.gltf --terrain 2000 --instances 20
//! ```
//!
//! Options: `--terrain N` (terrain triangles, default 500000), `--instances N` (default 2000),
//! `--detail D` (0 to 3, default 2: the rock and tree meshes' detail), `--nodes` (one node per
//! instance instead of one `EXT_mesh_gpu_instancing` node per mesh). `scenes/instancing/`
//! holds two small ones, `--terrain 800 --instances 40 --detail 0` with and without `--nodes`.
//! The output is `OUT.gltf` next to `OUT.bin`; the plume's `uri` is the path from there to
//! this repository's `scenes/vdb/plume.vdb`. Deterministic: the same options write the same
//! bytes. Too large to commit; generate it where it is needed.
use std::path::{Component, Path, PathBuf};

use serde_json::{json, Value};

/// What to generate.
#[derive(Clone, Copy, Debug)]
pub struct Params {
    /// Terrain triangles (rounded to a square grid of quads).
    pub terrain_triangles: usize,
    /// Instances of the rock and tree meshes.
    pub instances: usize,
    /// One node per instance (`true`) or one `EXT_mesh_gpu_instancing` node per mesh.
    pub nodes: bool,
    /// Detail of the rock and tree meshes: 0 (a few hundred triangles each) to 3; 2 gives
    /// 1.3k to 5k triangles each.
    pub detail: u32,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            terrain_triangles: 500_000,
            instances: 2000,
            nodes: false,
            detail: 2,
        }
    }
}

/// What was written: triangles once per mesh and as placed in the world.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Written {
    /// Triangles of the distinct meshes (the terrain and each rock and tree once).
    pub stored_triangles: usize,
    /// Triangles in the world, every instance counted.
    pub placed_triangles: usize,
    /// Mesh placements: the terrain and every instance.
    pub placements: usize,
}

/// One mesh in its local space: positions, unit normals and a counter-clockwise triangle list.
#[derive(Default)]
struct Mesh {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    triangles: Vec<[u32; 3]>,
}

fn hash(x: i32, y: i32, seed: u32) -> f32 {
    let mut h = (x as u32).wrapping_mul(0x8da6_b343)
        ^ (y as u32).wrapping_mul(0xd816_3841)
        ^ seed.wrapping_mul(0x9e37_79b9);
    h ^= h >> 16;
    h = h.wrapping_mul(0x7feb_352d);
    h ^= h >> 15;
    h = h.wrapping_mul(0x846c_a68b);
    h ^= h >> 16;
    h as f32 / u32::MAX as f32
}

/// Smooth 2D value noise in [0, 1].
fn noise2(x: f32, y: f32, seed: u32) -> f32 {
    let (ix, iy) = (x.floor() as i32, y.floor() as i32);
    let s = |t: f32| t * t * (3.0 - 2.0 * t);
    let (fx, fy) = (s(x - ix as f32), s(y - iy as f32));
    let a = hash(ix, iy, seed) * (1.0 - fx) + hash(ix + 1, iy, seed) * fx;
    let b = hash(ix, iy + 1, seed) * (1.0 - fx) + hash(ix + 1, iy + 1, seed) * fx;
    a * (1.0 - fy) + b * fy
}

/// Terrain height (metres) at `(x, z)`: rolling fractal hills, flattened under the plume.
fn height(x: f32, z: f32) -> f32 {
    let (mut h, mut amp, mut freq) = (0.0, 2.4, 0.06);
    for octave in 0..5 {
        h += amp * (noise2(x * freq, z * freq, 17 + octave) - 0.5);
        amp *= 0.45;
        freq *= 2.1;
    }
    let r = (x * x + z * z).sqrt();
    let t = ((r - 3.0) / 6.0).clamp(0.0, 1.0);
    TERRAIN_Y + h * t * t * (3.0 - 2.0 * t)
}

/// Height of the flat ground under the plume (its grid spans y in [-2.4, 2.4]).
const TERRAIN_Y: f32 = -2.45;
/// The camera's distance from the plume along +z, metres.
const CAMERA_Z: f32 = 15.0;
/// Half the terrain's side, metres.
const TERRAIN_HALF: f32 = 40.0;

/// A square grid over `[-TERRAIN_HALF, TERRAIN_HALF]^2` of about `triangles` triangles, displaced
/// by `height`, normals by central differences.
fn terrain(triangles: usize) -> Mesh {
    let n = (((triangles / 2) as f64).sqrt().round() as usize).max(1);
    let step = 2.0 * TERRAIN_HALF / n as f32;
    let mut m = Mesh::default();
    for j in 0..=n {
        for i in 0..=n {
            let (x, z) = (
                -TERRAIN_HALF + i as f32 * step,
                -TERRAIN_HALF + j as f32 * step,
            );
            m.positions.push([x, height(x, z), z]);
            let e = 0.5 * step;
            let dx = (height(x + e, z) - height(x - e, z)) / (2.0 * e);
            let dz = (height(x, z + e) - height(x, z - e)) / (2.0 * e);
            m.normals.push(normalize([-dx, 1.0, -dz]));
        }
    }
    let w = (n + 1) as u32;
    for j in 0..n as u32 {
        for i in 0..n as u32 {
            let (a, b, c, d) = (
                j * w + i,
                j * w + i + 1,
                (j + 1) * w + i,
                (j + 1) * w + i + 1,
            );
            // Counter-clockwise seen from above (+y).
            m.triangles.push([a, c, b]);
            m.triangles.push([b, c, d]);
        }
    }
    m
}

fn normalize(v: [f32; 3]) -> [f32; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.map(|c| c / l)
}

/// A unit icosphere subdivided `levels` times (20 * 4^levels triangles), its radius displaced
/// by noise (`roughness` of it) into a rock, resting on y = 0. Per-vertex normals are the
/// sphere's (smooth shading).
fn rock(levels: u32, roughness: f32, seed: u32) -> Mesh {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut pos: Vec<[f32; 3]> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .map(normalize)
    .to_vec();
    let mut tris: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid = std::collections::HashMap::new();
        let mut midpoint = |a: u32, b: u32, pos: &mut Vec<[f32; 3]>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let (p, q) = (pos[a as usize], pos[b as usize]);
                pos.push(normalize([p[0] + q[0], p[1] + q[1], p[2] + q[2]]));
                pos.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(tris.len() * 4);
        for [a, b, c] in tris {
            let (ab, bc, ca) = (
                midpoint(a, b, &mut pos),
                midpoint(b, c, &mut pos),
                midpoint(c, a, &mut pos),
            );
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        tris = next;
    }
    let positions = pos
        .iter()
        .map(|p| {
            let n = noise2(p[0] * 2.3 + p[2] * 1.7, p[1] * 2.9 - p[2] * 1.1, seed);
            let r = 1.0 + roughness * (n - 0.5);
            // Flattened to sit on the ground: y in about [0, 1.2].
            [p[0] * r, (p[1] * r + 1.0) * 0.6, p[2] * r]
        })
        .collect();
    Mesh {
        positions,
        normals: pos,
        triangles: tris,
    }
}

/// A tree: a tapered trunk and `tiers` stacked cones of foliage, each a ring of `sides`
/// segments over `rings` rings; about 2.5k triangles at the defaults. Base at y = 0.
fn tree(sides: u32, rings: u32, tiers: u32) -> Mesh {
    let mut m = Mesh::default();
    // (base y, top y, base radius, top radius)
    let mut parts = vec![(0.0, 1.2, 0.18, 0.12)];
    for k in 0..tiers {
        let y = 0.8 + 0.9 * k as f32;
        parts.push((y, y + 1.6, 1.1 - 0.25 * k as f32, 0.0));
    }
    for (y0, y1, r0, r1) in parts {
        let base = m.positions.len() as u32;
        let slope = (r0 - r1) / (y1 - y0);
        for ring in 0..=rings {
            let f = ring as f32 / rings as f32;
            let (y, r) = (y0 + f * (y1 - y0), r0 + f * (r1 - r0));
            for s in 0..sides {
                let a = s as f32 / sides as f32 * std::f32::consts::TAU;
                m.positions.push([r * a.cos(), y, r * a.sin()]);
                m.normals.push(normalize([a.cos(), slope, a.sin()]));
            }
        }
        // The apex ring of a cone has radius 0: skip its degenerate quads' upper triangle.
        for ring in 0..rings {
            for s in 0..sides {
                let at = |ring: u32, s: u32| base + ring * sides + s % sides;
                let (a, b, c, d) = (
                    at(ring, s),
                    at(ring, s + 1),
                    at(ring + 1, s),
                    at(ring + 1, s + 1),
                );
                m.triangles.push([a, c, b]);
                if !(r1 == 0.0 && ring + 1 == rings) {
                    m.triangles.push([b, c, d]);
                }
            }
        }
    }
    m
}

/// The instanced meshes: (name, mesh, material, share of the instances, scale range).
fn props(detail: u32) -> Vec<(&'static str, Mesh, usize, f32, [f32; 2])> {
    let d = detail.min(3);
    vec![
        (
            "rock_large",
            rock(d + 2, 0.5, 3),
            MAT_ROCK,
            0.25,
            [0.6, 1.4],
        ),
        (
            "rock_small",
            rock(d + 1, 0.7, 5),
            MAT_ROCK,
            0.25,
            [0.2, 0.6],
        ),
        (
            "pine",
            tree(16 * (d + 1), 2 + 3 * d, 3),
            MAT_LEAVES,
            0.3,
            [0.8, 1.5],
        ),
        (
            "fir",
            tree(8 + 12 * d, 2 + 2 * d, 4),
            MAT_LEAVES,
            0.2,
            [0.7, 1.2],
        ),
    ]
}

const MAT_TERRAIN: usize = 0;
const MAT_ROCK: usize = 1;
const MAT_LEAVES: usize = 2;

/// Instance placements of prop `kind` out of `count` in all: translation, rotation (about y,
/// as a quaternion) and uniform scale, on the terrain and away from the plume.
fn placements(kind: usize, shares: &[f32], count: usize, scale: [f32; 2]) -> Vec<[f32; 8]> {
    let mut out = Vec::new();
    for i in 0..count {
        // Instance i belongs to the prop whose cumulative share its hash falls in.
        let u = hash(i as i32, 0, 101);
        let mut acc = 0.0;
        let owner = shares.iter().position(|s| {
            acc += s;
            u < acc
        });
        if owner.unwrap_or(shares.len() - 1) != kind {
            continue;
        }
        let r = 7.0 + (TERRAIN_HALF - 9.0) * hash(i as i32, 1, 102).sqrt();
        let a = hash(i as i32, 2, 103) * std::f32::consts::TAU;
        let (x, mut z) = (r * a.cos(), r * a.sin());
        // Nothing right in front of the camera (at z = 15): mirrored to the far side instead.
        if x * x + (z - CAMERA_Z) * (z - CAMERA_Z) < 25.0 {
            z = -z;
        }
        let yaw = hash(i as i32, 3, 104) * std::f32::consts::TAU;
        let s = scale[0] + (scale[1] - scale[0]) * hash(i as i32, 4, 105);
        let y = height(x, z) - 0.05 * s;
        out.push([x, y, z, 0.0, (yaw / 2.0).sin(), 0.0, (yaw / 2.0).cos(), s]);
    }
    out
}

/// The glTF document and its binary buffer, appended to as meshes and accessors are added.
struct Builder {
    doc: Value,
    bin: Vec<u8>,
}

impl Builder {
    /// Appends `data` as a buffer view and an accessor over it; returns the accessor's index.
    fn accessor(
        &mut self,
        data: &[u8],
        component: u32,
        kind: &str,
        count: usize,
        bounds: Option<([f32; 3], [f32; 3])>,
    ) -> usize {
        while self.bin.len() % 4 != 0 {
            self.bin.push(0);
        }
        let views = self.doc["bufferViews"].as_array_mut().unwrap();
        views.push(json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": data.len()}));
        let view = views.len() - 1;
        self.bin.extend_from_slice(data);
        let mut acc =
            json!({"bufferView": view, "componentType": component, "count": count, "type": kind});
        if let Some((min, max)) = bounds {
            acc["min"] = json!(min);
            acc["max"] = json!(max);
        }
        let accessors = self.doc["accessors"].as_array_mut().unwrap();
        accessors.push(acc);
        accessors.len() - 1
    }

    fn floats<const N: usize>(&mut self, rows: &[[f32; N]], kind: &str, bounds: bool) -> usize {
        let bytes: Vec<u8> = rows
            .iter()
            .flatten()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        let b = bounds.then(|| {
            let mut lo = [f32::INFINITY; 3];
            let mut hi = [f32::NEG_INFINITY; 3];
            for r in rows {
                for k in 0..3 {
                    lo[k] = lo[k].min(r[k]);
                    hi[k] = hi[k].max(r[k]);
                }
            }
            (lo, hi)
        });
        self.accessor(&bytes, 5126, kind, rows.len(), b)
    }

    /// Adds `mesh` as a glTF mesh of one primitive; returns the mesh's index.
    fn mesh(&mut self, name: &str, mesh: &Mesh, material: usize) -> usize {
        let position = self.floats(&mesh.positions, "VEC3", true);
        let normal = self.floats(&mesh.normals, "VEC3", false);
        let bytes: Vec<u8> = mesh
            .triangles
            .iter()
            .flatten()
            .flat_map(|i| i.to_le_bytes())
            .collect();
        let indices = self.accessor(&bytes, 5125, "SCALAR", mesh.triangles.len() * 3, None);
        let meshes = self.doc["meshes"].as_array_mut().unwrap();
        meshes.push(json!({"name": name, "primitives": [{
            "attributes": {"POSITION": position, "NORMAL": normal},
            "indices": indices,
            "material": material
        }]}));
        meshes.len() - 1
    }

    fn node(&mut self, node: Value) {
        let index = self.doc["nodes"].as_array().map_or(0, Vec::len);
        self.doc["scenes"][0]["nodes"]
            .as_array_mut()
            .unwrap()
            .push(json!(index));
        self.doc["nodes"].as_array_mut().unwrap().push(node);
    }
}

/// The document's fixed parts: the camera, the sun, the sky and the materials; `bin_uri` names
/// the binary buffer.
fn skeleton(bin_uri: &str) -> Value {
    json!({
        "asset": {"version": "2.0", "generator": "brume scenes/make_heavy.rs"},
        "scene": 0,
        "scenes": [{"nodes": []}],
        "nodes": [],
        "cameras": [{"name": "camera", "type": "perspective",
            "perspective": {"yfov": 0.6, "znear": 0.05, "aspectRatio": 1.7777778}}],
        "materials": [
            {"name": "terrain", "pbrMetallicRoughness": {"baseColorFactor": [0.32, 0.27, 0.2, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.9}},
            {"name": "rock", "pbrMetallicRoughness": {"baseColorFactor": [0.45, 0.43, 0.4, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.8}},
            {"name": "leaves", "pbrMetallicRoughness": {"baseColorFactor": [0.1, 0.28, 0.09, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.7}}
        ],
        "meshes": [],
        "accessors": [],
        "bufferViews": [],
        "buffers": [{"byteLength": 0, "uri": bin_uri}],
        "extensions": {
            "KHR_lights_punctual": {"lights": [{"name": "sun", "type": "directional", "color": [1.0, 0.97, 0.9], "intensity": 3.0}]},
            "BRUME_environment": {"color": [0.55, 0.7, 1.0], "strength": 1.0}
        },
        "extensionsUsed": ["BRUME_medium_vdb", "KHR_lights_punctual", "BRUME_environment"]
    })
}

/// Writes the scene to `out` (`.gltf`) and `out` with extension `.bin`.
pub fn write_scene(out: &Path, params: &Params) -> std::io::Result<Written> {
    let dir = out
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir)?;
    let vdb = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/vdb/plume.vdb");
    let plume_uri = relative_uri(&dir.canonicalize()?, &vdb.canonicalize()?);
    let bin_path = out.with_extension("bin");
    let bin_uri = bin_path.file_name().unwrap().to_string_lossy().into_owned();
    let mut b = Builder {
        doc: skeleton(&bin_uri),
        bin: Vec::new(),
    };
    b.node(
        json!({"name": "camera_node", "camera": 0, "translation": [0.0, 4.5, CAMERA_Z],
        "rotation": [-0.1045285, 0.0, 0.0, 0.9945219]}),
    );
    b.node(
        json!({"name": "plume", "scale": [2.0, 2.0, 2.0], "extensions": {"BRUME_medium_vdb": {
        "uri": plume_uri, "densityGrid": "density", "densityScale": 20.0,
        "color": [0.9, 0.9, 0.9], "absorptionColor": [0.0, 0.0, 0.0], "anisotropy": 0.0}}}),
    );
    b.node(
        json!({"name": "sun", "rotation": [-0.3303661, 0.2432103, 0.0885213, 0.9076734],
        "extensions": {"KHR_lights_punctual": {"light": 0}}}),
    );
    let ground = terrain(params.terrain_triangles);
    let mut written = Written {
        stored_triangles: ground.triangles.len(),
        placed_triangles: ground.triangles.len(),
        placements: 1,
    };
    let m = b.mesh("terrain", &ground, MAT_TERRAIN);
    b.node(json!({"name": "terrain", "mesh": m}));
    let props = props(params.detail);
    let shares: Vec<f32> = props.iter().map(|p| p.3).collect();
    for (kind, (name, mesh, material, _, scale)) in props.iter().enumerate() {
        let rows = placements(kind, &shares, params.instances, *scale);
        written.stored_triangles += mesh.triangles.len();
        written.placed_triangles += mesh.triangles.len() * rows.len();
        written.placements += rows.len();
        let m = b.mesh(name, mesh, *material);
        if params.nodes {
            for (k, r) in rows.iter().enumerate() {
                b.node(json!({"name": format!("{name}_{k}"), "mesh": m,
                    "translation": [r[0], r[1], r[2]], "rotation": [r[3], r[4], r[5], r[6]],
                    "scale": [r[7], r[7], r[7]]}));
            }
        } else if !rows.is_empty() {
            let t: Vec<[f32; 3]> = rows.iter().map(|r| [r[0], r[1], r[2]]).collect();
            let q: Vec<[f32; 4]> = rows.iter().map(|r| [r[3], r[4], r[5], r[6]]).collect();
            let s: Vec<[f32; 3]> = rows.iter().map(|r| [r[7]; 3]).collect();
            let (t, q, s) = (
                b.floats(&t, "VEC3", false),
                b.floats(&q, "VEC4", false),
                b.floats(&s, "VEC3", false),
            );
            b.node(
                json!({"name": name, "mesh": m, "extensions": {"EXT_mesh_gpu_instancing": {
                "attributes": {"TRANSLATION": t, "ROTATION": q, "SCALE": s}}}}),
            );
        }
    }
    if !params.nodes {
        b.doc["extensionsUsed"]
            .as_array_mut()
            .unwrap()
            .push(json!("EXT_mesh_gpu_instancing"));
    }
    b.doc["buffers"][0]["byteLength"] = json!(b.bin.len());
    std::fs::write(&bin_path, &b.bin)?;
    std::fs::write(out, serde_json::to_vec_pretty(&b.doc)?)?;
    Ok(written)
}

/// The relative URI (`/`-separated) from directory `from` to file `to`, both canonical.
fn relative_uri(from: &Path, to: &Path) -> String {
    let a: Vec<Component> = from.components().collect();
    let b: Vec<Component> = to.components().collect();
    let common = a.iter().zip(&b).take_while(|(x, y)| x == y).count();
    let mut parts: Vec<String> = vec!["..".into(); a.len() - common];
    parts.extend(
        b[common..]
            .iter()
            .map(|c| c.as_os_str().to_string_lossy().into_owned()),
    );
    parts.join("/")
}

#[allow(dead_code)]
fn main() {
    let mut args = std::env::args().skip(1);
    let mut out: Option<PathBuf> = None;
    let mut params = Params::default();
    let usage = "usage: make_heavy OUT.gltf [--terrain TRIANGLES] [--instances N] [--detail 0..3] [--nodes]";
    while let Some(arg) = args.next() {
        let mut number = |name: &str| -> usize {
            let v = args.next().and_then(|v| v.parse().ok());
            v.unwrap_or_else(|| {
                eprintln!("{name} needs a whole number; {usage}");
                std::process::exit(2)
            })
        };
        match arg.as_str() {
            "--terrain" => params.terrain_triangles = number("--terrain"),
            "--instances" => params.instances = number("--instances"),
            "--detail" => params.detail = number("--detail") as u32,
            "--nodes" => params.nodes = true,
            _ if out.is_none() && !arg.starts_with('-') => out = Some(PathBuf::from(arg)),
            _ => {
                eprintln!("unexpected argument {arg:?}; {usage}");
                std::process::exit(2)
            }
        }
    }
    let Some(out) = out else {
        eprintln!("{usage}");
        std::process::exit(2)
    };
    match write_scene(&out, &params) {
        Ok(w) => println!(
            "{}: {} triangles stored in 5 meshes, {} placed by {} placements",
            out.display(),
            w.stored_triangles,
            w.placed_triangles,
            w.placements
        ),
        Err(e) => {
            eprintln!("{}: {e}", out.display());
            std::process::exit(1)
        }
    }
}
