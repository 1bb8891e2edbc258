// taa_sobel: how aliased each pixel of the current jittered frame is
// (the TAA thesis §4.3.3, docs/bibliography.md), mirroring
// src/reference/taa_sobel.rs.
//#include shared/colour.wgsl

@group(0) @binding(0) var current: texture_2d<f32>;
@group(0) @binding(1) var amount_out: texture_storage_2d<r32float, write>;

const BT709 = vec3<f32>(0.2126, 0.7152, 0.0722);

fn lum_at(x: i32, y: i32, dims: vec2<i32>) -> f32 {
    let p = vec2<i32>(clamp(x, 0, dims.x - 1), clamp(y, 0, dims.y - 1));
    return luminance_with(textureLoad(current, p, 0).rgb, BT709);
}

@compute @workgroup_size(64, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let dims = vec2<i32>(textureDimensions(current));
    let x = i32(id.x);
    let y = i32(id.y);
    if (x >= dims.x || y >= dims.y) {
        return;
    }
    let a = lum_at(x - 1, y - 1, dims);
    let b = lum_at(x, y - 1, dims);
    let c = lum_at(x + 1, y - 1, dims);
    let d = lum_at(x - 1, y, dims);
    let e = lum_at(x, y, dims);
    let f = lum_at(x + 1, y, dims);
    let g = lum_at(x - 1, y + 1, dims);
    let h = lum_at(x, y + 1, dims);
    let k = lum_at(x + 1, y + 1, dims);
    let gx = (c + 2.0 * f + k) - (a + 2.0 * d + g);
    let gy = (a + 2.0 * b + c) - (g + 2.0 * h + k);
    let ymax = max(max(max(a, b), max(c, d)), max(max(e, f), max(max(g, h), k)));
    var s = 0.0;
    if (ymax >= SMALLEST_NORMAL) {
        let m = clamp(sqrt(gx * gx + gy * gy) / (4.0 * ymax), 0.0, 1.0);
        s = sqrt(m * m * (3.0 - 2.0 * m));
    }
    textureStore(amount_out, vec2<i32>(x, y), vec4<f32>(s, 0.0, 0.0, 1.0));
}
