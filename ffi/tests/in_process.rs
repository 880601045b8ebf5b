//! `BRUME_VDB_IN_PROCESS`: `VdbFile::open` reads in this process (for profilers that cannot
//! follow the re-executed reader) and gives what the isolated reader gives. Its own test
//! binary, because the variable is set for the whole process.
#[path = "../../tests/common/scratch.rs"]
mod scratch;

use brume_ffi::*;

#[test]
fn in_process_reads_what_the_isolated_reader_reads() {
    let dir = scratch::dir("in_process");
    let path = dir.join("g.vdb");
    let mut spec = GridSpec::fog("density", 0.25, [0.5, -1.0, 2.0]);
    for i in 0..300i32 {
        spec.voxels
            .push(([i % 17, (i * 7) % 23, -(i % 11)], 0.01 * i as f32));
    }
    write_float_grids(&path, &[spec]).unwrap();
    let read = |p: &std::path::Path| {
        VdbFile::open(p).and_then(|f| f.read_float_grid("density", ReadOptions::default()))
    };

    assert!(std::env::var_os(IN_PROCESS_ENV).is_none());
    let isolated = read(&path).unwrap();
    std::env::set_var(IN_PROCESS_ENV, "1");
    let in_process = read(&path).unwrap();
    assert_eq!(in_process.leaves, isolated.leaves);
    assert_eq!(in_process.tiles, isolated.tiles);
    assert_eq!(in_process.background, isolated.background);
    assert_eq!(
        in_process.info.active_voxel_count,
        isolated.info.active_voxel_count
    );

    // Errors still name the file.
    let missing = dir.join("missing.vdb");
    let err = read(&missing).unwrap_err().to_string();
    assert!(err.contains("missing.vdb"), "{err}");
}
