//! EXR output: round trips, what OpenImageIO sees, atomic writes, and bad input to the reader.
use brume::film::checksum::CHECKSUM_ATTRIBUTE;
use brume::film::{
    read_exr, read_exr_verified, write_atomically, write_exr, write_exr_single, AttrValue, Film,
    FilmError, Image, Metadata, RenderInfo,
};
use std::path::{Path, PathBuf};

/// A fresh, empty directory for one test under Cargo's per-target temporary directory.
fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("film_exr-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Names in `dir`, sorted: what a test leaves behind.
fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// A small film with noise, an empty pixel and a one-sample pixel.
fn noisy_film() -> Film {
    let (w, h) = (13, 7);
    let mut film = Film::new(w, h);
    let mut state = 0x1234_5678_u32;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        state as f32 / u32::MAX as f32
    };
    for y in 0..h {
        for x in 0..w {
            let n = match (x, y) {
                (0, 0) => 0,
                (1, 0) => 1,
                _ => 2 + (x * y) % 9,
            };
            for _ in 0..n {
                film.add_sample(x, y, [next() * 10.0, next(), 1.0 / (next() + 1e-3), next()]);
            }
        }
    }
    film
}

fn info() -> RenderInfo {
    RenderInfo {
        estimator: "residual_ratio".into(),
        b: 0.75,
        m: 4.0,
        majorant_mode: "dda".into(),
        spp: 64,
        seconds: 12.345678901,
        seed: u64::MAX - 1,
        scene: "scenes/nuage été.gltf".into(),
        backend: "cpu (2 threads)".into(),
    }
}

#[test]
fn round_trip_keeps_every_value_and_attribute() {
    let dir = scratch("round_trip");
    let path = dir.join("render.exr");
    let film = noisy_film();
    let metadata = info().to_metadata();
    write_exr(&path, &film, &metadata).unwrap();
    assert_eq!(listing(&dir), ["render.exr"], "no temporary file is left");

    let read = read_exr(&path).unwrap();
    // Every Brume EXR carries the checksum of what it holds, which the verified read checks.
    let sum = read
        .attributes
        .text(CHECKSUM_ATTRIBUTE)
        .expect("a checksum");
    let with_sum = metadata
        .clone()
        .with(CHECKSUM_ATTRIBUTE, AttrValue::Text(sum.to_string()));
    let expected = Image::from_film(&film, &with_sum.sorted());
    assert_eq!(read, expected);
    assert_eq!(read_exr_verified(&path).unwrap().0, expected);
    // Spot checks through the Film API, bit for bit.
    let i = 3 * 13 + 5;
    assert_eq!(read.rgb[i], film.mean(5, 3));
    assert_eq!(
        read.variance.as_ref().unwrap()[i],
        film.variance_of_mean(5, 3)
    );
    assert_eq!(
        read.samples.as_ref().unwrap()[i],
        film.sample_count(5, 3) as f32
    );
    assert_eq!(read.samples.as_ref().unwrap()[0], 0.0);
    assert_eq!(
        read.attributes.text("brume:scene"),
        Some("scenes/nuage été.gltf")
    );
    assert_eq!(
        read.attributes.text("brume:seed"),
        Some("18446744073709551614")
    );
    assert_eq!(
        read.attributes.text("brume:version"),
        Some(env!("CARGO_PKG_VERSION"))
    );
    assert_eq!(
        read.attributes.get("brume:seconds"),
        Some(&AttrValue::Double(12.345678901))
    );
    assert_eq!(read.attributes.get("brume:spp"), Some(&AttrValue::Int(64)));
    assert_eq!(
        read.attributes.get("brume:b"),
        Some(&AttrValue::Float(0.75))
    );
}

#[test]
fn writing_twice_gives_the_same_pixels() {
    let dir = scratch("twice");
    let film = noisy_film();
    write_exr(dir.join("a.exr"), &film, &Metadata::new()).unwrap();
    write_exr(dir.join("b.exr"), &film, &Metadata::new()).unwrap();
    // Without attributes the header order question does not arise: the files are identical.
    assert_eq!(
        std::fs::read(dir.join("a.exr")).unwrap(),
        std::fs::read(dir.join("b.exr")).unwrap()
    );
}

#[test]
fn single_channel_and_rgb_maps_round_trip() {
    let dir = scratch("single");
    let grey: Vec<f32> = (0..12).map(|i| i as f32 * 0.5).collect();
    let md = Metadata::new().with("brume:cost_units", AttrValue::Text("ns per sample".into()));
    write_exr_single(dir.join("y.exr"), 4, 3, &grey, &md).unwrap();
    let y = read_exr(dir.join("y.exr")).unwrap();
    assert_eq!((y.width, y.height), (4, 3));
    assert_eq!(y.rgb_at(3, 2), [5.5; 3]);
    assert!(y.alpha.is_none() && y.variance.is_none() && y.samples.is_none());
    assert_eq!(y.attributes.text("brume:cost_units"), Some("ns per sample"));

    let rgb: Vec<f32> = (0..36).map(|i| i as f32).collect();
    write_exr_single(dir.join("rgb.exr"), 4, 3, &rgb, &Metadata::new()).unwrap();
    let c = read_exr(dir.join("rgb.exr")).unwrap();
    assert_eq!(c.rgb_at(1, 0), [3.0, 4.0, 5.0]);
    assert_eq!(c.rgb_at(3, 2), [33.0, 34.0, 35.0]);

    let err = write_exr_single(dir.join("bad.exr"), 4, 3, &rgb[..7], &Metadata::new()).unwrap_err();
    assert!(err.to_string().contains("bad.exr"), "{err}");
    assert_eq!(listing(&dir), ["rgb.exr", "y.exr"]);
}

#[test]
fn oiiotool_reads_the_layers_and_attributes() {
    if std::process::Command::new("oiiotool")
        .arg("--version")
        .output()
        .is_err()
    {
        println!("SKIPPED: oiiotool is not on PATH (apt-get install openimageio-tools)");
        return;
    }
    let dir = scratch("oiiotool");
    let path = dir.join("render.exr");
    write_exr(&path, &noisy_film(), &info().to_metadata()).unwrap();
    let out = std::process::Command::new("oiiotool")
        .args(["--info", "-v"])
        .arg(&path)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "oiiotool failed: {text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for needle in [
        "8 channel, float openexr",
        "channel list: R, G, B, A, samples.Y, variance.R, variance.G, variance.B",
        "variance.R",
        "samples.Y",
        "brume:estimator: \"residual_ratio\"",
        "brume:majorant_mode: \"dda\"",
        "brume:spp: 64",
        "brume:seed: \"18446744073709551614\"",
        "brume:backend: \"cpu (2 threads)\"",
        "brume:b: 0.75",
        "brume:m: 4",
        "brume:version:",
        "brume:seconds: 12.34",
    ] {
        assert!(
            text.contains(needle),
            "oiiotool output lacks {needle:?}:\n{text}"
        );
    }
}

#[test]
fn writing_into_a_missing_directory_names_the_path_and_leaves_nothing() {
    let dir = scratch("missing_dir");
    let path = dir.join("no/such/dir/render.exr");
    let err = write_exr(&path, &noisy_film(), &Metadata::new()).unwrap_err();
    let message = err.to_string();
    assert!(message.contains(&path.display().to_string()), "{message}");
    assert!(matches!(err, FilmError::Io { .. }));
    assert!(!dir.join("no").exists());
    assert!(listing(&dir).is_empty());
}

#[test]
fn a_failed_write_does_not_clobber_the_existing_file() {
    let dir = scratch("no_clobber");
    let path = dir.join("render.exr");
    std::fs::write(&path, b"the previous render").unwrap();

    // The writer fails halfway through.
    let err = write_atomically(&path, |file| {
        use std::io::Write;
        file.write_all(b"half a new ").unwrap();
        Err(FilmError::InvalidInput {
            path: path.clone(),
            reason: "simulated failure".into(),
        })
    })
    .unwrap_err();
    assert!(err.to_string().contains("simulated failure"));
    assert_eq!(std::fs::read(&path).unwrap(), b"the previous render");
    assert_eq!(
        listing(&dir),
        ["render.exr"],
        "the temporary file is removed"
    );

    // Invalid metadata is refused before anything is written.
    let bad = Metadata::new().with("", AttrValue::Int(1));
    assert!(write_exr(&path, &noisy_film(), &bad).is_err());
    assert_eq!(std::fs::read(&path).unwrap(), b"the previous render");

    // The final rename fails (the destination is a directory): the data was fully written,
    // and still the temporary file goes and the directory stays.
    let taken = dir.join("taken.exr");
    std::fs::create_dir(&taken).unwrap();
    std::fs::write(taken.join("keep"), b"x").unwrap();
    let err = write_exr(&taken, &noisy_film(), &Metadata::new()).unwrap_err();
    assert!(err.to_string().contains("taken.exr"), "{err}");
    assert_eq!(listing(&dir), ["render.exr", "taken.exr"]);
    assert_eq!(listing(&taken), ["keep"]);

    // A successful write replaces the old file.
    write_exr(&path, &noisy_film(), &Metadata::new()).unwrap();
    assert!(read_exr(&path).is_ok());
    assert_eq!(listing(&dir), ["render.exr", "taken.exr"]);
}

/// The error's message, checked to name `path`.
fn read_error(path: &Path) -> String {
    let err = read_exr(path).expect_err("bad input must not read");
    let message = err.to_string();
    assert!(message.contains(&path.display().to_string()), "{message}");
    message
}

#[test]
fn bad_files_give_clear_errors() {
    let dir = scratch("bad_input");
    assert!(read_error(&dir.join("absent.exr")).contains("No such file"));
    assert!(read_error(&dir).contains("directory"));

    std::fs::write(
        dir.join("garbage.exr"),
        b"this is not an image at all, just bytes",
    )
    .unwrap();
    read_error(&dir.join("garbage.exr"));
    std::fs::write(dir.join("empty.exr"), b"").unwrap();
    read_error(&dir.join("empty.exr"));

    // A real EXR cut short.
    let whole = dir.join("whole.exr");
    write_exr(&whole, &noisy_film(), &info().to_metadata()).unwrap();
    let bytes = std::fs::read(&whole).unwrap();
    for keep in [4, 40, bytes.len() / 2, bytes.len() - 1] {
        let cut = dir.join(format!("cut{keep}.exr"));
        std::fs::write(&cut, &bytes[..keep]).unwrap();
        read_error(&cut);
    }
    // Random bytes behind a valid magic number and version.
    let mut fake = bytes[..8].to_vec();
    fake.extend((0..500u32).map(|i| (i.wrapping_mul(2_654_435_761) >> 24) as u8));
    std::fs::write(dir.join("fake.exr"), &fake).unwrap();
    read_error(&dir.join("fake.exr"));
}

#[test]
fn missing_channels_and_mismatched_parts_are_named() {
    use exr::prelude::*;
    let dir = scratch("channels");
    let channel = |name: &str, n: usize| AnyChannel::new(name, FlatSamples::F32(vec![0.5; n]));

    // Only depth: no colour.
    let z = dir.join("depth.exr");
    let layer = Layer::new(
        (4, 2),
        LayerAttributes::default(),
        Encoding::UNCOMPRESSED,
        AnyChannels::sort(vec![channel("Z", 8)].into_iter().collect()),
    );
    Image::from_layer(layer).write().to_file(&z).unwrap();
    let err = read_exr(&z).unwrap_err();
    assert!(
        matches!(&err, FilmError::MissingChannels { missing, .. } if missing == &["R", "G", "B"]),
        "{err}"
    );
    read_error(&z);

    // Colour with a partial variance layer.
    let partial = dir.join("partial.exr");
    let list = ["R", "G", "B", "variance.R", "variance.B"].map(|n| channel(n, 8));
    let layer = Layer::new(
        (4, 2),
        LayerAttributes::default(),
        Encoding::UNCOMPRESSED,
        AnyChannels::sort(list.into_iter().collect()),
    );
    Image::from_layer(layer).write().to_file(&partial).unwrap();
    let err = read_exr(&partial).unwrap_err();
    assert!(
        matches!(&err, FilmError::MissingChannels { missing, .. } if missing == &["variance.G"]),
        "{err}"
    );

    // Two parts of different sizes.
    let parts = dir.join("parts.exr");
    let rgb = Layer::new(
        (4, 2),
        LayerAttributes::named("beauty"),
        Encoding::UNCOMPRESSED,
        AnyChannels::sort(["R", "G", "B"].map(|n| channel(n, 8)).into_iter().collect()),
    );
    let var = Layer::new(
        (3, 3),
        LayerAttributes::named("variance"),
        Encoding::UNCOMPRESSED,
        AnyChannels::sort(["R", "G", "B"].map(|n| channel(n, 9)).into_iter().collect()),
    );
    Image::from_layers(
        ImageAttributes::new(IntegerBounds::from_dimensions((4, 3))),
        vec![rgb, var].into_iter().collect::<SmallVec<_>>(),
    )
    .write()
    .to_file(&parts)
    .unwrap();
    let err = read_exr(&parts).unwrap_err();
    assert!(matches!(err, FilmError::SizeMismatch { .. }), "{err}");
    assert!(
        err.to_string()
            .contains("part \"variance\" is 3x3 pixels, expected 4x2"),
        "{err}"
    );
    read_error(&parts);
}
