// One pixel to packed RGBA8, or to 16-bit PQ (reference/encode.rs), shared
// by the `encode` stage and the fused tail (fused.wgsl); both declare the
// packed `frame_out` buffer `store_frame` writes.

//#include shared/pq.wgsl

// 0 = sRGB OETF, 1 = 1/γ power, 2 = PQ (16 bits).
override ENCODING: u32 = 0u;
override GAMMA: f32 = 2.2;
// PQ: the display the operator maps onto (cd/m²) and BT.709 → BT.2020,
// row by row (gpu/kernels/encode.rs computes them in f64).
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

// The SDR transfer's signal in [0, 1] of one display-relative channel.
fn transfer(v: f32) -> f32 {
    // NaN fails every comparison, so it becomes 0 here, as on the CPU.
    var c = 0.0;
    if (v > 0.0) {
        c = min(v, 1.0);
    }
    if (ENCODING == 0u) {
        return srgb_oetf(c);
    }
    return pow(c, 1.0 / GAMMA);
}

// A signal in [0, 1] rounded half up to the codes 0..top.
fn quantise(e: f32, top: f32) -> u32 {
    return u32(clamp(floor(top * e + 0.5), 0.0, top));
}

fn encode_channel(v: f32) -> u32 {
    return quantise(transfer(v), 255.0);
}

// Clamp, OETF and round each channel; A = 255; R in the low byte.
fn pack_rgba8(c: vec3<f32>) -> u32 {
    return encode_channel(c.r) | (encode_channel(c.g) << 8u) | (encode_channel(c.b) << 16u) | (255u << 24u);
}

// A display-relative BT.709 pixel to its 16-bit PQ codes
// (operators::DisplayLevels::bt2020_nits, then PQ): NaN and v <= 0 are
// the display's black, v >= 1 its peak.
fn pq_codes(c: vec3<f32>) -> vec3<u32> {
    let s = pq_signals(c);
    return vec3<u32>(clamp(floor(s * 65535.0 + 0.5), vec3<f32>(0.0), vec3<f32>(65535.0)));
}

// The display's light of a display-relative BT.709 pixel, in cd/m², still
// BT.709: NaN and v <= 0 are its black, v >= 1 its peak.
fn display_light(c: vec3<f32>) -> vec3<f32> {
    let v = select(vec3<f32>(0.0), min(c, vec3<f32>(1.0)), c > vec3<f32>(0.0));
    return PQ_BLACK + v * (PQ_PEAK - PQ_BLACK);
}

// The PQ signals in [0, 1] of a display-relative BT.709 pixel.
fn pq_signals(c: vec3<f32>) -> vec3<f32> {
    let light = display_light(c);
    let nits = clamp(
        vec3<f32>(
            PQ_M00 * light.r + PQ_M01 * light.g + PQ_M02 * light.b,
            PQ_M10 * light.r + PQ_M11 * light.g + PQ_M12 * light.b,
            PQ_M20 * light.r + PQ_M21 * light.g + PQ_M22 * light.b,
        ),
        vec3<f32>(0.0),
        vec3<f32>(PQ_PEAK),
    );
    return pq_signal(nits);
}

// Pixel `i` of the packed frame: one u32 of RGBA8, or, for PQ, two: R | G
// << 16 and B | 0xffff << 16 (reference/encode.rs, gpu/run/readback.rs).
fn store_frame(i: u32, c: vec3<f32>) {
    if (ENCODING == 2u) {
        let q = pq_codes(c);
        frame_out[2u * i] = q.r | (q.g << 16u);
        frame_out[2u * i + 1u] = q.b | (65535u << 16u);
    } else {
        frame_out[i] = pack_rgba8(c);
    }
}

// What a caller's texture holds of one display-relative pixel
// (gpu::ToneMapper, docs/embedding.md#targets), by `TARGET`:
// 0: the 8-bit codes k as k/255, which an Unorm texture stores back as k;
// 1: the same codes through an ...Srgb format, which applies the sRGB OETF
//    as it stores: the light of code k, srgb_eotf(k/255), stores back as k
//    (it lies half a code from either neighbour's boundary);
// 2: 10-bit codes k as k/1023 (Rgb10a2Unorm), of the SDR transfer or of PQ;
// 3: scRGB (Rgba16Float): linear BT.709 with 1.0 = 80 cd/m²; an SDR
//    encoding's display-relative value clamped to [0, 1], PQ's display
//    light over 80.
override TARGET: u32 = 0u;

fn srgb_eotf(e: f32) -> f32 {
    if (e <= 0.04045) {
        return e / 12.92;
    }
    return pow((e + 0.055) / 1.055, 2.4);
}

fn target_texel(c: vec3<f32>) -> vec4<f32> {
    if (TARGET == 3u) {
        if (ENCODING == 2u) {
            return vec4<f32>(display_light(c) / 80.0, 1.0);
        }
        return vec4<f32>(select(vec3<f32>(0.0), min(c, vec3<f32>(1.0)), c > vec3<f32>(0.0)), 1.0);
    }
    if (TARGET == 2u) {
        var s = vec3<f32>(0.0);
        if (ENCODING == 2u) {
            s = pq_signals(c);
        } else {
            s = vec3<f32>(transfer(c.r), transfer(c.g), transfer(c.b));
        }
        let k = vec3<u32>(quantise(s.r, 1023.0), quantise(s.g, 1023.0), quantise(s.b, 1023.0));
        return vec4<f32>(vec3<f32>(k) / 1023.0, 1.0);
    }
    let k = vec3<f32>(vec3<u32>(encode_channel(c.r), encode_channel(c.g), encode_channel(c.b))) / 255.0;
    if (TARGET == 1u) {
        return vec4<f32>(srgb_eotf(k.r), srgb_eotf(k.g), srgb_eotf(k.b), 1.0);
    }
    return vec4<f32>(k, 1.0);
}
