// encode: clamp, OETF, round half up to 8 bits, packed RGBA8 (A = 255), or
// 16-bit PQ in two words a pixel, into a buffer the host reads back without
// row padding (reference/encode.rs);
// `to_texture` stores the same bytes in a caller's Rgba8Unorm texture
// (gpu::ToneMapper).

//#include shared/encode.wgsl
//#include shared/extent.wgsl

@group(0) @binding(0) var src: texture_2d<f32>;
@group(0) @binding(1) var<storage, read_write> frame_out: array<u32>;
@group(0) @binding(2) var frame_texture: texture_storage_2d<rgba8unorm, write>;

@compute @workgroup_size(64, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let dims = extent.frame;
    if (id.x >= dims.x || id.y >= dims.y) {
        return;
    }
    store_frame(id.y * dims.x + id.x, textureLoad(src, id.xy, 0).rgb);
}

// k/255 in f32 stores back as k: the same bytes as `main`'s.
@compute @workgroup_size(64, 1)
fn to_texture(@builtin(global_invocation_id) id: vec3<u32>) {
    let dims = extent.frame;
    if (id.x >= dims.x || id.y >= dims.y) {
        return;
    }
    textureStore(frame_texture, vec2<i32>(id.xy), unpack4x8unorm(pack_rgba8(textureLoad(src, id.xy, 0).rgb)));
}
