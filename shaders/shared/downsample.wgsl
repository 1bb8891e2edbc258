// The bloom's downsample blocks (reference/bloom_downsample.rs), shared by the
// `bloom_downsample` stage and the fused bright pass (fused.wgsl).

override FACTOR: u32 = 2u;

// The full-resolution pixels [x0, x1) × [y0, y1) that low-resolution pixel
// `low` averages, as (x0, y0, x1, y1): blocks cut by the right or bottom edge
// keep only the pixels they have.
fn downsample_block(low: vec2<u32>, dims: vec2<u32>) -> vec4<u32> {
    let x0 = low.x * FACTOR;
    let y0 = low.y * FACTOR;
    return vec4<u32>(x0, y0, min(x0 + FACTOR, dims.x), min(y0 + FACTOR, dims.y));
}

// How many pixels `block` holds, as the divisor of the average.
fn block_size(block: vec4<u32>) -> f32 {
    return f32((block.z - block.x) * (block.w - block.y));
}
