// fused: the kernels of `--execution fused`. Each calls the same per-pixel
// functions as the stages it stands for, in the same order, so it computes
// the same values; what it saves is the full-frame stores and loads between
// those stages (on llvmpipe, storing one 1080p rgba32float frame costs about
// as much as the floor pass, ~4.8 ms). What it gives up: the stages inside a
// kernel are timed together and their outputs cannot be read back.
//#include shared/colour.wgsl
//#include shared/stats.wgsl
//#include operator
//#include shared/tone.wgsl
//#include shared/bright.wgsl
//#include shared/upsample.wgsl
//#include shared/encode.wgsl
//#include shared/downsample.wgsl
//#include shared/extent.wgsl

// The bright pass reads the tone-mapped frame (`threshold`), not the HDR one.
override BRIGHT_FROM_TONED: bool = false;
// The tail adds the bloom (bloom_composite); without it, binding 3 is a
// placeholder nobody reads.
override BLOOM: bool = false;

@group(0) @binding(0) var<uniform> config: OperatorConfig;
// The statistics and resolved curve (luminance_stats, tonemap's resolve).
@group(0) @binding(1) var<uniform> resolved: Stats;
@group(0) @binding(2) var hdr: texture_2d<f32>;
@group(0) @binding(3) var bloom: texture_2d<f32>;
@group(0) @binding(4) var<storage, read_write> frame_out: array<u32>;
@group(0) @binding(5) var low_out: texture_storage_2d<HDR_FORMAT, write>;

// [tonemap →] bloom_bright → bloom_downsample: one invocation per
// low-resolution pixel, averaging the bright pass of its FACTOR² block
// (blocks cut by the right or bottom edge average the pixels they have).
@compute @workgroup_size(64, 1)
fn bright_low(@builtin(global_invocation_id) id: vec3<u32>) {
    let out_dims = extent.low;
    if (id.x >= out_dims.x || id.y >= out_dims.y) {
        return;
    }
    let b = downsample_block(id.xy, extent.frame);
    var acc = vec3<f32>(0.0);
    for (var y = b.y; y < b.w; y = y + 1u) {
        for (var x = b.x; x < b.z; x = x + 1u) {
            var c = textureLoad(hdr, vec2<u32>(x, y), 0).rgb;
            if (BRIGHT_FROM_TONED) {
                c = toned(c, resolved.tone);
            }
            acc = acc + bright_pixel(c, resolved.max_y);
        }
    }
    textureStore(low_out, vec2<i32>(id.xy), vec4<f32>(acc / block_size(b), 1.0));
}

// tonemap → [bloom_composite →] encode: one invocation per pixel, straight
// from the HDR frame to the packed 8-bit frame.
@compute @workgroup_size(64, 1)
fn tail(@builtin(global_invocation_id) id: vec3<u32>) {
    let dims = extent.frame;
    if (id.x >= dims.x || id.y >= dims.y) {
        return;
    }
    var c = toned(textureLoad(hdr, id.xy, 0).rgb, resolved.tone);
    if (BLOOM) {
        c = bloom_add(c, upsample_at(bloom, id.x, id.y, dims, extent.low));
    }
    store_frame(id.y * dims.x + id.x, c);
}
