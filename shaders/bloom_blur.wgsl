// bloom_blur: one 1-D Gaussian pass (the host runs it horizontally, then
// vertically), clamping at the edges. Weights come from the host (f64 → f32).

override HORIZONTAL: bool = true;
override RADIUS: u32 = 6u;

@group(0) @binding(0) var<storage, read> weights: array<f32>;
@group(0) @binding(1) var src: texture_2d<f32>;
@group(0) @binding(2) var blur_out: texture_storage_2d<HDR_FORMAT, write>;

@compute @workgroup_size(64, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let dims = vec2<i32>(textureDimensions(src));
    let p = vec2<i32>(id.xy);
    if (p.x >= dims.x || p.y >= dims.y) {
        return;
    }
    let r = i32(RADIUS);
    var acc = vec3<f32>(0.0);
    for (var k = -r; k <= r; k = k + 1) {
        var s = p;
        if (HORIZONTAL) {
            s.x = clamp(p.x + k, 0, dims.x - 1);
        } else {
            s.y = clamp(p.y + k, 0, dims.y - 1);
        }
        acc = acc + weights[u32(k + r)] * textureLoad(src, s, 0).rgb;
    }
    textureStore(blur_out, p, vec4<f32>(acc, 1.0));
}
