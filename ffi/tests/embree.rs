//! The Embree shim and its safe wrapper: queries on a small mesh, and every failure a Rust
//! error naming what failed, never a crash.
use brume_ffi::embree::{EmbreeDevice, EmbreeErrorKind, EmbreeInstance, EmbreeMesh};

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
    assert_eq!((hit.inst, hit.prim), (None, 0));
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

/// A 3x4 column-major transform: scale `s` on each axis, then translation `t`.
fn scaled_moved(s: [f32; 3], t: [f32; 3]) -> [f32; 12] {
    [
        s[0], 0.0, 0.0, 0.0, s[1], 0.0, 0.0, 0.0, s[2], t[0], t[1], t[2],
    ]
}

#[test]
fn instances_name_their_placement_and_local_triangle() {
    let device = EmbreeDevice::new().unwrap();
    let square = EmbreeMesh {
        vertices: &SQUARE.0,
        indices: &SQUARE.1,
    };
    // The square as it is, doubled and moved along x, and mirrored in x (negative scale).
    let instances = [
        EmbreeInstance {
            mesh: 0,
            world_from_local: scaled_moved([1.0; 3], [0.0; 3]),
        },
        EmbreeInstance {
            mesh: 0,
            world_from_local: scaled_moved([2.0, 2.0, 1.0], [3.0, 0.0, 0.0]),
        },
        EmbreeInstance {
            mesh: 0,
            world_from_local: scaled_moved([-1.0, 1.0, 1.0], [-1.0, 0.0, 0.0]),
        },
    ];
    let scene = device.instanced_scene(&[square], &instances).unwrap();
    let down = [0.0, 0.0, -1.0];
    let hit = |x: f32, y: f32| scene.closest_hit([x, y, 2.0], down, 0.0, 10.0);
    let h = hit(0.75, 0.25).unwrap();
    assert_eq!((h.inst, h.prim), (Some(0), 0));
    assert!((h.t - 2.0).abs() < 1e-6, "{h:?}");
    // World (4.5, 0.5) is local (0.75, 0.25) of the doubled square; t is unchanged by scale.
    let h = hit(4.5, 0.5).unwrap();
    assert_eq!((h.inst, h.prim), (Some(1), 0));
    assert!((h.t - 2.0).abs() < 1e-6, "{h:?}");
    // World (-1.75, 0.25) is local (0.75, 0.25) of the mirrored square.
    let h = hit(-1.75, 0.25).unwrap();
    assert_eq!((h.inst, h.prim), (Some(2), 0));
    assert!(hit(2.0, 0.5).is_none());
    assert!(scene.occluded([4.5, 1.5, 2.0], down, 0.0, 3.0));
    assert!(!scene.occluded([2.5, 1.5, 2.0], down, 0.0, 3.0));
}

#[test]
fn bad_instances_are_errors_naming_them() {
    let device = EmbreeDevice::new().unwrap();
    let square = EmbreeMesh {
        vertices: &SQUARE.0,
        indices: &SQUARE.1,
    };
    let at = |mesh, t: f32| EmbreeInstance {
        mesh,
        world_from_local: scaled_moved([1.0; 3], [t, 0.0, 0.0]),
    };
    let err = device
        .instanced_scene(&[square], &[at(0, 0.0), at(1, 1.0)])
        .unwrap_err();
    eprintln!("{err}");
    assert_eq!(err.kind, EmbreeErrorKind::InvalidArgument);
    assert!(
        err.message.contains("instance 1 names mesh 1 of 1"),
        "{err}"
    );
    let err = device
        .instanced_scene(&[square], &[at(0, f32::NAN)])
        .unwrap_err();
    assert!(
        err.message.contains("instance 0's transform is not finite"),
        "{err}"
    );
    let bad = EmbreeMesh {
        vertices: &SQUARE.0,
        indices: &[[0, 1, 7]],
    };
    let err = device
        .instanced_scene(&[square, bad], &[at(0, 0.0)])
        .unwrap_err();
    assert!(
        err.message
            .contains("mesh 1: triangle 0 indexes vertex 7 of 4"),
        "{err}"
    );
    // No instances: a scene that nothing hits.
    let empty = device.instanced_scene(&[square], &[]).unwrap();
    assert!(!empty.occluded([0.5, 0.5, 1.0], [0.0, 0.0, -1.0], 0.0, 10.0));
}
