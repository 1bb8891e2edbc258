// Luminance and the tone curve, mirroring src/color.rs and reference/tonemap.rs.

// f32's smallest normal: a luminance or divisor below it counts as 0, as an
// adapter that flushes subnormals would make it in arithmetic but not in a
// comparison (src/color.rs, `SMALLEST_NORMAL`).
const SMALLEST_NORMAL: f32 = 1.17549435e-38;

fn luminance_with(c: vec3<f32>, w: vec3<f32>) -> f32 {
    return w.x * c.x + w.y * c.y + w.z * c.z;
}
