// One pixel to packed RGBA8, or to 16-bit PQ (reference/encode.rs), shared
// by the `encode` stage and the fused tail (fused.wgsl); both declare the
// packed `frame_out` buffer `store_frame` writes.

//#include shared/pq.wgsl

// 0 = sRGB OETF, 1 = 1/γ power, 2 = PQ (16 bits).
override ENCODING: u32 = 0u;
override GAMMA: f32 = 2.2;
// PQ: the display the operator maps onto (cd/m²) and BT.709 → BT.2020,
// row by row (gpu/encode.rs computes them in f64).
override PQ_BLACK: f32 = 0.0;
override PQ_PEAK: f32 = 100.0;
override PQ_M00: f32 = 1.0;
override PQ_M01: f32 = 0.0;
override PQ_M02: f32 = 0.0;
override PQ_M10: f32 = 0.0;
override PQ_M11: f32 = 1.0;
override PQ_M12: f32 = 0.0;
override PQ_M20: f32 = 0.0;
override PQ_M21: f32 = 0.0;
override PQ_M22: f32 = 1.0;

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

// A display-relative BT.709 pixel to its 16-bit PQ codes
// (operators::DisplayLevels::bt2020_nits, then PQ): NaN and v <= 0 are
// the display's black, v >= 1 its peak.
fn pq_codes(c: vec3<f32>) -> vec3<u32> {
    let v = select(vec3<f32>(0.0), min(c, vec3<f32>(1.0)), c > vec3<f32>(0.0));
    let light = PQ_BLACK + v * (PQ_PEAK - PQ_BLACK);
    let nits = clamp(
        vec3<f32>(
            PQ_M00 * light.r + PQ_M01 * light.g + PQ_M02 * light.b,
            PQ_M10 * light.r + PQ_M11 * light.g + PQ_M12 * light.b,
            PQ_M20 * light.r + PQ_M21 * light.g + PQ_M22 * light.b,
        ),
        vec3<f32>(0.0),
        vec3<f32>(PQ_PEAK),
    );
    let s = pq_signal(nits);
    return vec3<u32>(clamp(floor(s * 65535.0 + 0.5), vec3<f32>(0.0), vec3<f32>(65535.0)));
}

// Pixel `i` of the packed frame: one u32 of RGBA8, or, for PQ, two: R | G
// << 16 and B | 0xffff << 16 (reference/encode.rs, gpu/readback.rs).
fn store_frame(i: u32, c: vec3<f32>) {
    if (ENCODING == 2u) {
        let q = pq_codes(c);
        frame_out[2u * i] = q.r | (q.g << 16u);
        frame_out[2u * i + 1u] = q.b | (65535u << 16u);
    } else {
        frame_out[i] = pack_rgba8(c);
    }
}
