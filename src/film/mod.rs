//! The film: where per-sample radiance becomes an image, and where a render's measurements are
//! written out.
//!
//! - [`tiles()`] cuts the image into [`TileRect`]s in a fixed order.
//! - [`accum`] keeps per-pixel running mean and variance. Each rendering thread fills its own
//!   [`TileBuffer`]; [`Film::merge_tile`] folds finished tiles in, so threads never share memory
//!   and the result does not depend on the thread count.
//! - [`exr_io`] writes the film as one multi-channel OpenEXR file (beauty, variance of the pixel
//!   mean, sample count, render metadata) and reads such files back for comparisons.
//! - [`tile_log`] records per-tile work counters as JSON lines; [`cost_map`] turns them into a
//!   per-pixel heat map.
//! - [`atomic`] is the one way this module puts a file on disk: temporary file, fsync, rename.
//! - [`display`] streams the image, with any named channels, to the tev viewer while a render
//!   converges, never holding the render up.
pub mod accum;
pub mod adaptive;
pub mod atomic;
pub mod checksum;
pub mod cost_map;
pub mod display;
pub mod error;
pub mod exr_io;
pub mod metadata;
pub mod passes;
pub mod state;
pub mod tile_log;
pub mod tiles;

pub use accum::{Film, PixelStats, TileBuffer};
pub use atomic::{check_writable, write_atomically, AtomicFile};
pub use cost_map::{cost_map_from_tiles, per_sample, write_cost_map, CostMetric};
pub use display::{Display, DisplayImage};
pub use error::FilmError;
pub use exr_io::{
    read_exr, read_exr_channels, read_exr_verified, read_exr_with_state, write_exr,
    write_exr_single, write_exr_with_state, write_image, write_image_with, ExrChannels, Image,
};
pub use metadata::{AttrValue, Metadata, RenderInfo};
pub use tile_log::{read_tile_log, totals, TileCounters, TileLogWriter, TileRecord, TileTotals};
pub use tiles::{tiles, TileRect};
