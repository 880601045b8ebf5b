//! Streaming an image to the tev HDR viewer while a render converges.
//!
//! tev listens on a TCP socket (`127.0.0.1:14158` by default) for packets that each begin with
//! their own length, as a little-endian `u32` that counts those four bytes too, then a type
//! byte and the type's fields: booleans as one byte, `i32`s and `f32`s little-endian, strings
//! UTF-8 and NUL-terminated. Brume sends two types:
//!
//! - **CreateImage** (4): grab focus, the image's name, width, height, the channel count and
//!   the channel names. tev replaces an open image of the same name.
//! - **UpdateImage** (5, multi-channel): grab focus, the name, the channel count and names,
//!   the rectangle `x, y, width, height`, then its pixels as `f32`, one channel after another,
//!   each row-major from the rectangle's top-left.
//!
//! An image goes out in rectangles of at most [`PACKET_FLOATS`] values, so no packet exceeds
//! the 1 MiB that tev before version 1.17 read in one packet.
//!
//! A render never waits for the viewer: [`Display::connect`] returns at once and a background
//! thread connects and sends. [`Display::update`] leaves the image in a one-slot hand-off where
//! a newer image replaces one not yet taken, so a slow viewer only misses intermediate images.
//! The first failure (no connection, a lost connection, a viewer that stops reading) is told
//! once through the caller's `report`, and every later image is dropped.
use std::io::{self, Read, Write};
use std::net::{Shutdown, TcpStream, ToSocketAddrs};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use super::accum::Film;

/// The port tev listens on unless told otherwise.
pub const DEFAULT_PORT: u16 = 14158;

/// Floats of pixel data in one UpdateImage packet: 512 KiB, half of what tev before 1.17
/// accepted in one packet (it closed the connection on a larger one).
pub const PACKET_FLOATS: usize = 128 * 1024;

const CREATE_IMAGE: u8 = 4;
const UPDATE_IMAGE_MULTI: u8 = 5;

/// How long connecting to one address may take, and how long a write may stall on a viewer
/// that stopped reading before the connection counts as lost.
const CONNECT_TIMEOUT: Duration = Duration::from_secs(2);
const WRITE_TIMEOUT: Duration = Duration::from_secs(10);

/// Checks a `--display-server` value: `HOST:PORT` with a non-empty host (a name, an IPv4
/// address or a bracketed IPv6 one) and a port from 1 to 65535. Names are resolved later, by
/// the background thread, so a slow DNS never holds up the render.
pub fn parse_address(s: &str) -> Result<String, String> {
    let expected = format!("expected HOST:PORT, such as 127.0.0.1:{DEFAULT_PORT} (tev's default)");
    let Some((host, port)) = s.rsplit_once(':') else {
        return Err(expected);
    };
    if host.is_empty() || host.contains(char::is_whitespace) {
        return Err(format!("no host in {s:?}: {expected}"));
    }
    match port.parse::<u16>() {
        Ok(p) if p > 0 => Ok(s.to_string()),
        _ => Err(format!("{port:?} is not a port (1 to 65535): {expected}")),
    }
}

/// One image for the viewer: its name in tev's list, its size, and its channels by name (such
/// as `R`, `G`, `B`, or `volume.direct.R` for a light pass), each `width * height` values
/// row-major from the top-left.
#[derive(Debug, Clone, PartialEq)]
pub struct DisplayImage {
    pub name: String,
    pub width: u32,
    pub height: u32,
    pub channels: Vec<(String, Vec<f32>)>,
}

impl DisplayImage {
    /// An image with no channels yet; add them with [`DisplayImage::with_channel`].
    pub fn new(name: impl Into<String>, width: u32, height: u32) -> Self {
        Self {
            name: name.into(),
            width,
            height,
            channels: Vec::new(),
        }
    }

    /// The film's pixel means as channels `R`, `G`, `B`: the very values the EXR's beauty
    /// holds (each f64 mean rounded to f32).
    pub fn from_film(name: impl Into<String>, film: &Film) -> Self {
        let mut image = Self::new(name, film.width(), film.height());
        for (c, channel) in ["R", "G", "B"].into_iter().enumerate() {
            let values = film.pixels().iter().map(|p| p.mean[c] as f32).collect();
            image = image.with_channel(channel, values);
        }
        image
    }

    /// This image with one more channel.
    ///
    /// # Panics
    /// If `values` is not `width * height` long: a caller's bug, caught where it is made.
    pub fn with_channel(mut self, name: impl Into<String>, values: Vec<f32>) -> Self {
        let name = name.into();
        assert_eq!(
            values.len(),
            self.width as usize * self.height as usize,
            "channel {name} of the {}x{} display image {}",
            self.width,
            self.height,
            self.name
        );
        self.channels.push((name, values));
        self
    }

    fn channel_names(&self) -> Vec<&str> {
        self.channels.iter().map(|(n, _)| n.as_str()).collect()
    }
}

/// What the viewer's side looks like to the sending thread: the image tev holds, so a new
/// CreateImage goes out only when the name, size or channels change.
type Layout = (String, u32, u32, Vec<String>);

/// A connection to tev, run by a background thread; see the module's description.
pub struct Display {
    shared: Arc<Shared>,
}

/// What the caller's side and the sending thread share.
struct Shared {
    address: String,
    state: Mutex<State>,
    changed: Condvar,
    report: Box<dyn Fn(&str) + Send + Sync>,
}

#[derive(Default)]
struct State {
    /// The newest image not yet taken by the sending thread.
    pending: Option<DisplayImage>,
    /// Images handed over so far, and how many of them have been sent or dropped.
    posted: u64,
    done: u64,
    /// The caller has no more images: hang up once `pending` is sent.
    closing: bool,
    /// The sending thread has ended (hung up, or given up after a failure).
    ended: bool,
    /// A line has been reported: there is never a second.
    reported: bool,
}

impl Display {
    /// Starts connecting to `address` (`HOST:PORT`) on a background thread and returns at
    /// once. `report` receives at most one line in the display's life, naming the address and
    /// saying what went wrong; the caller prints it.
    pub fn connect(address: &str, report: impl Fn(&str) + Send + Sync + 'static) -> Display {
        let shared = Arc::new(Shared {
            address: address.to_string(),
            state: Mutex::new(State::default()),
            changed: Condvar::new(),
            report: Box::new(report),
        });
        let worker = shared.clone();
        let spawned = std::thread::Builder::new()
            .name("display".into())
            .spawn(move || worker.run());
        if let Err(e) = spawned {
            shared.give_up(&format!("no thread to send from ({})", describe(&e)));
        }
        Display { shared }
    }

    /// Whether images are still wanted: false once the connection has failed, so a caller can
    /// skip building them.
    pub fn is_live(&self) -> bool {
        !self.shared.lock().ended
    }

    /// Hands `image` to the sending thread, replacing an image it has not taken yet. Never
    /// blocks on the viewer.
    pub fn update(&self, image: DisplayImage) {
        let mut state = self.shared.lock();
        if state.ended || state.closing {
            return;
        }
        if state.pending.replace(image).is_some() {
            state.done += 1;
        }
        state.posted += 1;
        self.shared.changed.notify_all();
    }

    /// Waits up to `within` for every image handed over to be sent (or dropped after a
    /// failure); says so in the one report line when they were not. Returns whether they were.
    pub fn flush(&self, within: Duration) -> bool {
        let deadline = Instant::now() + within;
        let state = self
            .shared
            .wait_until(deadline, |s| s.done >= s.posted || s.ended);
        let sent = state.done >= state.posted || state.ended;
        if !sent {
            self.shared.report_once(
                state,
                &format!(
                    "the last image was not sent within {} s (the viewer is slow or \
                     unreachable)",
                    within.as_secs_f64()
                ),
            );
        }
        sent
    }

    /// Sends what is left (waiting up to `within`, as [`Display::flush`]), then hangs up.
    pub fn close(self, within: Duration) {
        let deadline = Instant::now() + within;
        self.shared.lock().closing = true;
        self.shared.changed.notify_all();
        if self.flush(within) {
            // The viewer has the image; give it the rest of the time to see the hang-up.
            drop(self.shared.wait_until(deadline, |s| s.ended));
        }
    }
}

impl Drop for Display {
    /// Lets the sending thread finish on its own; the process may exit before it does.
    fn drop(&mut self) {
        self.shared.lock().closing = true;
        self.shared.changed.notify_all();
    }
}

impl Shared {
    /// The state, even after a panic elsewhere: the display must never be the one to panic.
    fn lock(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The state once `ready` holds or `deadline` passes, whichever comes first.
    fn wait_until(
        &self,
        deadline: Instant,
        ready: impl Fn(&State) -> bool,
    ) -> MutexGuard<'_, State> {
        let mut state = self.lock();
        while !ready(&state) {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                break;
            }
            state = match self.changed.wait_timeout(state, left) {
                Ok((s, _)) => s,
                Err(e) => e.into_inner().0,
            };
        }
        state
    }

    fn report_once(&self, mut state: MutexGuard<'_, State>, what: &str) {
        if !std::mem::replace(&mut state.reported, true) {
            (self.report)(&format!("display server {}: {what}", self.address));
        }
    }

    /// Ends the sending thread after a failure: images are dropped from now on.
    fn give_up(&self, what: &str) {
        let mut state = self.lock();
        state.ended = true;
        state.pending = None;
        state.done = state.posted;
        self.changed.notify_all();
        self.report_once(state, &format!("{what}; the render goes on"));
    }

    /// The sending thread: connect, send each image handed over, hang up when closed.
    fn run(&self) {
        let mut stream = match connect(&self.address) {
            Ok(s) => s,
            Err(e) => return self.give_up(&format!("cannot connect ({})", describe(&e))),
        };
        let mut shown: Option<Layout> = None;
        while let Some(image) = self.next_image() {
            if let Err(e) = send_image(&mut stream, &image, &mut shown) {
                return self.give_up(&format!("connection lost ({})", describe(&e)));
            }
            self.lock().done += 1;
            self.changed.notify_all();
        }
        match hang_up(&mut stream) {
            Ok(()) => {
                self.lock().ended = true;
                self.changed.notify_all();
            }
            Err(e) => self.give_up(&format!("connection lost ({})", describe(&e))),
        }
    }

    /// The next image to send, waiting for one; `None` once the caller has closed and
    /// everything is sent.
    fn next_image(&self) -> Option<DisplayImage> {
        let mut state = self.lock();
        loop {
            if let Some(image) = state.pending.take() {
                return Some(image);
            }
            if state.closing {
                return None;
            }
            state = match self.changed.wait(state) {
                Ok(s) => s,
                Err(e) => e.into_inner(),
            };
        }
    }
}

/// Connects to the first of the address's resolutions that answers.
fn connect(address: &str) -> io::Result<TcpStream> {
    let mut last = io::Error::new(io::ErrorKind::NotFound, "the name resolves to no address");
    for addr in address.to_socket_addrs()? {
        match TcpStream::connect_timeout(&addr, CONNECT_TIMEOUT) {
            Ok(stream) => {
                stream.set_nodelay(true)?;
                stream.set_write_timeout(Some(WRITE_TIMEOUT))?;
                return Ok(stream);
            }
            Err(e) => last = e,
        }
    }
    Err(last)
}

/// Sends `image`, creating it in the viewer first unless `shown` says it holds one of the
/// same name, size and channels.
fn send_image(
    stream: &mut TcpStream,
    image: &DisplayImage,
    shown: &mut Option<Layout>,
) -> io::Result<()> {
    check_open(stream)?;
    let layout: Layout = (
        image.name.clone(),
        image.width,
        image.height,
        image.channels.iter().map(|(n, _)| n.clone()).collect(),
    );
    if shown.as_ref() != Some(&layout) {
        stream.write_all(&create_image_packet(image))?;
        *shown = Some(layout);
    }
    for rect in packet_rects(image.width, image.height, image.channels.len()) {
        stream.write_all(&update_image_packet(image, rect))?;
    }
    stream.flush()
}

/// An error when the viewer has closed its end (tev never sends anything, so readable data
/// can only be the end of the stream) or the connection was reset.
fn check_open(stream: &TcpStream) -> io::Result<()> {
    stream.set_nonblocking(true)?;
    let mut byte = [0u8; 1];
    let seen = stream.peek(&mut byte);
    stream.set_nonblocking(false)?;
    match seen {
        Ok(0) => Err(io::Error::new(
            io::ErrorKind::ConnectionAborted,
            "closed by the viewer",
        )),
        Ok(_) => Ok(()),
        Err(e) if e.kind() == io::ErrorKind::WouldBlock => Ok(()),
        Err(e) => Err(e),
    }
}

/// Ends the stream and waits (a little) for the viewer to close its end, which is when a
/// viewer that dropped the connection early shows it: a reset instead of an end of stream.
fn hang_up(stream: &mut TcpStream) -> io::Result<()> {
    stream.shutdown(Shutdown::Write)?;
    stream.set_read_timeout(Some(CONNECT_TIMEOUT))?;
    let mut sink = [0u8; 256];
    loop {
        match stream.read(&mut sink) {
            Ok(0) => return Ok(()),
            Ok(_) => {}
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                ) =>
            {
                return Ok(())
            }
            Err(e) => return Err(e),
        }
    }
}

/// An I/O failure in words: the system's message without its number (no "os error 32").
fn describe(e: &io::Error) -> String {
    match e.kind() {
        io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut => {
            "the viewer did not answer in time".to_string()
        }
        _ => {
            let text = e.to_string();
            match text.find(" (os error") {
                Some(i) => text[..i].to_string(),
                None => text,
            }
        }
    }
}

/// The rectangles, row-major from the top-left, in which an image of `channels` channels
/// goes out: whole rows where they fit in [`PACKET_FLOATS`], else pieces of rows.
pub fn packet_rects(width: u32, height: u32, channels: usize) -> impl Iterator<Item = [u32; 4]> {
    let per_pixel = channels.max(1);
    let w = width.min((PACKET_FLOATS / per_pixel).max(1) as u32).max(1);
    let h = height
        .min((PACKET_FLOATS / (w as usize * per_pixel)).max(1) as u32)
        .max(1);
    (0..height).step_by(h as usize).flat_map(move |y| {
        (0..width)
            .step_by(w as usize)
            .map(move |x| [x, y, w.min(width - x), h.min(height - y)])
    })
}

/// A packet under construction: the length field is filled in by [`Packet::finish`].
struct Packet(Vec<u8>);

impl Packet {
    fn new(kind: u8, capacity: usize) -> Self {
        let mut bytes = Vec::with_capacity(capacity + 64);
        bytes.extend_from_slice(&[0, 0, 0, 0, kind]);
        Packet(bytes)
    }

    fn bool(&mut self, b: bool) {
        self.0.push(b as u8);
    }

    /// A size or position, which tev reads as an `i32`.
    fn i32(&mut self, v: u32) {
        let v = i32::try_from(v).unwrap_or(i32::MAX);
        self.0.extend_from_slice(&v.to_le_bytes());
    }

    /// A NUL-terminated string; a NUL inside it (no file name has one) is left out.
    fn str(&mut self, s: &str) {
        self.0.extend(s.bytes().filter(|&b| b != 0));
        self.0.push(0);
    }

    fn f32s(&mut self, values: &[f32]) {
        for v in values {
            self.0.extend_from_slice(&v.to_le_bytes());
        }
    }

    fn finish(mut self) -> Vec<u8> {
        let len = u32::try_from(self.0.len()).unwrap_or(u32::MAX);
        self.0[..4].copy_from_slice(&len.to_le_bytes());
        self.0
    }
}

/// tev's CreateImage for `image`, taking the viewer's focus so the render shows at once.
pub fn create_image_packet(image: &DisplayImage) -> Vec<u8> {
    let mut p = Packet::new(CREATE_IMAGE, 0);
    p.bool(true);
    p.str(&image.name);
    p.i32(image.width);
    p.i32(image.height);
    p.i32(image.channels.len() as u32);
    for name in image.channel_names() {
        p.str(name);
    }
    p.finish()
}

/// tev's multi-channel UpdateImage with the pixels of `rect` (`[x, y, width, height]`).
pub fn update_image_packet(image: &DisplayImage, rect: [u32; 4]) -> Vec<u8> {
    let [x, y, w, h] = rect;
    let mut p = Packet::new(
        UPDATE_IMAGE_MULTI,
        4 * (w * h) as usize * image.channels.len(),
    );
    p.bool(false);
    p.str(&image.name);
    p.i32(image.channels.len() as u32);
    for name in image.channel_names() {
        p.str(name);
    }
    for v in [x, y, w, h] {
        p.i32(v);
    }
    let stride = image.width as usize;
    for (_, values) in &image.channels {
        for row in y..y + h {
            let start = row as usize * stride + x as usize;
            p.f32s(&values[start..start + w as usize]);
        }
    }
    p.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn addresses_need_a_host_and_a_port() {
        assert_eq!(parse_address("127.0.0.1:14158").unwrap(), "127.0.0.1:14158");
        assert!(parse_address("localhost:1").is_ok());
        assert!(parse_address("[::1]:14158").is_ok());
        for bad in [
            "14158",
            ":14158",
            "host:",
            "host:0",
            "host:70000",
            "host:port",
        ] {
            assert!(parse_address(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn rectangles_cover_the_image_once_within_the_packet_limit() {
        for (w, h, c) in [
            (7, 5, 3),
            (1000, 700, 3),
            (300_000, 2, 3),
            (1, 1, 1),
            (640, 480, 9),
        ] {
            let mut covered = vec![0u8; w as usize * h as usize];
            for [x, y, rw, rh] in packet_rects(w, h, c) {
                assert!(rw as usize * rh as usize * c <= PACKET_FLOATS.max(c));
                for yy in y..y + rh {
                    for xx in x..x + rw {
                        covered[(yy * w + xx) as usize] += 1;
                    }
                }
            }
            assert!(covered.iter().all(|&n| n == 1), "{w}x{h}x{c}");
        }
        assert_eq!(packet_rects(0, 0, 3).count(), 0);
    }

    #[test]
    fn packets_carry_their_length_and_fields() {
        let image = DisplayImage::new("a.exr", 2, 2)
            .with_channel("R", vec![1.0, 2.0, 3.0, 4.0])
            .with_channel("volume.direct.R", vec![5.0, 6.0, 7.0, 8.0]);
        let create = create_image_packet(&image);
        assert_eq!(
            u32::from_le_bytes(create[..4].try_into().unwrap()) as usize,
            create.len()
        );
        assert_eq!(&create[4..6], &[CREATE_IMAGE, 1]);
        assert_eq!(&create[6..12], b"a.exr\0");
        let update = update_image_packet(&image, [1, 0, 1, 2]);
        assert_eq!(
            u32::from_le_bytes(update[..4].try_into().unwrap()) as usize,
            update.len()
        );
        let floats: Vec<f32> = update[update.len() - 16..]
            .chunks(4)
            .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
            .collect();
        assert_eq!(
            floats,
            [2.0, 4.0, 6.0, 8.0],
            "column 1 of R, then of the pass"
        );
    }

    #[test]
    fn a_missing_viewer_is_reported_once_and_updates_are_dropped() {
        let free = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        let address = free.local_addr().unwrap().to_string();
        drop(free);
        let lines = Arc::new(Mutex::new(Vec::<String>::new()));
        let seen = lines.clone();
        let display = Display::connect(&address, move |l| seen.lock().unwrap().push(l.into()));
        for _ in 0..3 {
            display.update(DisplayImage::new("x", 1, 1).with_channel("R", vec![0.0]));
        }
        display.close(Duration::from_secs(2));
        let lines = lines.lock().unwrap();
        assert_eq!(lines.len(), 1, "{lines:?}");
        assert!(lines[0].starts_with(&format!("display server {address}: cannot connect")));
        assert!(!lines[0].to_lowercase().contains("error"), "{}", lines[0]);
    }
}
