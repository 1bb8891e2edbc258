// encode: clamp, OETF, round half up to 8 bits, packed RGBA8 (A = 255) into
// a buffer the host reads back without row padding (reference/encode.rs).

// 0 = sRGB OETF, 1 = 1/γ power.
override ENCODING: u32 = 0u;
override GAMMA: f32 = 2.2;

@group(0) @binding(0) var src: texture_2d<f32>;
@group(0) @binding(1) var<storage, read_write> frame_out: array<u32>;

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

@compute @workgroup_size(64, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let dims = textureDimensions(src);
    if (id.x >= dims.x || id.y >= dims.y) {
        return;
    }
    let c = textureLoad(src, id.xy, 0).rgb;
    let packed = encode_channel(c.r) | (encode_channel(c.g) << 8u) | (encode_channel(c.b) << 16u) | (255u << 24u);
    frame_out[id.y * dims.x + id.x] = packed;
}
