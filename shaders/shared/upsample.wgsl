// The bloom's bilinear upsample to the full frame, texel centres aligned,
// clamped at the edges (reference/bloom_composite.rs); shared by the
// `bloom_composite` stage and the fused tail (fused.wgsl). `full` is the
// frame's size and `low_size` the bloom's (shared/extent.wgsl). Then the
// bloom's addition to the tone-mapped pixel.

override STRENGTH: f32 = 0.5;

// C = C_tone + k·bloom.
fn bloom_add(toned: vec3<f32>, bloom: vec3<f32>) -> vec3<f32> {
    return toned + STRENGTH * bloom;
}

fn upsample_at(
    bloom: texture_2d<f32>,
    x: u32,
    y: u32,
    full: vec2<u32>,
    low_size: vec2<u32>,
) -> vec3<f32> {
    let low = vec2<i32>(low_size);
    let fx = (f32(x) + 0.5) * f32(low.x) / f32(full.x) - 0.5;
    let fy = (f32(y) + 0.5) * f32(low.y) / f32(full.y) - 0.5;
    let x0f = floor(fx);
    let y0f = floor(fy);
    let tx = fx - x0f;
    let ty = fy - y0f;
    let xa = clamp(i32(x0f), 0, low.x - 1);
    let xb = clamp(i32(x0f) + 1, 0, low.x - 1);
    let ya = clamp(i32(y0f), 0, low.y - 1);
    let yb = clamp(i32(y0f) + 1, 0, low.y - 1);
    let p00 = textureLoad(bloom, vec2<i32>(xa, ya), 0).rgb;
    let p10 = textureLoad(bloom, vec2<i32>(xb, ya), 0).rgb;
    let p01 = textureLoad(bloom, vec2<i32>(xa, yb), 0).rgb;
    let p11 = textureLoad(bloom, vec2<i32>(xb, yb), 0).rgb;
    let top = p00 * (1.0 - tx) + p10 * tx;
    let bottom = p01 * (1.0 - tx) + p11 * tx;
    return top * (1.0 - ty) + bottom * ty;
}
