// One pixel to packed RGBA8 (reference/encode.rs), shared by the `encode`
// stage and the fused tail (fused.wgsl).

// 0 = sRGB OETF, 1 = 1/γ power.
override ENCODING: u32 = 0u;
override GAMMA: f32 = 2.2;

fn srgb_oetf(v: f32) -> f32 {
    if (v <= 0.0031308) {
        return 12.92 * v;
    }
    return 1.055 * pow(v, 1.0 / 2.4) - 0.055;
}

fn encode_channel(v: f32) -> u32 {
    // NaN fails every comparison, so it becomes 0 here, as on the CPU.
    var c = 0.0;
    if (v > 0.0) {
        c = min(v, 1.0);
    }
    var e = 0.0;
    if (ENCODING == 0u) {
        e = srgb_oetf(c);
    } else {
        e = pow(c, 1.0 / GAMMA);
    }
    return u32(clamp(floor(255.0 * e + 0.5), 0.0, 255.0));
}

// Clamp, OETF and round each channel; A = 255; R in the low byte.
fn pack_rgba8(c: vec3<f32>) -> u32 {
    return encode_channel(c.r) | (encode_channel(c.g) << 8u) | (encode_channel(c.b) << 16u) | (255u << 24u);
}
