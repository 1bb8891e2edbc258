// Which part of a pixel feeds the bloom (reference/bloom_bright.rs), shared
// by the `bloom_bright` stage and the fused kernels (fused.wgsl). Needs
// shared/colour.wgsl.

// 0 = `scaled` (C·Y/Lmax where Y > T, on HDR), 1 = `threshold` (C where Y > T).
override PASS: u32 = 0u;
override THRESHOLD: f32 = 1.0;
override LUM_R: f32 = 0.2126;
override LUM_G: f32 = 0.7152;
override LUM_B: f32 = 0.0722;

fn bright_pixel(c: vec3<f32>, max_y: f32) -> vec3<f32> {
    let y = luminance_with(c, vec3<f32>(LUM_R, LUM_G, LUM_B));
    var out = vec3<f32>(0.0);
    if (y > THRESHOLD) {
        if (PASS == 0u) {
            var inv_max = 0.0;
            if (max_y >= SMALLEST_NORMAL && max_y < 3.0e38) {
                inv_max = 1.0 / max_y;
            }
            out = c * (y * inv_max);
        } else {
            out = c;
        }
    }
    return out;
}
