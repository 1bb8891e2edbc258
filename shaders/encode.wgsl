// encode: clamp, OETF, round half up to 8 bits, packed RGBA8 (A = 255), or
// 16-bit PQ in two words a pixel, into a buffer the host reads back without
// row padding (reference/encode.rs);
// the `to_*` entry points write a caller's texture instead (gpu::ToneMapper):
// the same codes into an 8-bit one, 10-bit codes, or scRGB
// (shared/encode.wgsl's `target_texel`).

//#include shared/encode.wgsl
//#include shared/extent.wgsl

@group(0) @binding(0) var src: texture_2d<f32>;
@group(0) @binding(1) var<storage, read_write> frame_out: array<u32>;
@group(0) @binding(2) var target_rgba8: texture_storage_2d<rgba8unorm, write>;
// The corner of the caller's texture the image goes to (xy).
@group(0) @binding(3) var<uniform> target_origin: vec4<u32>;
@group(0) @binding(4) var target_rgba16f: texture_storage_2d<rgba16float, write>;
@group(0) @binding(5) var target_bgra8: texture_storage_2d<bgra8unorm, write>;

@compute @workgroup_size(64, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let dims = extent.frame;
    if (id.x >= dims.x || id.y >= dims.y) {
        return;
    }
    store_frame(id.y * dims.x + id.x, textureLoad(src, id.xy, 0).rgb);
}

// The caller's texture (gpu::ToneMapper): a storage one by a compute
// pass, a render attachment by a fullscreen triangle; the region written
// starts at `target_origin` in it.
fn write_to(id: vec3<u32>) -> bool {
    let dims = extent.frame;
    return id.x < dims.x && id.y < dims.y;
}

@compute @workgroup_size(64, 1)
fn to_texture(@builtin(global_invocation_id) id: vec3<u32>) {
    if (write_to(id)) {
        textureStore(target_rgba8, id.xy + target_origin.xy, target_texel(textureLoad(src, id.xy, 0).rgb));
    }
}

@compute @workgroup_size(64, 1)
fn to_texture_bgra8(@builtin(global_invocation_id) id: vec3<u32>) {
    if (write_to(id)) {
        textureStore(target_bgra8, id.xy + target_origin.xy, target_texel(textureLoad(src, id.xy, 0).rgb));
    }
}

@compute @workgroup_size(64, 1)
fn to_texture_rgba16f(@builtin(global_invocation_id) id: vec3<u32>) {
    if (write_to(id)) {
        textureStore(target_rgba16f, id.xy + target_origin.xy, target_texel(textureLoad(src, id.xy, 0).rgb));
    }
}

// One triangle over the viewport (the region); clipped to it.
@vertex
fn fullscreen(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let corner = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(corner * 2.0 - 1.0, 0.0, 1.0);
}

// Pixel centres are at .5: truncation gives the pixel.
@fragment
fn to_attachment(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let xy = vec2<u32>(position.xy) - target_origin.xy;
    return target_texel(textureLoad(src, xy, 0).rgb);
}
