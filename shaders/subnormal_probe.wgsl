// subnormal_probe: not a plan stage. Whether the adapter flushes f32
// subnormals to zero (Vulkan allows it; SwiftShader and many GPUs do), as
// `gpu::probe` reads it when a device is opened. The inputs come from the
// buffer, so no compiler can fold the arithmetic away.
//
// It also shows how the compiler treats division, where a rewrite makes an
// intermediate leave f32's normal range (docs/stress.md#range-safe-arithmetic):
// (a/b)/b with a = 2^-100, b = 2^-70 is 2^40 as written, +Inf or NaN where
// it became a/(b·b) and b·b = 2^-140 flushed; p/q with p = 2^100,
// q = 2^127 is 2^-27 as written, 0 where it became p·(1/q) and 1/q = 2^-127
// flushed.
//
// In:  v[0] = 2^-126 (f32's smallest normal), v[1] = 2^-133 (a subnormal),
//      v[2] = 1.0, v[3] = 0.5, v[4] = 2^-100, v[5] = 2^-70, v[6] = 2^100,
//      v[7] = 2^127, as bits.
// Out: v[0] = 2^-126 · 0.5, a subnormal result (0 where results flush);
//      v[1] = 2^-133 · 1.0, a subnormal operand (0 where operands flush);
//      v[2] = 1 where 2^-133 > 0 compares true, else 0;
//      v[4] = (2^-100 / 2^-70) / 2^-70; v[5] = 2^100 / 2^127.
@group(0) @binding(0) var<storage, read_write> v: array<u32, 8>;

@compute @workgroup_size(1)
fn main() {
    let normal = bitcast<f32>(v[0]);
    let sub = bitcast<f32>(v[1]);
    let one = bitcast<f32>(v[2]);
    let half = bitcast<f32>(v[3]);
    let result = normal * half;
    let operand = sub * one;
    v[0] = bitcast<u32>(result);
    v[1] = bitcast<u32>(operand);
    v[2] = select(0u, 1u, sub > 0.0);
    let a = bitcast<f32>(v[4]);
    let b = bitcast<f32>(v[5]);
    let p = bitcast<f32>(v[6]);
    let q = bitcast<f32>(v[7]);
    v[4] = bitcast<u32>((a / b) / b);
    v[5] = bitcast<u32>(p / q);
}
