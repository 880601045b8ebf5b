//! Cutting the image into rectangular tiles, the unit of work for a rendering thread.

/// A half-open pixel rectangle `[x0, x1) x [y0, y1)` of the image, with its position in the
/// fixed tile order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct TileRect {
    /// First column inside the tile.
    pub x0: u32,
    /// First row inside the tile (row 0 is the top of the image).
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
    /// Position in the order returned by [`tiles`]; films merge tiles in this order.
    pub index: u32,
}

impl TileRect {
    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.x1 - self.x0
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.y1 - self.y0
    }

    /// Number of pixels.
    pub fn pixel_count(&self) -> usize {
        self.width() as usize * self.height() as usize
    }

    /// Whether pixel `(x, y)` lies inside.
    pub fn contains(&self, x: u32, y: u32) -> bool {
        (self.x0..self.x1).contains(&x) && (self.y0..self.y1).contains(&y)
    }
}

/// Cuts a `width` x `height` image into tiles of at most `tile_size` x `tile_size` pixels.
///
/// The order is fixed and is part of Brume's determinism: rows of tiles from the top, each
/// row left to right, `index` counting up from 0. Tiles on the right and bottom edges are
/// clipped to the image. An empty image has no tiles.
///
/// # Panics
/// If `tile_size` is 0.
pub fn tiles(width: u32, height: u32, tile_size: u32) -> Vec<TileRect> {
    assert!(tile_size > 0, "tile size must be at least one pixel");
    let mut out = Vec::new();
    let mut index = 0;
    for y0 in (0..height).step_by(tile_size as usize) {
        for x0 in (0..width).step_by(tile_size as usize) {
            out.push(TileRect {
                x0,
                y0,
                x1: x0.saturating_add(tile_size).min(width),
                y1: y0.saturating_add(tile_size).min(height),
                index,
            });
            index += 1;
        }
    }
    out
}
