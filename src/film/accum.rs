//! Per-pixel running mean and variance, accumulated per tile and merged into the film.
//!
//! Each pixel keeps Welford's running mean and sum of squared deviations in f64 (Welford 1962;
//! the merge of two partial results is Chan, Golub and LeVeque 1979). Unlike raw sums of `x`
//! and `x^2`, this never subtracts two nearly equal large numbers, so a low-noise pixel with a
//! large mean keeps its variance, and a pixel whose samples are all equal has variance exactly 0.
//!
//! Determinism: floating-point addition is not associative, so the film's bits depend on the
//! order in which samples and tiles are combined. Brume fixes both: one thread renders a whole
//! tile, adding its samples in a fixed order, and finished tiles are merged into the film in
//! tile order ([`TileRect::index`], then pass). [`Film::merge_tiles_in_order`] does the sort,
//! so collecting tile buffers from any number of threads and merging them with it gives
//! bit-identical images.
use super::passes::PassLayers;
use super::tiles::TileRect;

/// Channels a pixel keeps statistics of: radiance R, G, B and the coverage A (1 minus the
/// camera path's transmittance to the background).
pub const CHANNELS: usize = 4;

/// Running statistics of the samples that landed in one pixel, per channel (R, G, B, A).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PixelStats {
    /// Number of samples.
    pub count: u32,
    /// Mean of the samples so far.
    pub mean: [f64; CHANNELS],
    /// Sum of squared deviations from the mean (Welford's `M2`); `m2 / (count - 1)` is the
    /// unbiased sample variance.
    pub m2: [f64; CHANNELS],
}

/// The R, G, B part of per-channel values.
#[inline]
pub fn rgb<T: Copy>(v: [T; CHANNELS]) -> [T; 3] {
    [v[0], v[1], v[2]]
}

impl PixelStats {
    /// Adds one sample, radiance and coverage (Welford's update).
    ///
    /// Non-finite samples are not filtered: a NaN or infinity poisons the pixel so that the
    /// fault shows in the image instead of silently biasing it.
    // Indexing three parallel arrays by channel reads more plainly than a triple zip.
    #[allow(clippy::needless_range_loop)]
    pub fn add(&mut self, rgba: [f32; CHANNELS]) {
        self.count += 1;
        let n = self.count as f64;
        for c in 0..CHANNELS {
            let x = rgba[c] as f64;
            let delta = x - self.mean[c];
            self.mean[c] += delta / n;
            // Uses the updated mean: delta * (x - new mean) is Welford's M2 increment.
            self.m2[c] += delta * (x - self.mean[c]);
        }
    }

    /// Folds another pixel's statistics into this one, as if its samples had been added here
    /// (Chan et al.'s pairwise combination).
    pub fn merge(&mut self, other: &PixelStats) {
        if other.count == 0 {
            return;
        }
        if self.count == 0 {
            *self = *other;
            return;
        }
        let (na, nb) = (self.count as f64, other.count as f64);
        let n = na + nb;
        for c in 0..CHANNELS {
            let delta = other.mean[c] - self.mean[c];
            self.mean[c] += delta * (nb / n);
            self.m2[c] += other.m2[c] + delta * delta * (na * nb / n);
        }
        self.count += other.count;
    }

    /// Unbiased sample variance of the samples (denominator `count - 1`); 0 with fewer than two
    /// samples, where it is unknown rather than zero (the sample count tells the two apart).
    pub fn sample_variance(&self) -> [f64; CHANNELS] {
        if self.count < 2 {
            return [0.0; CHANNELS];
        }
        let dof = (self.count - 1) as f64;
        // Rounding can leave M2 a hair below 0 after merges; a variance is never negative.
        self.m2.map(|m2| (m2 / dof).max(0.0))
    }

    /// Variance of the pixel mean as an estimate of the pixel's expected value: the sample
    /// variance divided by the sample count.
    pub fn variance_of_mean(&self) -> [f64; CHANNELS] {
        let n = self.count as f64;
        self.sample_variance()
            .map(|v| if v > 0.0 { v / n } else { 0.0 })
    }
}

/// A tile's private accumulation buffer: one rendering thread owns it while it renders the
/// tile, then hands it to [`Film::merge_tile`].
#[derive(Debug, Clone, PartialEq)]
pub struct TileBuffer {
    rect: TileRect,
    pass: u32,
    pixels: Vec<PixelStats>,
    /// The light passes asked for, `None` without.
    passes: Option<PassLayers>,
}

impl TileBuffer {
    /// An empty buffer for `rect` in pass 0.
    pub fn new(rect: TileRect) -> Self {
        Self::for_pass(rect, 0)
    }

    /// An empty buffer for `rect` in progressive pass `pass`; passes of the same tile merge in
    /// pass order.
    pub fn for_pass(rect: TileRect, pass: u32) -> Self {
        Self {
            rect,
            pass,
            pixels: vec![PixelStats::default(); rect.pixel_count()],
            passes: None,
        }
    }

    /// [`Self::for_pass`] keeping the light passes `names` too (none: as `for_pass`).
    pub fn with_passes(rect: TileRect, pass: u32, names: &[String]) -> Self {
        let mut t = Self::for_pass(rect, pass);
        if !names.is_empty() {
            t.passes = Some(PassLayers::new(names, rect.pixel_count()));
        }
        t
    }

    /// The rectangle this buffer covers.
    pub fn rect(&self) -> &TileRect {
        &self.rect
    }

    /// The pass this buffer belongs to.
    pub fn pass(&self) -> u32 {
        self.pass
    }

    /// Adds a sample (radiance and coverage) to pixel `(x, y)`, given in image coordinates.
    ///
    /// # Panics
    /// If `(x, y)` is outside the tile: a sample landing in another tile's pixel would be a
    /// bug in the caller's pixel loop.
    pub fn add_sample(&mut self, x: u32, y: u32, rgba: [f32; CHANNELS]) {
        let i = self.local_index(x, y);
        self.pixels[i].add(rgba);
    }

    /// [`Self::add_sample`] with the sample's light passes (one RGB per pass kept; ignored
    /// where the buffer keeps none).
    pub fn add_sample_passes(
        &mut self,
        x: u32,
        y: u32,
        rgba: [f32; CHANNELS],
        passes: &[[f32; 3]],
    ) {
        let i = self.local_index(x, y);
        self.pixels[i].add(rgba);
        if let Some(p) = &mut self.passes {
            p.add(i, self.pixels[i].count, passes);
        }
    }

    /// Statistics of pixel `(x, y)` in image coordinates.
    ///
    /// # Panics
    /// If `(x, y)` is outside the tile.
    pub fn pixel(&self, x: u32, y: u32) -> &PixelStats {
        &self.pixels[self.local_index(x, y)]
    }

    /// Total number of samples in the tile.
    pub fn sample_count(&self) -> u64 {
        self.pixels.iter().map(|p| p.count as u64).sum()
    }

    fn local_index(&self, x: u32, y: u32) -> usize {
        assert!(
            self.rect.contains(x, y),
            "pixel ({x}, {y}) is outside tile {:?}",
            self.rect
        );
        (y - self.rect.y0) as usize * self.rect.width() as usize + (x - self.rect.x0) as usize
    }
}

/// The image being rendered: per-pixel running mean and variance of radiance samples.
#[derive(Debug, Clone, PartialEq)]
pub struct Film {
    width: u32,
    height: u32,
    /// Row-major, row 0 at the top.
    pixels: Vec<PixelStats>,
    /// The light passes asked for, `None` without.
    passes: Option<PassLayers>,
}

impl Film {
    /// An empty film (no samples in any pixel).
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            pixels: vec![PixelStats::default(); width as usize * height as usize],
            passes: None,
        }
    }

    /// An empty film keeping the light passes `names` too (none: as [`Film::new`]).
    pub fn with_passes(width: u32, height: u32, names: &[String]) -> Self {
        let mut f = Self::new(width, height);
        if !names.is_empty() {
            f.passes = Some(PassLayers::new(names, f.pixels.len()));
        }
        f
    }

    /// The light passes' statistics, `None` where none were asked for.
    pub fn passes(&self) -> Option<&PassLayers> {
        self.passes.as_ref()
    }

    /// Gives the film light passes' statistics (a state read back from a file).
    ///
    /// # Panics
    /// If they do not cover the film's pixels.
    pub fn set_passes(&mut self, passes: PassLayers) {
        assert_eq!(
            passes.names().len() * 3 * self.pixels.len(),
            passes.len(),
            "passes for another film size"
        );
        self.passes = Some(passes);
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The pixels of rows `y0..y1`, row-major: for code that fills whole rows in parallel
    /// (the GPU backend's batches).
    ///
    /// # Panics
    /// If the rows are not inside the film.
    pub fn rows_mut(&mut self, y0: u32, y1: u32) -> &mut [PixelStats] {
        assert!(
            y0 <= y1 && y1 <= self.height,
            "rows {y0}..{y1} are outside the {}x{} film",
            self.width,
            self.height
        );
        let w = self.width as usize;
        &mut self.pixels[y0 as usize * w..y1 as usize * w]
    }

    /// Adds one sample straight to the film; for single-threaded code and tests. Renderers
    /// use a [`TileBuffer`] per thread instead.
    pub fn add_sample(&mut self, x: u32, y: u32, rgba: [f32; CHANNELS]) {
        let i = self.index(x, y);
        self.pixels[i].add(rgba);
    }

    /// Folds a finished tile into the film.
    ///
    /// Merging is sequential and its order decides the last bits of overlapping pixels (more
    /// than one pass per tile); merge in tile order, or use [`Film::merge_tiles_in_order`].
    ///
    /// # Panics
    /// If the tile does not lie inside the film.
    pub fn merge_tile(&mut self, tile: &TileBuffer) {
        let r = tile.rect;
        assert!(
            r.x1 <= self.width && r.y1 <= self.height,
            "tile {r:?} does not fit a {}x{} film",
            self.width,
            self.height
        );
        let w = r.width() as usize;
        for (row, stats) in tile.pixels.chunks_exact(w.max(1)).enumerate() {
            let start = self.index(r.x0, r.y0 + row as u32);
            for (k, src) in stats.iter().enumerate() {
                let i = start + k;
                // Passes first: their merge takes both counts before the beauty's changes.
                if let (Some(dst), Some(from)) = (&mut self.passes, &tile.passes) {
                    dst.merge(i, self.pixels[i].count, from, row * w + k, src.count);
                }
                self.pixels[i].merge(src);
            }
        }
    }

    /// Sorts tile buffers by (tile index, pass) and merges them in that order, so the result is
    /// the same bits however many threads produced them and in whatever order they finished.
    pub fn merge_tiles_in_order(&mut self, tiles: &mut [TileBuffer]) {
        tiles.sort_by_key(|t| (t.rect.index, t.pass));
        for tile in tiles.iter() {
            self.merge_tile(tile);
        }
    }

    /// A film holding `pixels` (row-major from the top-left), e.g. a state read back from a
    /// file; `None` when their number is not `width * height`.
    pub fn from_pixels(width: u32, height: u32, pixels: Vec<PixelStats>) -> Option<Self> {
        (pixels.len() == width as usize * height as usize).then_some(Self {
            width,
            height,
            pixels,
            passes: None,
        })
    }

    /// Folds another film of the same size into this one, pixel by pixel, as if its samples
    /// had been added here ([`PixelStats::merge`]); pixels without samples in either change
    /// nothing.
    ///
    /// # Panics
    /// If the sizes differ.
    pub fn merge_film(&mut self, other: &Film) {
        assert_eq!(
            (self.width, self.height),
            (other.width, other.height),
            "films of different sizes"
        );
        for (i, src) in other.pixels.iter().enumerate() {
            if let (Some(dst), Some(from)) = (&mut self.passes, &other.passes) {
                dst.merge(i, self.pixels[i].count, from, i, src.count);
            }
            self.pixels[i].merge(src);
        }
    }

    /// Statistics of pixel `(x, y)`.
    pub fn pixel(&self, x: u32, y: u32) -> &PixelStats {
        &self.pixels[self.index(x, y)]
    }

    /// All pixels, row-major from the top-left.
    pub fn pixels(&self) -> &[PixelStats] {
        &self.pixels
    }

    /// Pixel mean (the radiance estimate); black with no samples.
    pub fn mean(&self, x: u32, y: u32) -> [f32; 3] {
        rgb(self.pixel(x, y).mean).map(|m| m as f32)
    }

    /// The pixel's coverage estimate (alpha); 0 with no samples.
    pub fn alpha(&self, x: u32, y: u32) -> f32 {
        self.pixel(x, y).mean[3] as f32
    }

    /// Variance of the pixel mean (sample variance over the sample count) per R, G, B; 0
    /// with fewer than two samples.
    pub fn variance_of_mean(&self, x: u32, y: u32) -> [f32; 3] {
        rgb(self.pixel(x, y).variance_of_mean()).map(|v| v as f32)
    }

    /// Number of samples in pixel `(x, y)`.
    pub fn sample_count(&self, x: u32, y: u32) -> u32 {
        self.pixel(x, y).count
    }

    fn index(&self, x: u32, y: u32) -> usize {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) is outside the {}x{} film",
            self.width,
            self.height
        );
        y as usize * self.width as usize + x as usize
    }
}
