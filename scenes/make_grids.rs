//! Writes Brume's procedural example grids through OpenVDB (`scenes/make_vdbs.sh` runs it).
//!
//! The shapes are deterministic (a hash-based value noise, no RNG state), so rerunning the
//! script reproduces the committed files. Each grid sits around the origin inside about
//! [-1, 1]^3 in world units, as the example scenes expect.
use brume_ffi::{write_float_grids, GridClass, GridSpec};
use std::path::PathBuf;

fn hash3(x: i32, y: i32, z: i32, seed: u32) -> f32 {
    let mut h = (x as u32).wrapping_mul(0x8da6_b343)
        ^ (y as u32).wrapping_mul(0xd816_3841)
        ^ (z as u32).wrapping_mul(0xcb1a_b31f)
        ^ seed.wrapping_mul(0x9e37_79b9);
    h ^= h >> 16;
    h = h.wrapping_mul(0x7feb_352d);
    h ^= h >> 15;
    h = h.wrapping_mul(0x846c_a68b);
    h ^= h >> 16;
    h as f32 / u32::MAX as f32
}

fn smooth(t: f32) -> f32 {
    t * t * (3.0 - 2.0 * t)
}

/// Value noise in [0, 1].
fn noise(p: [f32; 3], seed: u32) -> f32 {
    let i = p.map(|c| c.floor() as i32);
    let f = [p[0] - i[0] as f32, p[1] - i[1] as f32, p[2] - i[2] as f32].map(smooth);
    let mut acc = 0.0;
    for corner in 0..8 {
        let (dx, dy, dz) = (corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
        let w = (if dx == 1 { f[0] } else { 1.0 - f[0] })
            * (if dy == 1 { f[1] } else { 1.0 - f[1] })
            * (if dz == 1 { f[2] } else { 1.0 - f[2] });
        acc += w * hash3(i[0] + dx, i[1] + dy, i[2] + dz, seed);
    }
    acc
}

/// Fractal sum of 4 octaves, centred on 0, roughly in [-0.5, 0.5].
fn fbm(p: [f32; 3], seed: u32) -> f32 {
    let (mut sum, mut amp, mut freq) = (0.0, 0.5, 1.0);
    for o in 0..4 {
        sum += amp * (noise(p.map(|c| c * freq), seed + o) - 0.5);
        amp *= 0.5;
        freq *= 2.03;
    }
    sum * 1.9
}

fn len(v: [f32; 3]) -> f32 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Samples `f` at voxel centres of a cube of `half` voxels around the origin and keeps the
/// non-zero values.
fn voxelize(spec: &mut GridSpec, half: i32, voxel: f32, f: impl Fn([f32; 3]) -> f32) {
    for x in -half..half {
        for y in -half..half {
            for z in -half..half {
                let v = f([x as f32 * voxel, y as f32 * voxel, z as f32 * voxel]);
                if v > 0.0 {
                    spec.voxels.push(([x, y, z], v));
                }
            }
        }
    }
}

fn cloud() -> GridSpec {
    let voxel = 1.0 / 48.0;
    let mut g = GridSpec::fog("density", voxel as f64, [0.0; 3]);
    let blobs = [
        ([0.0, -0.1, 0.0], 0.55),
        ([0.45, -0.25, 0.1], 0.4),
        ([-0.45, -0.2, -0.1], 0.42),
        ([0.1, 0.3, 0.05], 0.4),
        ([-0.2, 0.15, 0.3], 0.3),
    ];
    voxelize(&mut g, 48, voxel, |p| {
        let sd = blobs
            .iter()
            .map(|(c, r)| len([p[0] - c[0], p[1] - c[1], p[2] - c[2]]) - r)
            .fold(f32::MAX, f32::min);
        // A flat base, as cumulus have.
        let sd = sd.max(-0.45 - p[1]);
        let d = -sd + 0.22 * fbm(p.map(|c| c * 3.5), 7);
        (d * 6.0).clamp(0.0, 1.0)
    });
    g
}

fn smoke() -> GridSpec {
    let voxel = 1.0 / 40.0;
    let mut g = GridSpec::fog("density", voxel as f64, [0.0; 3]);
    voxelize(&mut g, 40, voxel, |p| {
        let h = (p[1] + 1.0) * 0.5; // 0 at the bottom, 1 at the top
        let twist = 0.25 * (3.0 * p[1]).sin();
        let r = len([p[0] - twist, 0.0, p[2] - 0.15 * (2.0 * p[1]).cos()]);
        let radius = 0.12 + 0.35 * h;
        let d = (1.0 - r / radius) + 0.5 * fbm([p[0] * 4.0, p[1] * 2.5, p[2] * 4.0], 11);
        (d * 1.2).clamp(0.0, 1.0) * (1.0 - h).powf(0.5) * 0.8
    });
    g
}

fn fire() -> [GridSpec; 3] {
    let voxel = 1.0 / 40.0;
    let field = |p: [f32; 3]| {
        let r = len([p[0], (p[1] + 0.3) * 0.8, p[2]]);
        (1.0 - r / 0.8) + 0.45 * fbm(p.map(|c| c * 3.0), 23)
    };
    let mut density = GridSpec::fog("density", voxel as f64, [0.0; 3]);
    voxelize(&mut density, 40, voxel, |p| {
        (field(p) * 2.0).clamp(0.0, 1.0) * 0.6
    });
    let mut temperature = GridSpec::fog("temperature", voxel as f64, [0.0; 3]);
    voxelize(&mut temperature, 40, voxel, |p| {
        (field(p) * 1.6 - 0.2).clamp(0.0, 1.0)
    });
    let mut flame = GridSpec::fog("flame", voxel as f64, [0.0; 3]);
    voxelize(&mut flame, 40, voxel, |p| {
        ((field(p) - 0.45) * 2.5).clamp(0.0, 1.0)
    });
    [density, temperature, flame]
}

/// The two-file fire (`fire2.gltf`): smoke and flame as separate caches, as simulators write
/// them, overlapping where the flame burns inside the smoke. The smoke is a rising, widening
/// column above and around the flame; the flame file holds the flame's own density and its
/// temperature. Coarser than `fire()` (voxel 1/20) so the two files stay small.
fn fire2() -> (GridSpec, [GridSpec; 2]) {
    let voxel = 1.0 / 20.0;
    let mut smoke = GridSpec::fog("density", voxel as f64, [0.0; 3]);
    voxelize(&mut smoke, 20, voxel, |p| {
        let h = ((p[1] + 0.6) / 1.6).clamp(0.0, 1.0);
        let r = len([p[0] - 0.1 * (3.0 * p[1]).sin(), 0.0, p[2]]);
        let radius = 0.25 + 0.45 * h;
        let d = (1.0 - r / radius) + 0.4 * fbm(p.map(|c| c * 3.5), 31);
        (d * 1.5).clamp(0.0, 1.0) * (1.0 - h).powf(0.7) * 0.8
    });
    let field = |p: [f32; 3]| {
        let r = len([p[0], (p[1] + 0.45) * 0.7, p[2]]);
        (1.0 - r / 0.5) + 0.35 * fbm(p.map(|c| c * 4.0), 37)
    };
    let mut flame = GridSpec::fog("density", voxel as f64, [0.0; 3]);
    voxelize(&mut flame, 20, voxel, |p| {
        ((field(p) - 0.2) * 2.0).clamp(0.0, 1.0)
    });
    let mut temperature = GridSpec::fog("temperature", voxel as f64, [0.0; 3]);
    voxelize(&mut temperature, 20, voxel, |p| {
        (field(p) * 1.4).clamp(0.0, 1.0)
    });
    (smoke, [flame, temperature])
}

/// A thin smoke plume: a rising column that widens with height, meanders and is displaced by
/// noise, its density falling off with radius (Gaussian profile) and with height (smoke
/// spreads and thins as it rises). Values under 0.02 are dropped so the grid stays sparse.
/// Prints the largest horizontal column integral through the plume's axis (grid world
/// units), from which `plume_*.gltf` choose `densityScale` for an optical depth of order 1-3.
fn plume() -> GridSpec {
    let voxel = 1.0 / 40.0;
    let field = |p: [f32; 3]| {
        let h = ((p[1] + 1.0) * 0.5).clamp(0.0, 1.0); // 0 at the source, 1 at the top
        let q = p.map(|c| c * 3.0);
        let amp = 0.05 + 0.22 * h;
        let d = [fbm(q, 41), fbm(q, 43), fbm(q, 47)].map(|v| v * amp);
        let (x, y, z) = (p[0] + d[0], p[1] + d[1], p[2] + d[2]);
        let cx = 0.1 * (2.5 * y + 0.5).sin() + 0.35 * h * h;
        let cz = 0.07 * (3.0 * y).cos();
        let radius = 0.06 + 0.45 * h;
        let r = len([x - cx, 0.0, z - cz]) / radius;
        if r > 1.8 {
            return 0.0;
        }
        let profile = (-2.5 * r * r).exp();
        let source = ((h - 0.01) / 0.04).clamp(0.0, 1.0);
        let wisps = (0.6 + 1.2 * fbm([x * 5.0, y * 3.0, z * 5.0], 53)).clamp(0.0, 1.5);
        // Thinning as it spreads: the column integral stays about level up to two thirds of the
        // height, then fades out.
        let thinning = (1.0 - h).powf(0.6) * 0.2 / (0.2 + h);
        let v = profile * source * thinning * wisps;
        if v < 0.02 {
            0.0
        } else {
            v.min(1.0)
        }
    };
    let mut g = GridSpec::fog("density", voxel as f64, [0.0; 3]);
    voxelize(&mut g, 40, voxel, field);
    // Column integrals along x through the plume (every z), per height: the optical depth
    // across the plume per unit densityScale, in the grid's own world units.
    let mut best = (0.0f32, 0.0f32);
    let mut depths = Vec::new();
    for y in -40..40 {
        let mut row_max = 0f32;
        for z in -40..40 {
            let s: f32 = (-40..40)
                .map(|x| field([x as f32 * voxel, y as f32 * voxel, z as f32 * voxel]))
                .sum::<f32>()
                * voxel;
            row_max = row_max.max(s);
        }
        depths.push(row_max);
        if row_max > best.0 {
            best = (row_max, y as f32 * voxel);
        }
    }
    depths.sort_by(f32::total_cmp);
    println!(
        "plume: {} voxels; column integral across the axis: max {:.4} (at y = {:.2}), median \
         over heights {:.4} (grid units)",
        g.voxels.len(),
        best.0,
        best.1,
        depths[depths.len() / 2]
    );
    g
}

/// The plume's velocity, as a fluid cache stores it beside the density (`plume_blur.gltf`):
/// a staggered Vec3 grid named `velocity` (Blender's name and Mantaflow's layout: component
/// `a` of voxel `ijk` on its lower face along `a`), in grid units per second, over the voxels
/// within two of the smoke. The smoke rises at up to 1.2 units a second along the column's
/// axis, faster at its core, and swirls about the axis at 2.5 radians a second.
fn plume_velocity(density: &GridSpec) -> GridSpec {
    let voxel = 1.0 / 40.0;
    let mut g = GridSpec::vec3("velocity", GridClass::Staggered, voxel as f64, [0.0; 3]);
    let mut near = std::collections::BTreeSet::new();
    for (c, _) in &density.voxels {
        for d in 0..125 {
            near.insert([c[0] + d % 5 - 2, c[1] + d / 5 % 5 - 2, c[2] + d / 25 - 2]);
        }
    }
    let velocity = |p: [f32; 3]| -> [f32; 3] {
        let h = ((p[1] + 1.0) * 0.5).clamp(0.0, 1.0);
        let cx = 0.1 * (2.5 * p[1] + 0.5).sin() + 0.35 * h * h;
        let cz = 0.07 * (3.0 * p[1]).cos();
        let (x, z) = (p[0] - cx, p[2] - cz);
        let radius = 0.06 + 0.45 * h;
        let core = (-(x * x + z * z) / (radius * radius)).exp();
        let omega = 2.5;
        [-omega * z, 0.4 + 0.8 * core, omega * x]
    };
    let v = g.vectors.as_mut().unwrap();
    for c in near {
        let at = |a: usize| {
            let mut p = c.map(|i| i as f32 * voxel);
            p[a] -= 0.5 * voxel;
            velocity(p)[a]
        };
        v.voxels.push((c, [at(0), at(1), at(2)]));
    }
    g.save_as_half = true;
    g
}

/// A 128^3 block of constant density that OpenVDB stores as one upper-level tile, beside a
/// ramp held in leaves: the case where leaf-only readers see an almost empty grid.
fn tiles() -> GridSpec {
    let voxel = 1.0 / 80.0;
    let mut g = GridSpec::fog("density", voxel, [-1.0, -0.8, -0.8]);
    for x in 0..160 {
        for y in 0..128 {
            for z in 0..128 {
                let v = if x < 128 {
                    0.3
                } else {
                    0.3 * (1.0 - (x - 127) as f32 / 33.0) * (1.0 + 0.1 * ((y + z) % 3) as f32)
                };
                g.voxels.push(([x, y, z], v));
            }
        }
    }
    g
}

fn main() {
    let out = PathBuf::from(
        std::env::args()
            .nth(1)
            .unwrap_or_else(|| "scenes/vdb".to_string()),
    );
    std::fs::create_dir_all(&out).expect("cannot create the output folder");
    let write = |name: &str, grids: &[GridSpec]| {
        let path = out.join(name);
        write_float_grids(&path, grids).unwrap_or_else(|e| panic!("{e}"));
        println!("wrote {}", path.display());
    };
    write("cloud.vdb", &[cloud()]);
    write("smoke.vdb", &[smoke()]);
    write("fire.vdb", &fire());
    write("tiles.vdb", &[tiles()]);
    let plume = plume();
    let velocity = plume_velocity(&plume);
    write("plume_vel.vdb", &[plume.clone(), velocity]);
    write("plume.vdb", &[plume]);
    let (smoke, flame) = fire2();
    write("fire2_smoke.vdb", &[smoke]);
    write("fire2_flame.vdb", &flame);
}
