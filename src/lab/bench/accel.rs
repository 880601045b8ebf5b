//! `brume bench accel`: the CPU's two closest-hit accelerators side by side, the obvhs BVH
//! (with all-triangle tests on small meshes) and Embree (with Brume's triangle test on its
//! hit): build time, memory and rays per second on one thread for camera rays, incoherent
//! shadow rays (occlusion to a random point) and incoherent bounce rays (closest hit), the
//! rays drawn from a fixed seed. Scenes that place a primitive more than once get a second
//! table on the same rays: the two-level BVH, and Embree over the same stored primitives and
//! placements (what `--accel auto` traces such scenes through).
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{anyhow, Result};
use glam::{Vec3, Vec3A};

use crate::accel::embree::EmbreeTriangles;
use crate::accel::instanced::InstancedBvh;
use crate::accel::TriangleBvh;
use crate::math::Ray;
use crate::volume::check::SplitMix64;

/// One set of rays: closest-hit queries, or occlusion queries up to a distance.
struct Rays {
    rays: Vec<Ray>,
    /// `t_max` of each ray.
    t_max: Vec<f32>,
}

/// A mesh to measure: world-space vertices, triangles of three indices, and a camera.
struct Mesh {
    name: String,
    vertices: Vec<[f32; 3]>,
    indices: Vec<[u32; 3]>,
    camera: crate::scene::Pinhole,
    aspect: f32,
    /// The scene's two-level BVH and its build seconds, and Embree over the same placements,
    /// where it places a primitive more than once.
    two_level: Option<(InstancedBvh, f64, EmbreeTriangles)>,
}

/// One row of the table.
struct Row {
    name: String,
    triangles: usize,
    build_ms: [f64; 2],
    memory_kib: [f64; 2],
    /// Million rays per second: camera, shadow, bounce; each `[bvh, embree]`.
    mrays: [[f64; 2]; 3],
}

/// Soup sizes `--sweep` measures, from the small-mesh path's size to large meshes.
pub const SWEEP_SOUPS: [usize; 10] = [
    10, 30, 100, 300, 1_000, 3_000, 10_000, 30_000, 100_000, 300_000,
];

/// Measures each scene and a random triangle soup of each of `soups` triangles (none for
/// 0), `rays` rays a kind, best of `runs`.
pub fn run(scenes: &[PathBuf], rays: usize, runs: usize, soups: &[usize]) -> Result<()> {
    let meshes = meshes(scenes, soups)?;
    table(&meshes, rays, runs)?;
    two_level_table(&meshes, rays, runs);
    Ok(())
}

/// The two-level BVH and instanced Embree of each mesh that has them, on the rays of
/// [`table`]; the shadow rays are closest-hit queries to their end, as the renderer asks them
/// (it needs the surface hit).
fn two_level_table(meshes: &[Mesh], rays: usize, runs: usize) {
    let placed: Vec<_> = meshes
        .iter()
        .filter_map(|m| m.two_level.as_ref().map(|t| (m, t)))
        .collect();
    if placed.is_empty() {
        return;
    }
    println!();
    println!("Each primitive stored once under its placements, same rays:");
    println!();
    println!("| scene | accel | placements | build ms | memory KiB | camera | shadow | bounce |");
    println!("|---|---|---:|---:|---:|---:|---:|---:|");
    for (mesh, (bvh, build_s, embree)) in placed {
        let sets = ray_sets(mesh, rays);
        let mrays = |query: &dyn Fn(&Ray, f32) -> Option<crate::accel::Hit>| {
            sets.each_ref().map(|set| {
                let s = best_of(runs, || {
                    for (ray, &t_max) in set.rays.iter().zip(&set.t_max) {
                        black_box(query(ray, t_max));
                    }
                });
                set.rays.len() as f64 / s / 1e6
            })
        };
        let rows = [
            (
                "two-level BVH",
                build_s * 1e3,
                bvh.memory_bytes() as f64,
                mrays(&|ray, t_max| bvh.closest_hit(ray, 0.0, t_max)),
            ),
            (
                "Embree, instanced",
                embree.build_seconds() * 1e3,
                embree.memory_bytes() as f64,
                mrays(&|ray, t_max| embree.closest_hit_instanced(bvh, ray, 0.0, t_max)),
            ),
        ];
        for (accel, build_ms, bytes, m) in rows {
            println!(
                "| {} | {accel} | {} | {build_ms:.2} | {:.1} | {:.2} | {:.2} | {:.2} |",
                mesh.name,
                bvh.placements(),
                bytes / 1024.0,
                m[0],
                m[1],
                m[2],
            );
        }
    }
}

/// Measures `scenes` then soups of [`SWEEP_SOUPS`] triangles, and names the smallest soup from
/// which Embree is faster for camera, shadow and bounce rays alike, every larger one too.
pub fn sweep(scenes: &[PathBuf], rays: usize, runs: usize) -> Result<()> {
    let meshes = meshes(scenes, &SWEEP_SOUPS)?;
    let rows = table(&meshes, rays, runs)?;
    two_level_table(&meshes, rays, runs);
    let soups = &rows[rows.len() - SWEEP_SOUPS.len()..];
    let faster = |r: &Row| r.mrays.iter().all(|m| m[1] > m[0]);
    let from = (0..soups.len()).find(|&k| soups[k..].iter().all(faster));
    println!();
    match from {
        Some(k) => println!(
            "Embree is faster for every kind of ray from {} triangles (accel auto switches \
             at {})",
            soups[k].triangles,
            crate::accel::EMBREE_FROM_TRIANGLES
        ),
        None => println!("Embree is not faster for every kind of ray at any soup size measured"),
    }
    Ok(())
}

fn meshes(scenes: &[PathBuf], soups: &[usize]) -> Result<Vec<Mesh>> {
    let mut meshes = Vec::new();
    for path in scenes {
        meshes.push(scene_mesh(path)?);
    }
    meshes.extend(soups.iter().filter(|&&n| n > 0).map(|&n| soup_mesh(n)));
    Ok(meshes)
}

/// Prints the table of `meshes` and returns its measured rows (empty meshes left out).
fn table(meshes: &[Mesh], rays: usize, runs: usize) -> Result<Vec<Row>> {
    println!("{rays} rays a kind, one thread, best of {runs}; Mrays/s as BVH / Embree");
    println!(
        "Embree's memory is what its memory-monitor callback counts for the scene; the BVH's is \
         its nodes, primitive indices and triangle corners (which Embree's hits also read)."
    );
    println!();
    println!(
        "| scene | triangles | build ms BVH / Embree | memory KiB BVH / Embree | camera | shadow | bounce |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|");
    let mut rows = Vec::new();
    for mesh in meshes {
        if mesh.indices.is_empty() {
            println!("| {} | 0 | - | - | - | - | - |", mesh.name);
            continue;
        }
        let row = measure(mesh, rays, runs)?;
        let pair = |p: [f64; 2], digits: usize| format!("{:.digits$} / {:.digits$}", p[0], p[1]);
        println!(
            "| {} | {} | {} | {} | {} | {} | {} |",
            row.name,
            row.triangles,
            pair(row.build_ms, 2),
            pair(row.memory_kib, 1),
            pair(row.mrays[0], 2),
            pair(row.mrays[1], 2),
            pair(row.mrays[2], 2),
        );
        rows.push(row);
    }
    Ok(rows)
}

fn scene_mesh(path: &Path) -> Result<Mesh> {
    let mut scene = crate::scene::load(path).map_err(|e| anyhow!("{e}"))?;
    let name = path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    let render = &scene.render;
    let (w, h) = (render.width.unwrap_or(320), render.height.unwrap_or(240));
    Ok(Mesh {
        name,
        vertices: scene.vertices().iter().map(|v| v.position).collect(),
        indices: scene.triangles().iter().map(|t| t.vertices).collect(),
        camera: scene.camera.pinhole(),
        aspect: w as f32 / h.max(1) as f32,
        two_level: instanced_pair(&mut scene)?,
    })
}

/// The scene's two-level BVH, its build seconds and Embree over the same placements, where
/// it has a two-level BVH.
fn instanced_pair(
    scene: &mut crate::scene::Scene,
) -> Result<Option<(InstancedBvh, f64, EmbreeTriangles)>> {
    if scene.instanced.is_none() {
        return Ok(None);
    }
    scene
        .use_accel(crate::accel::Accel::Embree)
        .map_err(|e| anyhow!("{e}"))?;
    let embree = scene.embree.take().expect("instanced Embree");
    let bvh = scene.instanced.take().expect("two-level BVH");
    Ok(Some((bvh, scene.timings.bvh_seconds, embree)))
}

/// `n` random triangles of random sizes in a 40 m cube, seen from outside it.
fn soup_mesh(n: usize) -> Mesh {
    let mut rng = SplitMix64(17);
    let mut r = move |lo: f64, hi: f64| rng.range(lo, hi) as f32;
    let mut vertices = Vec::with_capacity(3 * n);
    for _ in 0..n {
        let c = Vec3::new(r(-20.0, 20.0), r(-20.0, 20.0), r(-20.0, 20.0));
        let s = r(0.05, 1.0);
        for _ in 0..3 {
            vertices.push(
                (c + Vec3::new(
                    r(-s as f64, s as f64),
                    r(-s as f64, s as f64),
                    r(-s as f64, s as f64),
                ))
                .to_array(),
            );
        }
    }
    let indices = (0..n as u32)
        .map(|k| [3 * k, 3 * k + 1, 3 * k + 2])
        .collect();
    let camera = crate::scene::camera::default_camera(&crate::math::Aabb::new(
        Vec3::splat(-20.0),
        Vec3::splat(20.0),
    ));
    Mesh {
        name: format!("random soup ({n} triangles)"),
        vertices,
        indices,
        camera: camera.pinhole(),
        aspect: 4.0 / 3.0,
        two_level: None,
    }
}

fn measure(mesh: &Mesh, rays: usize, runs: usize) -> Result<Row> {
    let corners: Vec<[Vec3A; 3]> = mesh
        .indices
        .iter()
        .map(|t| t.map(|i| Vec3A::from_array(mesh.vertices[i as usize])))
        .collect();
    let start = Instant::now();
    let bvh = TriangleBvh::build(corners);
    let bvh_ms = start.elapsed().as_secs_f64() * 1e3;
    let embree = EmbreeTriangles::build(&mesh.vertices, &mesh.indices)
        .map_err(|e| anyhow!("{}: {e}", mesh.name))?;
    let bvh_bytes = bvh.cwbvh().map_or(0, |b| {
        std::mem::size_of_val(&b.nodes[..]) + std::mem::size_of_val(&b.primitive_indices[..])
    }) + std::mem::size_of_val(bvh.triangles());
    let sets = ray_sets(mesh, rays);
    let mut mrays = [[0.0; 2]; 3];
    for (k, set) in sets.iter().enumerate() {
        let occlusion = k == 1;
        let bvh_s = best_of(runs, || {
            for (ray, &t_max) in set.rays.iter().zip(&set.t_max) {
                if occlusion {
                    black_box(bvh.any_hit(ray, 0.0, t_max));
                } else {
                    black_box(bvh.closest_hit(ray, 0.0, t_max));
                }
            }
        });
        let embree_s = best_of(runs, || {
            for (ray, &t_max) in set.rays.iter().zip(&set.t_max) {
                if occlusion {
                    black_box(embree.occluded(ray, 0.0, t_max));
                } else {
                    black_box(embree.closest_hit(&bvh, ray, 0.0, t_max));
                }
            }
        });
        let n = set.rays.len() as f64;
        mrays[k] = [n / bvh_s / 1e6, n / embree_s / 1e6];
    }
    Ok(Row {
        name: mesh.name.clone(),
        triangles: mesh.indices.len(),
        build_ms: [bvh_ms, embree.build_seconds() * 1e3],
        memory_kib: [
            bvh_bytes as f64 / 1024.0,
            embree.memory_bytes() as f64 / 1024.0,
        ],
        mrays,
    })
}

/// The three sets of `n` rays a mesh is measured with: camera, shadow and bounce rays.
fn ray_sets(mesh: &Mesh, n: usize) -> [Rays; 3] {
    let bounds = mesh.vertices.iter().fold(crate::math::Aabb::EMPTY, |b, v| {
        b.union_point(Vec3::from_array(*v))
    });
    [
        camera_rays(mesh, n),
        shadow_rays(&bounds, n),
        bounce_rays(&bounds, n),
    ]
}

/// Rays through a square grid of pixel centres of the scene's camera, row by row.
fn camera_rays(mesh: &Mesh, n: usize) -> Rays {
    let side = (n as f64).sqrt().ceil() as usize;
    let rays: Vec<Ray> = (0..side * side)
        .take(n)
        .map(|k| {
            let (x, y) = ((k % side) as f32 + 0.5, (k / side) as f32 + 0.5);
            mesh.camera
                .generate_ray(x / side as f32, y / side as f32, mesh.aspect)
        })
        .collect();
    let t_max = vec![f32::INFINITY; rays.len()];
    Rays { rays, t_max }
}

/// A random point of the box grown by a tenth.
fn point_in(rng: &mut SplitMix64, b: &crate::math::Aabb) -> Vec3 {
    let pad = 0.1 * (b.max - b.min);
    let (lo, hi) = ((b.min - pad).as_dvec3(), (b.max + pad).as_dvec3());
    Vec3::new(
        rng.range(lo.x, hi.x) as f32,
        rng.range(lo.y, hi.y) as f32,
        rng.range(lo.z, hi.z) as f32,
    )
}

/// From a random point of the bounds to another: occlusion up to the second point.
fn shadow_rays(b: &crate::math::Aabb, n: usize) -> Rays {
    let mut rng = SplitMix64(23);
    let (mut rays, mut t_max) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for _ in 0..n {
        let o = point_in(&mut rng, b);
        let d = point_in(&mut rng, b) - o;
        rays.push(Ray::new(o, d));
        t_max.push(1.0);
    }
    Rays { rays, t_max }
}

/// From a random point of the bounds in a uniform direction, to the first hit.
fn bounce_rays(b: &crate::math::Aabb, n: usize) -> Rays {
    let mut rng = SplitMix64(29);
    let rays: Vec<Ray> = (0..n)
        .map(|_| {
            let o = point_in(&mut rng, b);
            let d = rng.unit_vector();
            Ray::new(o, Vec3::new(d.x as f32, d.y as f32, d.z as f32))
        })
        .collect();
    let t_max = vec![f32::INFINITY; n];
    Rays { rays, t_max }
}

/// The shortest of `runs` timings of `f`, in seconds.
fn best_of(runs: usize, mut f: impl FnMut()) -> f64 {
    (0..runs.max(1))
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}
