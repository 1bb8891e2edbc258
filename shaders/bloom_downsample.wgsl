// bloom_downsample: box average to 1/FACTOR resolution; blocks cut by the
// right or bottom edge average only the pixels they have.

override FACTOR: u32 = 2u;

@group(0) @binding(0) var src: texture_2d<f32>;
@group(0) @binding(1) var low_out: texture_storage_2d<HDR_FORMAT, write>;

@compute @workgroup_size(64, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let out_dims = textureDimensions(low_out);
    if (id.x >= out_dims.x || id.y >= out_dims.y) {
        return;
    }
    let dims = textureDimensions(src);
    let x0 = id.x * FACTOR;
    let y0 = id.y * FACTOR;
    let x1 = min(x0 + FACTOR, dims.x);
    let y1 = min(y0 + FACTOR, dims.y);
    var acc = vec3<f32>(0.0);
    for (var y = y0; y < y1; y = y + 1u) {
        for (var x = x0; x < x1; x = x + 1u) {
            acc = acc + textureLoad(src, vec2<u32>(x, y), 0).rgb;
        }
    }
    let n = f32((x1 - x0) * (y1 - y0));
    textureStore(low_out, vec2<i32>(id.xy), vec4<f32>(acc / n, 1.0));
}
