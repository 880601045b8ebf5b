//! Base-colour and emissive textures (src/scene/texture.rs): decoding (sRGB to linear, PNG and
//! JPEG, files, data URIs and buffer views), the lookup seen through a render, every bad input
//! as a clear error naming the file and the JSON pointer, and a seeded fuzz of the decoder.
use crate::common::scratch;

use std::io::Cursor;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

use brume::scene::texture::{decode_image, srgb_to_linear};
use brume::scene::{self, SceneError};
use brume::volume::check::SplitMix64;
use glam::{Vec2, Vec3};
use serde_json::{json, Value};

/// PNG bytes of an RGB image given row by row from the top.
fn png(width: u32, height: u32, px: impl Fn(u32, u32) -> [u8; 3]) -> Vec<u8> {
    let img = image::RgbImage::from_fn(width, height, |x, y| image::Rgb(px(x, y)));
    let mut out = Vec::new();
    img.write_to(&mut Cursor::new(&mut out), image::ImageOutputFormat::Png)
        .unwrap();
    out
}

fn jpeg(width: u32, height: u32, px: impl Fn(u32, u32) -> [u8; 3]) -> Vec<u8> {
    let img = image::RgbImage::from_fn(width, height, |x, y| image::Rgb(px(x, y)));
    let mut out = Vec::new();
    img.write_to(
        &mut Cursor::new(&mut out),
        image::ImageOutputFormat::Jpeg(95),
    )
    .unwrap();
    out
}

/// The 2x2 test image: red, green / blue, grey 128.
fn quad_px(x: u32, y: u32) -> [u8; 3] {
    match (x, y) {
        (0, 0) => [255, 0, 0],
        (1, 0) => [0, 255, 0],
        (0, 1) => [0, 0, 255],
        _ => [128, 128, 128],
    }
}

/// A unit quad in the z = 0 plane facing +z, uv (0, 0) at its top-left corner (x = -1, y = 1),
/// with an emissive textured material, seen by a camera at z = 3; `image` is spliced in as
/// image 0. Buffer layout: positions (48 bytes), uvs (32), indices (12).
fn quad_doc(image: Value, sampler: Value) -> (Value, Vec<u8>) {
    let mut bin = Vec::new();
    for p in [
        [-1.0f32, 1.0, 0.0],
        [1.0, 1.0, 0.0],
        [1.0, -1.0, 0.0],
        [-1.0, -1.0, 0.0],
    ] {
        for c in p {
            bin.extend(c.to_le_bytes());
        }
    }
    for uv in [[0.0f32, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]] {
        for c in uv {
            bin.extend(c.to_le_bytes());
        }
    }
    for i in [0u16, 2, 1, 0, 3, 2] {
        bin.extend(i.to_le_bytes());
    }
    let doc = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"mesh": 0}, {"camera": 0, "translation": [0.0, 0.0, 3.0]}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.5, "znear": 0.01}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0}]}],
        "materials": [{
            "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "baseColorTexture": {"index": 0}},
            "emissiveFactor": [1, 1, 1], "emissiveTexture": {"index": 0}
        }],
        "textures": [{"source": 0, "sampler": 0}],
        "samplers": [sampler],
        "images": [image],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, -1, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 32},
            {"buffer": 0, "byteOffset": 80, "byteLength": 12}
        ],
        "buffers": [{"byteLength": 92, "uri": "buf.bin"}]
    });
    (doc, bin)
}

fn write(dir: &Path, doc: &Value, bin: &[u8]) -> PathBuf {
    std::fs::write(dir.join("buf.bin"), bin).unwrap();
    let path = dir.join("scene.gltf");
    std::fs::write(&path, serde_json::to_vec_pretty(doc).unwrap()).unwrap();
    path
}

fn nearest() -> Value {
    json!({"magFilter": 9728, "wrapS": 33071, "wrapT": 33071})
}

/// Loads, expecting an error naming the file, at a JSON pointer starting with `pointer`, whose
/// message contains `what`.
fn load_err(path: &Path, pointer: &str, what: &str) -> SceneError {
    let e = match scene::load(path) {
        Ok(_) => panic!("{} loaded but should fail at {pointer}", path.display()),
        Err(e) => e,
    };
    let msg = e.to_string();
    assert!(msg.contains(&path.display().to_string()), "no file: {msg}");
    assert!(
        e.pointer().starts_with(pointer),
        "at {:?}: {msg}",
        e.pointer()
    );
    assert!(msg.contains(what), "{msg}");
    e
}

#[test]
fn png_and_jpeg_decode_to_linear() {
    let img = decode_image(&png(2, 2, quad_px)).unwrap();
    assert_eq!((img.width, img.height), (2, 2));
    assert_eq!(img.texels[0], [1.0, 0.0, 0.0, 1.0]);
    assert_eq!(img.texels[1], [0.0, 1.0, 0.0, 1.0]);
    let grey = srgb_to_linear(128.0 / 255.0);
    assert!((grey - 0.215_861).abs() < 1e-5, "{grey}");
    assert_eq!(img.texels[3], [grey, grey, grey, 1.0]);
    // JPEG is lossy: a flat image decodes to within a code value.
    let img = decode_image(&jpeg(16, 16, |_, _| [200, 100, 50])).unwrap();
    for t in &img.texels {
        for (c, v) in [200.0f32, 100.0, 50.0].iter().enumerate() {
            let lo = srgb_to_linear((v - 2.0) / 255.0);
            let hi = srgb_to_linear((v + 2.0) / 255.0);
            assert!((lo..=hi).contains(&t[c]), "{t:?}");
        }
    }
}

/// The four texels of a nearest-filtered emissive quad, read back through the loader's
/// lookup at their centres, and as images: a file, a data URI and a buffer view.
#[test]
fn textures_load_from_files_data_uris_and_buffer_views() {
    let bytes = png(2, 2, quad_px);
    let dir = scratch::dir("sources");
    std::fs::write(dir.join("t.png"), &bytes).unwrap();
    let data_uri = format!("data:image/png;base64,{}", base64_encode(&bytes));
    let cases = [
        ("file", json!({"uri": "t.png"})),
        ("data", json!({"uri": data_uri})),
        ("view", json!({"bufferView": 3, "mimeType": "image/png"})),
    ];
    for (name, image) in cases {
        let (mut doc, mut bin) = quad_doc(image, nearest());
        if name == "view" {
            let offset = bin.len();
            bin.extend(&bytes);
            doc["bufferViews"]
                .as_array_mut()
                .unwrap()
                .push(json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len()}));
            doc["buffers"][0]["byteLength"] = json!(bin.len());
        }
        let path = write(&dir, &doc, &bin);
        let s = scene::load(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
        s.validate().unwrap();
        let mat = &s.materials[0];
        let at = |u: f32, v: f32| s.emission_at(mat, Vec2::new(u, v));
        assert_eq!(at(0.25, 0.25), Vec3::X, "{name}");
        assert_eq!(at(0.75, 0.25), Vec3::Y, "{name}");
        assert_eq!(at(0.25, 0.75), Vec3::Z, "{name}");
        // The triangles carry the uvs: the quad's top-left corner is red.
        let t = (0..s.triangle_count())
            .find(|&t| {
                s.triangles()[t]
                    .vertices
                    .iter()
                    .any(|&v| s.vertices()[v as usize].position == [-1.0, 1.0, 0.0])
            })
            .unwrap();
        let k = s.triangles()[t]
            .vertices
            .iter()
            .position(|&v| s.vertices()[v as usize].position == [-1.0, 1.0, 0.0])
            .unwrap();
        let (b1, b2) = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)][k];
        assert_eq!(s.uv_at(t, b1, b2), Vec2::ZERO, "{name}");
    }
}

fn base64_encode(bytes: &[u8]) -> String {
    const A: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in bytes.chunks(3) {
        let n = (c[0] as u32) << 16
            | (*c.get(1).unwrap_or(&0) as u32) << 8
            | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            if k <= c.len() {
                s.push(A[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// The camera sees the emissive quad; with no other light a pixel is the emission where its
/// samples land. The pixels at the centres of the four quarters read the four texels.
#[test]
fn a_render_shows_the_texture_the_right_way_up() {
    let dir = scratch::dir("render");
    std::fs::write(dir.join("t.png"), png(2, 2, quad_px)).unwrap();
    let (doc, bin) = quad_doc(json!({"uri": "t.png"}), nearest());
    let path = write(&dir, &doc, &bin);
    let out = dir.join("r.exr");
    let st = std::process::Command::new(env!("CARGO_BIN_EXE_brume"))
        .arg("render")
        .arg(&path)
        .arg("-o")
        .arg(&out)
        .args([
            "--spp",
            "4",
            "--width",
            "40",
            "--height",
            "40",
            "--max-depth",
            "1",
        ])
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    let img = brume::film::read_exr(&out).unwrap();
    // yfov 0.5 at distance 3: the quad (2 m) spans 2 / (2 * 3 * tan 0.25) = 1.30 of the frame
    // height, so pixels 10 and 30 sit at the quarters' centres... well inside each quarter.
    let grey = srgb_to_linear(128.0 / 255.0);
    assert_eq!(img.rgb_at(10, 10), [1.0, 0.0, 0.0]);
    assert_eq!(img.rgb_at(30, 10), [0.0, 1.0, 0.0]);
    assert_eq!(img.rgb_at(10, 30), [0.0, 0.0, 1.0]);
    assert_eq!(img.rgb_at(30, 30), [grey; 3]);
}

#[test]
fn bad_textures_are_clear_errors() {
    let dir = scratch::dir("bad");
    let good = png(4, 4, |x, y| [x as u8 * 60, y as u8 * 60, 0]);
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        (
            "truncated.png",
            good[..good.len() / 2].to_vec(),
            "cannot decode",
        ),
        (
            "text.png",
            b"not an image at all".to_vec(),
            "not a PNG or JPEG",
        ),
        ("empty.png", Vec::new(), "not a PNG or JPEG"),
        (
            "a.gif",
            b"GIF89a\x01\x00\x01\x00\x00\x00\x00;".to_vec(),
            "not supported",
        ),
    ];
    for (name, bytes, what) in cases {
        std::fs::write(dir.join(name), &bytes).unwrap();
        let (doc, bin) = quad_doc(json!({ "uri": name }), nearest());
        let e = load_err(&write(&dir, &doc, &bin), "/images/0/uri", what);
        assert!(e.to_string().contains(name), "{e}");
    }
    // Missing file.
    let (doc, bin) = quad_doc(json!({"uri": "missing.png"}), nearest());
    load_err(&write(&dir, &doc, &bin), "/images/0/uri", "missing.png");
    // A directory where the image should be.
    std::fs::create_dir_all(dir.join("folder.png")).unwrap();
    let (doc, bin) = quad_doc(json!({"uri": "folder.png"}), nearest());
    load_err(&write(&dir, &doc, &bin), "/images/0/uri", "folder.png");
    // Texture, image and sampler indices out of range.
    std::fs::write(dir.join("ok.png"), &good).unwrap();
    let (mut doc, bin) = quad_doc(json!({"uri": "ok.png"}), nearest());
    doc["materials"][0]["emissiveTexture"]["index"] = json!(5);
    load_err(
        &write(&dir, &doc, &bin),
        "/materials/0/emissiveTexture/index",
        "",
    );
    let (mut doc, bin) = quad_doc(json!({"uri": "ok.png"}), nearest());
    doc["textures"][0]["source"] = json!(3);
    load_err(&write(&dir, &doc, &bin), "/textures/0/source", "");
    let (mut doc, bin) = quad_doc(json!({"uri": "ok.png"}), nearest());
    doc["textures"][0]["sampler"] = json!(2);
    load_err(&write(&dir, &doc, &bin), "/textures/0/sampler", "");
    // A buffer view image past the end of its buffer.
    let (mut doc, bin) = quad_doc(json!({"bufferView": 3, "mimeType": "image/png"}), nearest());
    doc["bufferViews"]
        .as_array_mut()
        .unwrap()
        .push(json!({"buffer": 0, "byteOffset": 80, "byteLength": 400}));
    load_err(&write(&dir, &doc, &bin), "/bufferViews/3", "");
}

/// Seeded mutations of valid PNG and JPEG files through the decoder: every input is either a
/// clear error or an image of finite texels within the size limit; no panic.
#[test]
fn fuzz_the_texture_decoder() {
    let seeds = [
        png(7, 5, |x, y| [(x * 30) as u8, (y * 40) as u8, 77]),
        png(1, 1, |_, _| [1, 2, 3]),
        jpeg(9, 8, |x, y| [(x * 25) as u8, 200, (y * 30) as u8]),
    ];
    let mut rng = SplitMix64(0x7e47_04e5);
    let (mut ok, mut refused) = (0, 0);
    for i in 0..3000u64 {
        let mut bytes = seeds[(i % 3) as usize].clone();
        let edits = 1 + rng.below(4);
        for _ in 0..edits {
            let n = bytes.len().max(1) as u64;
            match rng.below(5) {
                0 => {
                    let k = rng.below(n) as usize % bytes.len().max(1);
                    if !bytes.is_empty() {
                        bytes[k] ^= 1 << rng.below(8);
                    }
                }
                1 => bytes.truncate(rng.below(n) as usize),
                2 => {
                    let k = rng.below(n + 1) as usize;
                    let v = [0u8, 0xff, 0x7f, 0x80][rng.below(4) as usize];
                    bytes.insert(k.min(bytes.len()), v);
                }
                3 => {
                    // An "interesting" 32-bit value, e.g. a width or length field.
                    if bytes.len() >= 4 {
                        let k = rng.below(n - 3) as usize;
                        let v = [0u32, 1, 0xffff_ffff, 0x7fff_ffff, 0x4000, 65536]
                            [rng.below(6) as usize];
                        bytes[k..k + 4].copy_from_slice(&v.to_be_bytes());
                    }
                }
                _ => {
                    if !bytes.is_empty() {
                        let k = rng.below(n) as usize % bytes.len();
                        bytes.remove(k);
                    }
                }
            }
        }
        let r = catch_unwind(AssertUnwindSafe(|| decode_image(&bytes)));
        match r {
            Err(_) => panic!(
                "iteration {i}: the decoder panicked on {} bytes",
                bytes.len()
            ),
            Ok(Err(e)) => {
                assert!(!e.is_empty());
                refused += 1;
            }
            Ok(Ok(img)) => {
                assert!(img.width >= 1 && img.width <= brume::scene::texture::MAX_TEXTURE_SIZE);
                assert_eq!(img.texels.len(), (img.width * img.height) as usize);
                assert!(img.texels.iter().all(|t| t.iter().all(|c| c.is_finite())));
                ok += 1;
            }
        }
    }
    println!("texture fuzz: 3000 inputs, {ok} decoded, {refused} refused");
    assert!(ok > 0 && refused > 0);
}
