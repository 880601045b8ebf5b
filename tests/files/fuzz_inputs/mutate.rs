//! The fuzz inputs: byte-level mutations of the corpus files (VDB grids and environment maps:
//! bit flips, interesting integers, truncations, splices, insertions and deletions) and
//! structural mutations of the glTF scenes' `BRUME_medium_vdb` objects. Iteration `i` of a
//! campaign with seed `s` is generated from `(s, i)` alone ([`input`]).
use brume::volume::check::SplitMix64;
use serde_json::{json, Value};

const INTERESTING_U32: [u32; 12] = [
    0,
    1,
    7,
    8,
    0xff,
    0x7fff,
    0xffff,
    0x7fff_ffff,
    0x8000_0000,
    0xffff_fffe,
    0xffff_ffff,
    4096,
];

/// One to four byte-level mutations of a corpus file (or a splice of two).
fn mutate_bytes(rng: &mut SplitMix64, corpus: &[(String, Vec<u8>)]) -> Vec<u8> {
    let mut b = corpus[rng.below(corpus.len() as u64) as usize].1.clone();
    for _ in 0..1 + rng.below(4) {
        let len = b.len().max(1) as u64;
        match rng.below(9) {
            0 => {
                // Bit flips.
                for _ in 0..1 + rng.below(8) {
                    if !b.is_empty() {
                        let i = rng.below(b.len() as u64) as usize;
                        b[i] ^= 1 << rng.below(8);
                    }
                }
            }
            1 => {
                // An interesting 32-bit integer (little endian, as OpenVDB writes) at a random
                // offset: counts, sizes and coordinates.
                if b.len() >= 4 {
                    let i = rng.below(b.len() as u64 - 3) as usize;
                    let v = INTERESTING_U32[rng.below(INTERESTING_U32.len() as u64) as usize];
                    b[i..i + 4].copy_from_slice(&v.to_le_bytes());
                }
            }
            2 => b.truncate(rng.below(len) as usize),
            3 => {
                // Splice: a prefix of this file and a suffix of another.
                let other = &corpus[rng.below(corpus.len() as u64) as usize].1;
                let cut = rng.below(len) as usize;
                let from = rng.below(other.len().max(1) as u64) as usize;
                b.truncate(cut);
                b.extend_from_slice(&other[from.min(other.len())..]);
            }
            4 => {
                // Random bytes inserted.
                let i = rng.below(len) as usize;
                let n = 1 + rng.below(64) as usize;
                let ins: Vec<u8> = (0..n).map(|_| rng.next_u64() as u8).collect();
                b.splice(i.min(b.len())..i.min(b.len()), ins);
            }
            5 => {
                // A range deleted.
                let i = rng.below(len) as usize;
                let n = 1 + rng.below(256) as usize;
                let end = (i + n).min(b.len());
                b.drain(i.min(end)..end);
            }
            6 => {
                // A range overwritten with random bytes.
                let i = rng.below(len) as usize;
                for j in i..(i + 1 + rng.below(32) as usize).min(b.len()) {
                    b[j] = rng.next_u64() as u8;
                }
            }
            7 => {
                // A chunk duplicated.
                let i = rng.below(len) as usize;
                let n = 1 + rng.below(512) as usize;
                let chunk: Vec<u8> = b[i.min(b.len())..(i + n).min(b.len())].to_vec();
                let at = rng.below(len) as usize;
                b.splice(at.min(b.len())..at.min(b.len()), chunk);
            }
            _ => {
                // A random length of random bytes (rarely a valid header).
                if rng.below(8) == 0 {
                    b = (0..rng.below(200)).map(|_| rng.next_u64() as u8).collect();
                }
            }
        }
    }
    b
}

use brume::scene::media::FIELDS as MEDIUM_FIELDS;

/// A JSON value of a random kind, biased toward the troublesome ones.
fn random_value(rng: &mut SplitMix64, depth: u32) -> Value {
    let numbers = [
        0.0,
        -0.0,
        1.0,
        -1.0,
        0.5,
        0.999_999_9,
        1.000_000_1,
        -0.999_999_9,
        1e-45,
        1e-320,
        3.4e38,
        3.5e38,
        -3.5e38,
        1e300,
        -1e300,
        f32::MAX as f64,
        f32::MIN_POSITIVE as f64,
        4294967296.0,
        9.007_199_254_740_992e15,
    ];
    match rng.below(if depth > 2 { 9 } else { 11 }) {
        0 => Value::Null,
        1 => Value::Bool(rng.coin()),
        2 => json!(numbers[rng.below(numbers.len() as u64) as usize]),
        3 => json!(rng.range(-10.0, 10.0)),
        4 => json!([i64::MIN, -1, 0, 1, 2, 3, i64::MAX][rng.below(7) as usize]),
        5 => json!(u64::MAX),
        6 => {
            let s = [
                "NaN",
                "nan",
                "Infinity",
                "-Infinity",
                "1e400",
                "",
                "density",
                "flame",
                "temperature",
                "grid.vdb",
                "missing.vdb",
                ".",
                "..",
                "/dev/null",
                "/dev/zero",
                "grid.vdb%",
                "grid%2Evdb",
                "%ff%fe",
                "data:application/octet-stream;base64,AAAA",
                "http://example.com/grid.vdb",
                "../fuzz/grid.vdb",
                "grid.vdb\u{0}x",
                "\u{1F32B}",
            ];
            json!(s[rng.below(s.len() as u64) as usize])
        }
        7 => json!("x".repeat(rng.below(5000) as usize)),
        8 => json!(1e308 * 10.0f64.powi(rng.below(3) as i32).min(1.0)),
        9 => {
            let n = rng.below(5) as usize;
            Value::Array((0..n).map(|_| random_value(rng, depth + 1)).collect())
        }
        _ => {
            let mut m = serde_json::Map::new();
            for _ in 0..rng.below(3) {
                m.insert(
                    MEDIUM_FIELDS[rng.below(MEDIUM_FIELDS.len() as u64) as usize].into(),
                    random_value(rng, depth + 1),
                );
            }
            Value::Object(m)
        }
    }
}

/// Mutates one `BRUME_medium_vdb` object in place.
fn mutate_medium(rng: &mut SplitMix64, m: &mut Value) {
    if !m.is_object() || rng.below(40) == 0 {
        *m = random_value(rng, 0);
        return;
    }
    let obj = m.as_object_mut().unwrap();
    let field = MEDIUM_FIELDS[rng.below(MEDIUM_FIELDS.len() as u64) as usize];
    match rng.below(7) {
        0 => {
            obj.remove(field);
        }
        1 => {
            obj.insert(format!("unknown{}", rng.below(100)), random_value(rng, 1));
        }
        2 => {
            // A colour with a bad component or a wrong length.
            let n = [0usize, 1, 2, 3, 3, 3, 4][rng.below(7) as usize];
            let mut arr: Vec<Value> = (0..n).map(|_| json!(rng.uniform())).collect();
            if n > 0 && rng.coin() {
                let i = rng.below(n as u64) as usize;
                arr[i] = random_value(rng, 1);
            }
            obj.insert(field.into(), Value::Array(arr));
        }
        3 => {
            // A number just outside or on the edge of its range.
            let edges = [
                -1.0,
                -1e-7,
                0.0,
                1.0,
                1.0 + 1e-7,
                0.999_999_94,
                -0.999_999_94,
                3.4028235e38,
                3.4028236e38,
            ];
            obj.insert(
                field.into(),
                json!(edges[rng.below(edges.len() as u64) as usize]),
            );
        }
        4 => {
            // Scale an existing number by a huge or tiny factor.
            if let Some(x) = obj.get(field).and_then(Value::as_f64) {
                let f = [1e-30, 1e-3, -1.0, 1e3, 1e30, 1e38][rng.below(6) as usize];
                obj.insert(field.into(), json!(x * f));
            }
        }
        _ => {
            obj.insert(field.into(), random_value(rng, 0));
        }
    }
}

/// One mutated glTF text: structural mutations of every `BRUME_medium_vdb` object, and
/// sometimes a few raw byte flips of the text.
fn mutate_gltf(rng: &mut SplitMix64, corpus: &[(String, Vec<u8>)]) -> Vec<u8> {
    let src = &corpus[rng.below(corpus.len() as u64) as usize].1;
    let mut doc: Value = serde_json::from_slice(src).expect("corpus files are valid JSON");
    if let Some(nodes) = doc.get_mut("nodes").and_then(Value::as_array_mut) {
        for node in nodes.iter_mut() {
            if let Some(m) = node.pointer_mut("/extensions/BRUME_medium_vdb") {
                for _ in 0..1 + rng.below(4) {
                    mutate_medium(rng, m);
                }
            }
        }
    }
    let mut text = serde_json::to_vec(&doc).unwrap();
    if rng.below(10) == 0 {
        for _ in 0..1 + rng.below(4) {
            if !text.is_empty() {
                let i = rng.below(text.len() as u64) as usize;
                let set = b"{}[]\",:0123456789.eE-+ntfalsu\\";
                text[i] = set[rng.below(set.len() as u64) as usize];
            }
        }
    }
    text
}

/// The input of iteration `i`: corpus files first, unmutated, then mutations.
pub(crate) fn input(kind: &str, corpus: &[(String, Vec<u8>)], seed: u64, i: u64) -> Vec<u8> {
    if (i as usize) < corpus.len() {
        return corpus[i as usize].1.clone();
    }
    let mut rng = SplitMix64(
        seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ i.wrapping_mul(0xD1B5_4A32_D192_ED03),
    );
    rng.next_u64();
    if kind == "gltf" {
        mutate_gltf(&mut rng, corpus)
    } else {
        mutate_bytes(&mut rng, corpus)
    }
}
