// Luminance and the tone curve, mirroring src/color.rs and reference/tonemap.rs.

fn luminance_with(c: vec3<f32>, w: vec3<f32>) -> f32 {
    return w.x * c.x + w.y * c.y + w.z * c.z;
}

// Ld = L/(1+L)·(1 + L/white²), written with 1/white² so "no white" is 0.
fn reinhard_curve(l: f32, inv_white_sq: f32) -> f32 {
    return l / (1.0 + l) * (1.0 + l * inv_white_sq);
}
