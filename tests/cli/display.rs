//! `brume render --display-server`: a tev viewer stood in for by a TCP server in the test that
//! decodes tev's packets. The viewer gets an image named after the output, with its size and
//! channels, updated more than once as the render converges and ending on the EXR's pixels bit
//! for bit (the GPU backend: its final image); a viewer that hangs up or is not there costs one
//! warning line and no bits.
use crate::common::cli::render_to;
use crate::common::scratch;
use crate::common::sequence::cloud_sequence;

use std::collections::BTreeMap;
use std::io::{ErrorKind, Read};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::Output;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use brume::film::read_exr;

/// A small render with several passes (1, 1, 2, 4, 8, 16, 16, 16 samples per pixel).
const SMALL: [&str; 8] = [
    "--spp",
    "64",
    "--width",
    "24",
    "--height",
    "18",
    "--backend",
    "cpu",
];

/// The largest packet tev before version 1.17 accepted.
const TEV_OLD_PACKET_LIMIT: usize = 1 << 20;

fn cloud() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cloud.gltf")
}

/// One packet as tev reads it.
#[derive(Debug)]
enum Packet {
    Create {
        grab_focus: bool,
        name: String,
        size: [i32; 2],
        channels: Vec<String>,
    },
    Update {
        name: String,
        channels: Vec<String>,
        rect: [i32; 4],
        /// Per channel, the rectangle's values row-major.
        values: Vec<Vec<f32>>,
    },
}

/// Reads a packet's fields in order, as tev's `IStream` does.
struct Fields<'a>(&'a [u8]);

impl Fields<'_> {
    fn take(&mut self, n: usize) -> &[u8] {
        assert!(self.0.len() >= n, "a field runs past the packet's end");
        let (head, tail) = self.0.split_at(n);
        self.0 = tail;
        head
    }
    fn byte(&mut self) -> u8 {
        self.take(1)[0]
    }
    fn i32(&mut self) -> i32 {
        i32::from_le_bytes(self.take(4).try_into().unwrap())
    }
    fn f32(&mut self) -> f32 {
        f32::from_le_bytes(self.take(4).try_into().unwrap())
    }
    fn string(&mut self) -> String {
        let end = self
            .0
            .iter()
            .position(|&b| b == 0)
            .expect("a NUL-terminated string");
        let s = String::from_utf8(self.take(end).to_vec()).expect("UTF-8");
        self.take(1);
        s
    }
    fn strings(&mut self, n: i32) -> Vec<String> {
        (0..n).map(|_| self.string()).collect()
    }
}

/// Decodes one packet: `body` is what follows its length field.
fn decode(body: &[u8]) -> Packet {
    let mut f = Fields(body);
    let packet = match f.byte() {
        4 => Packet::Create {
            grab_focus: f.byte() == 1,
            name: f.string(),
            size: [f.i32(), f.i32()],
            channels: {
                let n = f.i32();
                f.strings(n)
            },
        },
        5 => {
            let _grab_focus = f.byte();
            let name = f.string();
            let n = f.i32();
            let channels = f.strings(n);
            let rect = [f.i32(), f.i32(), f.i32(), f.i32()];
            let count = (rect[2] * rect[3]) as usize;
            let values = (0..n)
                .map(|_| (0..count).map(|_| f.f32()).collect())
                .collect();
            Packet::Update {
                name,
                channels,
                rect,
                values,
            }
        }
        other => panic!("packet type {other}: brume sends CreateImage (4) and UpdateImage (5)"),
    };
    assert!(
        f.0.is_empty(),
        "{} bytes after the packet's fields",
        f.0.len()
    );
    packet
}

/// A stand-in for tev on 127.0.0.1: accepts one connection and decodes its packets until the
/// client hangs up, or hangs up itself after `hang_up_after` packets. Returns the packets and
/// the largest packet's size.
fn viewer(hang_up_after: Option<usize>) -> (String, JoinHandle<(Vec<Packet>, usize)>) {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let address = listener.local_addr().unwrap().to_string();
    let serve = std::thread::spawn(move || {
        let mut stream = accept_within(&listener, Duration::from_secs(60));
        let (mut packets, mut largest) = (Vec::new(), 0);
        while hang_up_after != Some(packets.len()) {
            let mut len = [0u8; 4];
            match stream.read_exact(&mut len) {
                Ok(()) => {}
                Err(e) if e.kind() == ErrorKind::UnexpectedEof => break,
                Err(e) => panic!("reading a packet's length: {e}"),
            }
            let len = u32::from_le_bytes(len) as usize;
            assert!(len > 5, "a packet of {len} bytes");
            let mut body = vec![0u8; len - 4];
            stream.read_exact(&mut body).expect("a whole packet");
            largest = largest.max(len);
            packets.push(decode(&body));
        }
        (packets, largest)
    });
    (address, serve)
}

fn accept_within(listener: &TcpListener, limit: Duration) -> TcpStream {
    listener.set_nonblocking(true).unwrap();
    let start = Instant::now();
    loop {
        match listener.accept() {
            Ok((stream, _)) => {
                stream.set_nonblocking(false).unwrap();
                return stream;
            }
            Err(e) if e.kind() == ErrorKind::WouldBlock && start.elapsed() < limit => {
                std::thread::sleep(Duration::from_millis(5))
            }
            Err(e) => panic!("no connection from brume: {e}"),
        }
    }
}

/// What the viewer shows of each image after all the packets: its size, channels and
/// pixels, and how many whole images' worth of pixels arrived.
struct Shown {
    size: [i32; 2],
    channels: Vec<String>,
    pixels: Vec<Vec<f32>>,
    images: f64,
}

fn replay(packets: &[Packet]) -> BTreeMap<String, Shown> {
    let mut shown: BTreeMap<String, Shown> = BTreeMap::new();
    for p in packets {
        match p {
            Packet::Create {
                name,
                size,
                channels,
                ..
            } => {
                let n = (size[0] * size[1]) as usize;
                let pixels = vec![vec![f32::NAN; n]; channels.len()];
                let s = Shown {
                    size: *size,
                    channels: channels.clone(),
                    pixels,
                    images: 0.0,
                };
                shown.insert(name.clone(), s);
            }
            Packet::Update {
                name,
                channels,
                rect: [x, y, w, h],
                values,
            } => {
                let s = shown.get_mut(name).expect("an update of a created image");
                assert_eq!(channels, &s.channels, "{name}: the created channels");
                assert!(x + w <= s.size[0] && y + h <= s.size[1], "{name}: inside");
                for (plane, vals) in s.pixels.iter_mut().zip(values) {
                    for (k, v) in vals.iter().enumerate() {
                        let (px, py) = (x + k as i32 % w, y + k as i32 / w);
                        plane[(py * s.size[0] + px) as usize] = *v;
                    }
                }
                s.images += (w * h) as f64 / (s.size[0] * s.size[1]) as f64;
            }
        }
    }
    shown
}

/// The EXR's beauty as R, G and B planes of bits.
fn exr_bits(path: &Path) -> Vec<Vec<u32>> {
    let rgb = read_exr(path).unwrap().rgb;
    (0..3)
        .map(|c| rgb.iter().map(|p| p[c].to_bits()).collect())
        .collect()
}

fn bits(planes: &[Vec<f32>]) -> Vec<Vec<u32>> {
    planes
        .iter()
        .map(|p| p.iter().map(|v| v.to_bits()).collect())
        .collect()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The lines of a render's stderr that speak of the display server.
fn display_lines(o: &Output) -> Vec<String> {
    stderr(o)
        .lines()
        .filter(|l| l.contains("display server"))
        .map(str::to_string)
        .collect()
}

#[test]
fn the_viewer_watches_the_render_converge_to_the_exr() {
    let out = scratch::file("display.exr");
    let (address, serve) = viewer(None);
    let o = render_to(&cloud(), &out, &SMALL, &["--display-server", &address]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(display_lines(&o), Vec::<String>::new(), "no warning");
    let (packets, largest) = serve.join().expect("the viewer decodes every packet");
    let Some(Packet::Create { grab_focus, .. }) = packets.first() else {
        panic!("the first packet creates the image: {:?}", packets.first());
    };
    assert!(grab_focus, "the image takes the viewer's focus");
    let shown = replay(&packets);
    let name = out.display().to_string();
    let image = &shown[&name];
    assert_eq!(shown.len(), 1, "one image, named after the output");
    assert_eq!(image.size, [24, 18]);
    assert_eq!(image.channels, ["R", "G", "B"]);
    assert!(
        largest <= TEV_OLD_PACKET_LIMIT,
        "a packet of {largest} bytes"
    );
    assert!(
        image.images >= 2.0,
        "{} images sent: at least one while rendering and the final one",
        image.images
    );
    assert_eq!(
        bits(&image.pixels),
        exr_bits(&out),
        "the last image is the EXR"
    );
    println!(
        "{} packets, {} whole images of {name}, largest packet {largest} bytes",
        packets.len(),
        image.images
    );
}

/// On the GPU backend the viewer sees the passes converge too: an image after a pass and the
/// final one, with the light passes as channels (where no Vulkan adapter exists the render
/// says so and the test is SKIPPED).
#[test]
fn the_gpu_render_streams_its_passes_as_it_converges() {
    let out = scratch::file("display_gpu.exr");
    let (address, serve) = viewer(None);
    let args = [
        "--display-server",
        &address,
        "--backend",
        "gpu",
        "--passes",
        "light",
    ];
    let o = render_to(&cloud(), &out, &SMALL[..6], &args);
    if !o.status.success() {
        assert!(stderr(&o).contains("adapter"), "{}", stderr(&o));
        println!("SKIPPED: no Vulkan adapter: {}", stderr(&o).trim());
        return;
    }
    let (packets, _) = serve.join().expect("the viewer decodes every packet");
    let shown = replay(&packets);
    let image = &shown[&out.display().to_string()];
    assert!(
        image.channels.iter().any(|c| c == "volume.direct.R"),
        "{:?}",
        image.channels
    );
    assert!(image.images >= 2.0, "{} images sent", image.images);
    let rgb: Vec<Vec<f32>> = image.pixels[..3].to_vec();
    assert_eq!(bits(&rgb), exr_bits(&out), "the last image is the EXR");
    println!(
        "GPU: {} whole images, channels {:?}",
        image.images, image.channels
    );
}

/// The render without a viewer, to compare bits with.
fn reference(name: &str) -> Vec<Vec<u32>> {
    let out = scratch::file(name);
    let o = render_to(&cloud(), &out, &SMALL, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    exr_bits(&out)
}

/// Asserts one warning line, starting `warning: display server ADDRESS: WHAT`, without the
/// word "error", and a successful render.
fn assert_one_warning(o: &Output, address: &str, what: &str) {
    assert!(o.status.success(), "{}", stderr(o));
    let lines = display_lines(o);
    println!("{lines:?}");
    assert_eq!(lines.len(), 1, "one line about the viewer:\n{}", stderr(o));
    let expected = format!("warning: display server {address}: {what}");
    assert!(
        lines[0].starts_with(&expected),
        "{:?} not {expected:?}",
        lines[0]
    );
    assert!(lines[0].ends_with("; the render goes on"), "{}", lines[0]);
    assert!(!lines[0].to_lowercase().contains("error"), "{}", lines[0]);
    assert!(!stderr(o).contains("panicked"), "{}", stderr(o));
}

#[test]
fn a_viewer_that_hangs_up_costs_one_warning_and_no_bits() {
    let out = scratch::file("display_hang_up.exr");
    let (address, serve) = viewer(Some(1));
    let o = render_to(&cloud(), &out, &SMALL, &["--display-server", &address]);
    let (packets, _) = serve.join().unwrap();
    assert!(
        matches!(packets[..], [Packet::Create { .. }]),
        "{packets:?}"
    );
    assert_one_warning(&o, &address, "connection lost (");
    assert_eq!(exr_bits(&out), reference("display_hang_up_ref.exr"));
}

#[test]
fn no_viewer_costs_one_warning_and_no_bits() {
    let out = scratch::file("display_nowhere.exr");
    // A port that was just free: nothing listens there.
    let address = {
        let l = TcpListener::bind("127.0.0.1:0").unwrap();
        l.local_addr().unwrap().to_string()
    };
    let o = render_to(&cloud(), &out, &SMALL, &["--display-server", &address]);
    assert_one_warning(&o, &address, "cannot connect (Connection refused)");
    assert_eq!(exr_bits(&out), reference("display_nowhere_ref.exr"));
}

#[test]
fn each_frame_is_an_image_of_its_own() {
    let dir = scratch::dir("display_frames");
    let scene = cloud_sequence(&dir, [1, 2]);
    let pattern = dir.join("out_####.exr");
    let (address, serve) = viewer(None);
    let extra = ["--frames", "1..2", "--display-server", &address];
    let o = render_to(&scene, &pattern, &SMALL, &extra);
    assert!(o.status.success(), "{}", stderr(&o));
    let (packets, _) = serve.join().unwrap();
    let shown = replay(&packets);
    let frames = [1, 2].map(|f| dir.join(format!("out_{f:04}.exr")));
    let names: Vec<String> = frames.iter().map(|f| f.display().to_string()).collect();
    assert_eq!(
        shown.keys().cloned().collect::<Vec<_>>(),
        names,
        "one image per frame"
    );
    for frame in &frames {
        let image = &shown[&frame.display().to_string()];
        assert_eq!(bits(&image.pixels), exr_bits(frame), "{}", frame.display());
    }
}

/// The GPU backend has no per-pass hook: the viewer gets its final image, the EXR's bits.
#[test]
fn the_gpu_backend_shows_its_final_image() {
    let out = scratch::file("display_gpu.exr");
    let (address, serve) = viewer(None);
    let args = ["--backend", "gpu", "--display-server", &address];
    let few = ["--spp", "4", "--width", "24", "--height", "18"];
    let o = render_to(&cloud(), &out, &few, &args);
    if !o.status.success() && stderr(&o).contains("--backend gpu:") {
        let why = stderr(&o).lines().last().unwrap_or("").to_string();
        println!("SKIPPED: no GPU backend here ({why})");
        // The render failed before its first image; the viewer still saw a connection.
        drop(serve.join());
        return;
    }
    assert!(o.status.success(), "{}", stderr(&o));
    let (packets, _) = serve.join().unwrap();
    let shown = replay(&packets);
    let image = &shown[&out.display().to_string()];
    assert!(image.images >= 1.0, "the final image");
    assert_eq!(
        bits(&image.pixels),
        exr_bits(&out),
        "the last image is the EXR"
    );
    println!("{} packets, {} whole images", packets.len(), image.images);
}

#[test]
fn a_bad_address_is_refused_saying_what_is_expected() {
    let out = scratch::file("display_bad.exr");
    for bad in ["14158", "localhost:", "localhost:99999"] {
        let o = render_to(&cloud(), &out, &SMALL, &["--display-server", bad]);
        let err = stderr(&o);
        println!("{bad}: {}", err.lines().next().unwrap_or(""));
        assert!(!o.status.success(), "{bad} accepted");
        assert!(
            err.contains("--display-server") && err.contains("HOST:PORT"),
            "{err}"
        );
        assert!(!out.exists(), "nothing rendered");
    }
}

#[test]
fn the_viewer_shows_the_alpha_and_every_pass_asked_for() {
    let out = scratch::file("display_passes.exr");
    let (address, serve) = viewer(None);
    let extra = [
        "--display-server",
        &address,
        "--passes",
        "all",
        "--film",
        "transparent",
    ];
    let o = render_to(&cloud(), &out, &SMALL, &extra);
    assert!(o.status.success(), "{}", stderr(&o));
    let (packets, _) = serve.join().expect("the viewer decodes every packet");
    let shown = replay(&packets);
    let image = &shown[&out.display().to_string()];
    let mut expected: Vec<String> = ["R", "G", "B", "A"].map(String::from).to_vec();
    for pass in brume::film::passes::LIGHT_PASSES
        .iter()
        .chain(&brume::film::passes::DATA_PASSES)
    {
        expected.extend(
            brume::film::passes::exr_channels(pass)
                .into_iter()
                .map(|(c, _)| c),
        );
    }
    let scene = brume::scene::load(&cloud()).unwrap();
    let groups = brume::render::light_groups::LightGroups::of(&scene).unwrap();
    for group in &groups.names {
        expected.extend(["R", "G", "B"].map(|c| format!("{group}.{c}")));
    }
    println!("channels shown: {}", image.channels.join(" "));
    assert_eq!(image.channels, expected);
    assert_eq!(
        bits(&image.pixels[..3]),
        exr_bits(&out),
        "the colour is the EXR's"
    );
}
