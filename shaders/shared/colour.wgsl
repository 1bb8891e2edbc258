// Luminance and the tone curve, mirroring src/color.rs and reference/tonemap.rs.

// f32's smallest normal: a luminance or divisor below it counts as 0, as an
// adapter that flushes subnormals would make it in arithmetic but not in a
// comparison (src/color.rs, `SMALLEST_NORMAL`).
const SMALLEST_NORMAL: f32 = 1.17549435e-38;

fn luminance_with(c: vec3<f32>, w: vec3<f32>) -> f32 {
    return w.x * c.x + w.y * c.y + w.z * c.z;
}

// Ld = L/(1+L)·(1 + L/white²), with L/white² taken as (L/white)/white:
// neither division leaves f32's range for any white f32 can hold, where
// 1/white² does (white = 1.5e-33 in a frame of subnormals: 1/white² would be
// +Inf and the brightest pixel would not burn; found by the stress suite).
// white <= 0, +Inf or NaN means "never burn", as the reference's +Inf.
fn reinhard_curve(l: f32, white: f32) -> f32 {
    var burn = 0.0;
    if (white > 0.0 && white <= 3.4028235e38) {
        burn = (l / white) / white;
    }
    return l / (1.0 + l) * (1.0 + burn);
}
