//! `brume render --display-server`: which images of a render go to the tev viewer, and when.
use std::path::Path;
use std::sync::Mutex;
use std::time::{Duration, Instant};

use brume::film::passes::PassLayers;
use brume::film::{Display, DisplayImage, Film};

/// The shortest time between two intermediate images: often enough to watch the noise clear,
/// rarely enough that copying the film costs the render nothing noticeable.
const EVERY: Duration = Duration::from_millis(500);

/// How long a finished render waits for its final image to reach the viewer.
pub const FLUSH: Duration = Duration::from_secs(2);

/// Starts the connection to tev at `address`; its one possible warning goes to stderr.
pub fn connect(address: &str) -> Display {
    Display::connect(address, |line| eprintln!("warning: {line}"))
}

/// One output file's image in the viewer, named after the file.
pub struct Viewer<'a> {
    display: &'a Display,
    name: String,
    /// A transparent film: the image carries its alpha, as the EXR does.
    transparent: bool,
    /// When the last intermediate image was handed over.
    shown: Mutex<Option<Instant>>,
}

impl<'a> Viewer<'a> {
    pub fn new(display: &'a Display, output: &Path, transparent: bool) -> Self {
        Viewer {
            display,
            name: output.display().to_string(),
            transparent,
            shown: Mutex::new(None),
        }
    }

    /// After a pass: the film's mean, unless an image went out less than [`EVERY`] ago.
    pub fn pass(&self, film: &Film) {
        self.pass_with(film, film.passes());
    }

    /// [`Viewer::pass`] for a film whose passes are kept apart while it renders (the GPU's).
    pub fn pass_with(&self, film: &Film, passes: Option<&PassLayers>) {
        let mut shown = self.shown.lock().unwrap_or_else(|e| e.into_inner());
        if shown.is_some_and(|t| t.elapsed() < EVERY) || !self.display.is_live() {
            return;
        }
        *shown = Some(Instant::now());
        self.display.update(self.image(film, passes));
    }

    /// The film's colour, its coverage as `A` on a transparent film, and its passes named as
    /// in the EXR.
    fn image(&self, film: &Film, passes: Option<&PassLayers>) -> DisplayImage {
        let mut image = DisplayImage::from_film(&self.name, film);
        if self.transparent {
            let alpha = film.pixels().iter().map(|p| p.mean[3] as f32).collect();
            image = image.with_channel("A", alpha);
        }
        if let Some(p) = passes {
            let pixels = film.pixels().len();
            for (k, name) in p.names().iter().enumerate() {
                for (channel, c) in brume::film::passes::exr_channels(name) {
                    let values = (0..pixels).map(|i| p.mean(i, k)[c] as f32).collect();
                    image = image.with_channel(channel, values);
                }
            }
        }
        image
    }

    /// The render's final film, whatever the time since the last image.
    pub fn last(&self, film: &Film) {
        if self.display.is_live() {
            self.display.update(self.image(film, film.passes()));
        }
    }

    /// Waits up to [`FLUSH`] for the final image to go out, so that the next frame's images
    /// cannot replace it and the process does not exit before it is sent.
    pub fn flush(&self) {
        self.display.flush(FLUSH);
    }
}
