// bloom_downsample: box average to 1/FACTOR resolution; blocks cut by the
// right or bottom edge average only the pixels they have.
//#include shared/downsample.wgsl
//#include shared/extent.wgsl

@group(0) @binding(0) var src: texture_2d<f32>;
@group(0) @binding(1) var low_out: texture_storage_2d<HDR_FORMAT, write>;

@compute @workgroup_size(64, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let out_dims = extent.low;
    if (id.x >= out_dims.x || id.y >= out_dims.y) {
        return;
    }
    let b = downsample_block(id.xy, extent.frame);
    var acc = vec3<f32>(0.0);
    for (var y = b.y; y < b.w; y = y + 1u) {
        for (var x = b.x; x < b.z; x = x + 1u) {
            acc = acc + textureLoad(src, vec2<u32>(x, y), 0).rgb;
        }
    }
    textureStore(low_out, vec2<i32>(id.xy), vec4<f32>(acc / block_size(b), 1.0));
}
