// Mirrors src/render/envmap.rs (EnvironmentMap: direction_to_uv, uv_to_direction,
// bilinear, le, sample, pdf) and src/sampling/piecewise.rs (find_interval, sample_1d,
// PiecewiseConstant2D::sample and pdf) for the wavefront kernels. Blender's equirectangular
// convention: u = 0.5 - atan2(d.y, d.x) / (2 pi), v = acos(d.z) / pi from the top row, with d
// the world direction in Blender's axes after the Mapping rotation (lookup_from_world).
// The pixels and the distribution share one f32 buffer (GpuEnvMap gives the offsets). Without
// FEATURE_ENV_MAP none of this is compiled and the environment is the constant wf.env.

// #if FEATURE_ENV_MAP
@group(1) @binding(16) var<uniform> env_map: GpuEnvMap;
@group(1) @binding(17) var<storage, read> env_data: array<f32>;

const ENV_ONE_BELOW: f32 = 0.99999994;

fn env_lookup_dir(w: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(env_map.row0.xyz, w), dot(env_map.row1.xyz, w), dot(env_map.row2.xyz, w));
}

// direction_to_uv.
fn env_direction_to_uv(d: vec3<f32>) -> vec2<f32> {
    var u = 0.5 - atan2(d.y, d.x) * (0.5 / PI);
    if (u >= 1.0) {
        u -= 1.0;
    }
    let v = acos(clamp(d.z, -1.0, 1.0)) / PI;
    return vec2<f32>(u, v);
}

// uv_to_direction.
fn env_uv_to_direction(uv: vec2<f32>) -> vec3<f32> {
    let phi = PI * (1.0 - 2.0 * uv.x);
    let theta = PI * uv.y;
    let st = sin(theta);
    return vec3<f32>(st * cos(phi), st * sin(phi), cos(theta));
}

fn env_pixel(i: i32, j: i32) -> vec3<f32> {
    let w = i32(env_map.width);
    let h = i32(env_map.height);
    var x = i % w;
    if (x < 0) {
        x += w;
    }
    let y = clamp(j, 0, h - 1);
    let k = 3u * u32(y * w + x);
    return vec3<f32>(env_data[k], env_data[k + 1u], env_data[k + 2u]);
}

// bilinear: columns wrap, rows clamp; pixel centres at (i + 0.5) / w.
fn env_bilinear(uv: vec2<f32>) -> vec3<f32> {
    let x = uv.x * f32(env_map.width) - 0.5;
    let y = uv.y * f32(env_map.height) - 0.5;
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    let i = i32(x0);
    let j = i32(y0);
    let top = env_pixel(i, j) * (1.0 - fx) + env_pixel(i + 1, j) * fx;
    let bottom = env_pixel(i, j + 1) * (1.0 - fx) + env_pixel(i + 1, j + 1) * fx;
    return top * (1.0 - fy) + bottom * fy;
}

// EnvironmentMap::le: radiance from world direction w.
fn env_le(w: vec3<f32>) -> vec3<f32> {
    return env_map.scale * env_bilinear(env_direction_to_uv(env_lookup_dir(w)));
}

// find_interval over env_data[first .. first + n + 1]: the last i in 0..n with cdf[i] <= u.
fn env_find_interval(first: u32, n: u32, u: f32) -> u32 {
    // Binary search for the first index in 1..=n with cdf > u (partition_point), minus one.
    var lo = 1u;
    var hi = n;
    while (lo < hi) {
        let mid = (lo + hi) / 2u;
        if (env_data[first + mid] <= u) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    // lo is in 1..=n: clamp(partition_point, 1, n) - 1.
    return lo - 1u;
}

// sample_1d: the interval and the offset within it.
fn env_sample_1d(first: u32, n: u32, u: f32) -> vec2<f32> {
    let i = env_find_interval(first, n, u);
    let c0 = env_data[first + i];
    let width = env_data[first + i + 1u] - c0;
    var d = 0.0;
    if (width > 0.0) {
        d = clamp((u - c0) / width, 0.0, ENV_ONE_BELOW);
    }
    return vec2<f32>(f32(i), d);
}

// PiecewiseConstant2D::pdf at uv (area measure).
fn env_pdf_uv(uv: vec2<f32>) -> f32 {
    let nu = env_map.width;
    let c = min(u32(uv.x * f32(nu)), nu - 1u);
    let v = min(u32(uv.y * f32(env_map.height)), env_map.height - 1u);
    return env_data[env_map.func_offset + v * nu + c] / env_map.integral;
}

// EnvironmentMap::pdf: solid-angle density of env_sample drawing world direction w.
fn env_pdf(w: vec3<f32>) -> f32 {
    if (env_map.uniform != 0u) {
        return INV_4PI;
    }
    let d = env_lookup_dir(w);
    let sin_theta = sqrt(max(1.0 - d.z * d.z, 0.0));
    if (!(sin_theta > 0.0)) {
        return 0.0;
    }
    return env_pdf_uv(env_direction_to_uv(d)) / (2.0 * PI * PI * sin_theta);
}

struct EnvSample {
    wi: vec3<f32>,
    pdf: f32,
    le: vec3<f32>,
    valid: bool,
}

// EnvironmentMap::sample with u in [0, 1)^2: u.y picks the row, u.x the column.
fn env_sample(u: vec2<f32>) -> EnvSample {
    var s: EnvSample;
    s.valid = false;
    if (env_map.uniform != 0u) {
        s.wi = uniform_sphere(u);
        s.le = env_le(s.wi);
        s.pdf = INV_4PI;
        s.valid = true;
        return s;
    }
    if (!(env_map.integral > 0.0)) {
        return s;
    }
    let nu = env_map.width;
    let nv = env_map.height;
    let rv = env_sample_1d(env_map.marg_offset, nv, u.y);
    let row = u32(rv.x);
    let cu = env_sample_1d(env_map.cond_offset + row * (nu + 1u), nu, u.x);
    let uv = vec2<f32>(
        min((cu.x + cu.y) / f32(nu), ENV_ONE_BELOW),
        min((rv.x + rv.y) / f32(nv), ENV_ONE_BELOW),
    );
    let d = env_uv_to_direction(uv);
    // The transpose of lookup_from_world takes the direction back to the world.
    s.wi = env_map.row0.xyz * d.x + env_map.row1.xyz * d.y + env_map.row2.xyz * d.z;
    s.pdf = env_pdf(s.wi);
    if (!(s.pdf > 0.0)) {
        return s;
    }
    s.le = env_map.scale * env_bilinear(uv);
    s.valid = true;
    return s;
}
// #endif
