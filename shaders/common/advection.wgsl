// Mirrors src/volume/advection.rs (`Advection::source` with `Advection::velocity_at`),
// VectorGrid::sample (src/volume/vector.rs), VelocityBlur::source and
// VelocityBlur::source_world (src/render/media.rs), Blur::index_point and Blur::world_point
// (src/integrator/views.rs) and NodeMotion::world_from_node (src/scene/motion.rs):
// the lookups of velocity motion blur and the camera's pose at a sample's time. Needs
// types.wgsl and grid.wgsl (the velocity's components live in the shared grid buffers after
// the density and emission grids, GpuGridInfo::cell_offset); camera_pose reads wf
// (wavefront.wgsl).
//
// The CPU advects in f64 and rounds the source point to f32; here every step is f32, so the
// points agree to rounding. The camera's rotation is interpolated as glam's slerp does it
// (its acos approximation, the linear blend above its dot threshold), and the pose's matrix
// is glam's from_rotation_translation, written as rows.

// The 3x4 affine map with rows `m` applied to point p.
fn rows_point(m: array<vec4<f32>, 3>, p: vec3<f32>) -> vec3<f32> {
    let q = vec4<f32>(p, 1.0);
    return vec3<f32>(dot(m[0], q), dot(m[1], q), dot(m[2], q));
}

// The linear part of the map with rows `m` applied to vector v.
fn rows_vector(m: array<vec4<f32>, 3>, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(m[0].xyz, v), dot(m[1].xyz, v), dot(m[2].xyz, v));
}

// Component a of VectorGrid::sample at velocity index point p: its trilinear lookup (OpenVDB's
// BoxSampler), read at p + 0.5 e_a for a staggered grid (StaggeredBoxSampler; adding 0 to the
// other coordinates changes nothing).
fn velocity_component(b: GpuVelocityBlur, a: u32, p: vec3<f32>) -> f32 {
    let e = vec3<f32>(vec3<bool>(a == 0u, a == 1u, a == 2u));
    var g = b.x;
    if (a == 1u) {
        g = b.y;
    } else if (a == 2u) {
        g = b.z;
    }
    return grid_sample_trilinear_in(g, p + (0.5 * f32(b.staggered)) * e);
}

// Advection::source: the density index point read for p at factor k, two steps of
// Advection::velocity_at (p1 = p - k u(p), q = p - k u(p1), u the velocity grid's value at the
// point mapped into its index space, as a density-index displacement); p itself at k == 0.
// The two steps' six component lookups run as one loop with one lookup in its body: Mesa
// inlines every call, and this function is inlined at every density lookup of every
// estimator, so each inlined copy carries one trilinear lookup rather than six (lavapipe's
// compile time grows with the copies).
fn advection_source(b: GpuVelocityBlur, p: vec3<f32>, k: f32) -> vec3<f32> {
    var q = p;
    var at = p;
    var v = vec3<f32>(0.0);
    let lookups = select(0u, 6u, k != 0.0);
    for (var i = 0u; i < lookups; i++) {
        let a = i % 3u;
        if (a == 0u) {
            // Advection::velocity_at: the point in the velocity's index space.
            at = rows_point(b.velocity_from_density, q);
        }
        let c = velocity_component(b, a, at);
        v = select(v, vec3<f32>(c), vec3<bool>(a == 0u, a == 1u, a == 2u));
        if (a == 2u) {
            q = p - k * rows_vector(b.index_from_value, v);
        }
    }
    return q;
}

// Blur::index_point with VelocityBlur::source: the index point a lookup at index point p by a
// sample at time offset dt reads (p where the medium is not blurred or dt is the frame's).
fn blur_index_point(b: GpuVelocityBlur, p: vec3<f32>, dt: f32) -> vec3<f32> {
    if (b.factor == 0.0 || dt == 0.0) {
        return p;
    }
    return advection_source(b, p, dt * b.factor);
}

// Blur::world_point with VelocityBlur::source_world: the world point an emission lookup at
// world point p_world (index point p_index) reads.
fn blur_world_point(b: GpuVelocityBlur, p_world: vec3<f32>, p_index: vec3<f32>,
                    dt: f32) -> vec3<f32> {
    if (b.factor == 0.0 || dt == 0.0) {
        return p_world;
    }
    return rows_point(b.world_from_index, advection_source(b, p_index, dt * b.factor));
}

// glam's acos_approx (DirectXMath's XMScalarAcos), which its slerp uses.
fn acos_approx(v: f32) -> f32 {
    let x = abs(v);
    let root = sqrt(max(1.0 - x, 0.0));
    let r = ((((((-0.0012624911 * x + 0.00667009) * x - 0.017088126) * x + 0.03089188) * x
        - 0.050174303) * x + 0.08897899) * x - 0.2145988) * x + 1.5707963;
    if (v >= 0.0) {
        return r * root;
    }
    return 3.14159265 - r * root;
}

// glam's Quat::slerp between unit quaternions a and b (the shorter arc).
fn quat_slerp(a: vec4<f32>, b_in: vec4<f32>, s: f32) -> vec4<f32> {
    var b = b_in;
    var d = dot(a, b);
    if (d < 0.0) {
        b = -b;
        d = -d;
    }
    // 1 - f32::EPSILON: nearly equal rotations blend linearly (no division by sin 0).
    if (d > 1.0 - 1.1920929e-7) {
        return normalize(a * (1.0 - s) + b * s);
    }
    let theta = acos_approx(d);
    return (b * sin(theta * s) + a * sin(theta * (1.0 - s))) / sin(theta);
}

// NodeMotion::world_from_node (for the camera, whose scale is 1): the rows of the camera's rigid pose at time offset dt, the
// poses on either side interpolated (rotation by slerp, position linearly), clamped to the
// shutter.
fn camera_pose(dt: f32) -> array<vec4<f32>, 3> {
// #if FEATURE_MOTION
    let steps = f32(GPU_CAMERA_POSES - 1u);
    let u = clamp((dt - wf.motion.open) / (wf.motion.close - wf.motion.open), 0.0, 1.0) * steps;
    let i = min(u32(floor(u)), GPU_CAMERA_POSES - 2u);
    let f = u - f32(i);
    let q = normalize(quat_slerp(wf.motion.rotation[i], wf.motion.rotation[i + 1u], f));
    let t = wf.motion.translation[i].xyz * (1.0 - f) + wf.motion.translation[i + 1u].xyz * f;
    // Mat4::from_rotation_translation (glam's quat_to_axes), row by row.
    let x2 = q.x + q.x;
    let y2 = q.y + q.y;
    let z2 = q.z + q.z;
    let xx = q.x * x2;
    let xy = q.x * y2;
    let xz = q.x * z2;
    let yy = q.y * y2;
    let yz = q.y * z2;
    let zz = q.z * z2;
    let wx = q.w * x2;
    let wy = q.w * y2;
    let wz = q.w * z2;
    return array<vec4<f32>, 3>(
        vec4<f32>(1.0 - (yy + zz), xy - wz, xz + wy, t.x),
        vec4<f32>(xy + wz, 1.0 - (xx + zz), yz - wx, t.y),
        vec4<f32>(xz - wy, yz + wx, 1.0 - (xx + yy), t.z));
// #endif
// #if !FEATURE_MOTION
    return wf.camera;
// #endif
}
