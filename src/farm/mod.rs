//! Rendering one image in parts (farm tasks, sample ranges, regions, checkpoints) and putting
//! it back together: what a part covers ([`coverage`]), what makes parts parts of one image
//! ([`key`]), a part read back whole ([`part`]), the header a render writes for it
//! ([`context`]), the merge ([`merge`]) and a render split over a Slurm array ([`slurm`]).
pub mod context;
pub mod coverage;
pub mod key;
pub mod merge;
pub mod part;
pub mod slurm;

pub use coverage::{coalesce, parse_range, parse_region, Coverage};
pub use key::{scene_hash, settings_key};
pub use merge::{check_mergeable, merge_files, merged_metadata};
pub use part::{read_part, read_part_info, Part, PartError, PartInfo};
