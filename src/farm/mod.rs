//! Rendering one image in parts (farm tasks, sample ranges, regions, checkpoints) and putting
//! it back together: what a part covers ([`coverage`]), what makes parts parts of one image
//! ([`key`]), a part read back whole ([`part`]) and the merge ([`merge`]).
pub mod coverage;
pub mod key;
pub mod merge;
pub mod part;

pub use coverage::{coalesce, parse_range, parse_region, Coverage};
pub use key::{scene_hash, settings_key};
pub use merge::{check_mergeable, merge_files, merged_metadata};
pub use part::{read_part, read_part_info, Part, PartError, PartInfo};
