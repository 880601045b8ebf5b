// Mirrors src/scene/texture.rs: TextureRef::sample (wrap_index, floor_index, nearest or
// bilinear, KHR_texture_transform) and Scene::uv_at, texture_rgb, base_color_at, emission_at.
// The texels are the CPU's decoded linear RGBA, uploaded as they are (GpuTexture::offset
// locates each image), and the texture coordinates of each triangle come in the BVH's
// primitive order (GpuTriangleUv), like GpuTriangle. Without FEATURE_TEXTURES every texture
// reads as white and none of the three buffers is bound.

// #if FEATURE_TEXTURES
@group(1) @binding(13) var<storage, read> triangle_uvs: array<GpuTriangleUv>;
@group(1) @binding(14) var<storage, read> textures: array<GpuTexture>;
@group(1) @binding(15) var<storage, read> texels: array<vec4<f32>>;

// i.rem_euclid(n) for n > 0 (WGSL's % truncates towards zero, as Rust's).
fn rem_euclid_i32(i: i32, n: i32) -> i32 {
    let r = i % n;
    return select(r, r + n, r < 0);
}

// wrap_index: texel index along an axis of n texels by TEXTURE_WRAP_* mode.
fn wrap_index(i: i32, n: i32, wrap: u32) -> i32 {
    if (wrap == TEXTURE_WRAP_CLAMP) {
        return clamp(i, 0, n - 1);
    }
    if (wrap == TEXTURE_WRAP_MIRROR) {
        let m = rem_euclid_i32(i, 2 * n);
        return select(m, 2 * n - 1 - m, m >= n);
    }
    return rem_euclid_i32(i, n);
}

// floor_index: floor(x) clamped to +-1e9 before the conversion.
fn floor_index(x: f32) -> i32 {
    return i32(clamp(floor(x), -1.0e9, 1.0e9));
}

fn texel(t: GpuTexture, i: i32, j: i32) -> vec4<f32> {
    let w = i32(t.width);
    let x = wrap_index(i, w, t.wrap_s);
    let y = wrap_index(j, i32(t.height), t.wrap_t);
    return texels[t.offset + u32(y * w + x)];
}

// TextureRef::sample: linear RGBA at texture coordinate uv (before the transform).
fn texture_sample(t: GpuTexture, uv: vec2<f32>) -> vec4<f32> {
    let st = vec2<f32>(
        t.row0.x * uv.x + t.row0.y * uv.y + t.row0.z,
        t.row1.x * uv.x + t.row1.y * uv.y + t.row1.z,
    );
    let w = f32(t.width);
    let h = f32(t.height);
    if (t.nearest != 0u) {
        return texel(t, floor_index(st.x * w), floor_index(st.y * h));
    }
    let x = st.x * w - 0.5;
    let y = st.y * h - 0.5;
    let fx = x - floor(x);
    let fy = y - floor(y);
    let i = floor_index(x);
    let j = floor_index(y);
    let top = texel(t, i, j) * (1.0 - fx) + texel(t, i + 1, j) * fx;
    let bottom = texel(t, i, j + 1) * (1.0 - fx) + texel(t, i + 1, j + 1) * fx;
    return top * (1.0 - fy) + bottom * fy;
}
// #endif

// Scene::uv_at for the triangle at scene-wide slot `prim` (placements.wgsl).
fn triangle_uv(prim: u32, b1: f32, b2: f32) -> vec2<f32> {
    var uv = vec2<f32>(0.0);
// #if FEATURE_TEXTURES
    let slot = placed_slot(prim);
    let t = triangle_uvs[slot.x];
    // A mirroring placement's world corners 1 and 2 are its local corners 2 and 1.
    let uv1 = select(t.uv1, t.uv2, slot.y != 0u);
    let uv2 = select(t.uv2, t.uv1, slot.y != 0u);
    uv = t.uv0 * (1.0 - b1 - b2) + uv1 * b1 + uv2 * b2;
// #endif
    return uv;
}

// Scene::texture_rgb: texture k (NO_INDEX: white) at uv.
fn texture_rgb(k: u32, uv: vec2<f32>) -> vec3<f32> {
    var c = vec3<f32>(1.0);
// #if FEATURE_TEXTURES
    if (k != NO_INDEX) {
        c = texture_sample(textures[k], uv).xyz;
    }
// #endif
    return c;
}

// Scene::base_color_at.
fn base_color_at(m: Material, uv: vec2<f32>) -> vec3<f32> {
    return m.base_color.xyz * texture_rgb(m.base_color_texture, uv);
}

// Scene::emission_at.
fn emission_at(m: Material, uv: vec2<f32>) -> vec3<f32> {
    return m.emission * texture_rgb(m.emissive_texture, uv);
}
