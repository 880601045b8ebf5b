//! The Embree shim and its safe wrapper: queries on a small mesh, and every failure a Rust
//! error naming what failed, never a crash.
use brume_ffi::embree::{EmbreeDevice, EmbreeErrorKind};

/// Two triangles making the unit square at z = 0.
const SQUARE: ([[f32; 3]; 4], [[u32; 3]; 2]) = (
    [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ],
    [[0, 1, 2], [0, 2, 3]],
);

#[test]
fn closest_hit_and_occlusion_on_a_square() {
    let device = EmbreeDevice::new().unwrap();
    let scene = device.triangle_scene(&SQUARE.0, &SQUARE.1).unwrap();
    assert!(
        device.memory_bytes() > 0,
        "Embree's memory callback counted nothing"
    );
    let hit = scene
        .closest_hit([0.75, 0.25, 1.0], [0.0, 0.0, -1.0], 0.0, f32::INFINITY)
        .unwrap();
    assert_eq!(hit.prim, 0);
    assert!((hit.t - 1.0).abs() < 1e-6, "{hit:?}");
    assert_eq!(
        scene
            .closest_hit([0.25, 0.75, 1.0], [0.0, 0.0, -1.0], 0.0, 10.0)
            .unwrap()
            .prim,
        1
    );
    // Outside the square, behind the origin, and beyond t_max: misses.
    assert!(scene
        .closest_hit([2.0, 2.0, 1.0], [0.0, 0.0, -1.0], 0.0, 10.0)
        .is_none());
    assert!(scene
        .closest_hit([0.5, 0.5, 1.0], [0.0, 0.0, 1.0], 0.0, 10.0)
        .is_none());
    assert!(scene.occluded([0.5, 0.2, 1.0], [0.0, 0.0, -1.0], 0.0, 2.0));
    assert!(!scene.occluded([0.5, 0.2, 1.0], [0.0, 0.0, -1.0], 0.0, 0.5));
    // The scene keeps its device alive.
    drop(device);
    assert!(scene.occluded([0.5, 0.2, 1.0], [0.0, 0.0, -1.0], 0.0, 2.0));
}

#[test]
fn a_bad_device_configuration_is_an_error() {
    let err = EmbreeDevice::with_config("threads=abc").unwrap_err();
    eprintln!("{err}");
    assert_eq!(err.kind, EmbreeErrorKind::Device);
    assert!(err.to_string().contains("creating a device"), "{err}");
    assert!(err.message.contains("rtcNewDevice"), "{err}");
    let err = EmbreeDevice::with_config("verbose=0\0").unwrap_err();
    assert_eq!(err.kind, EmbreeErrorKind::InvalidArgument, "{err}");
}

#[test]
fn degenerate_input_is_an_error_or_never_hit() {
    let device = EmbreeDevice::new().unwrap();
    let err = device.triangle_scene(&SQUARE.0, &[[0, 1, 4]]).unwrap_err();
    eprintln!("{err}");
    assert_eq!(err.kind, EmbreeErrorKind::InvalidArgument);
    assert!(
        err.message.contains("triangle 0 indexes vertex 4 of 4"),
        "{err}"
    );
    let err = device
        .triangle_scene(&[[0.0, f32::INFINITY, 0.0]; 3], &[[0, 1, 2]])
        .unwrap_err();
    assert!(err.message.contains("vertex 0 is not finite"), "{err}");
    // Zero-area triangles and an empty mesh build, and are never hit.
    let scene = device
        .triangle_scene(&[[1.0, 1.0, 0.0]; 3], &[[0, 1, 2]])
        .unwrap();
    assert!(scene
        .closest_hit([1.0, 1.0, 1.0], [0.0, 0.0, -1.0], 0.0, 10.0)
        .is_none());
    let empty = device.triangle_scene(&[], &[]).unwrap();
    assert!(!empty.occluded([0.0; 3], [1.0, 0.0, 0.0], 0.0, f32::INFINITY));
}
