//! RGB spaces by their primaries: the normalised primary matrix and the
//! conversion between two spaces of the same white, as colour-science
//! derives them (tonegate's working space is BT.709; BT.2100's is BT.2020).

/// A 3×3 matrix, row-major: `m[row][column]`.
pub type Mat3 = [[f64; 3]; 3];

/// D65's chromaticity (x, y).
pub const D65_XY: [f64; 2] = [0.3127, 0.329];
/// BT.709's (and sRGB's) primaries, red, green, blue (x, y).
pub const BT709_XY: [[f64; 2]; 3] = [[0.64, 0.33], [0.30, 0.60], [0.15, 0.06]];
/// BT.2020's (and BT.2100's) primaries.
pub const BT2020_XY: [[f64; 2]; 3] = [[0.708, 0.292], [0.170, 0.797], [0.131, 0.046]];

/// a·b.
pub fn mul(a: &Mat3, b: &Mat3) -> Mat3 {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

/// m·v.
pub fn apply(m: &Mat3, v: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2])
}

/// m⁻¹ by cofactors.
pub fn inverse(m: &Mat3) -> Mat3 {
    let c = |i: usize, j: usize| {
        let (r0, r1) = ((i + 1) % 3, (i + 2) % 3);
        let (c0, c1) = ((j + 1) % 3, (j + 2) % 3);
        m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0]
    };
    let det = m[0][0] * c(0, 0) + m[0][1] * c(0, 1) + m[0][2] * c(0, 2);
    std::array::from_fn(|i| std::array::from_fn(|j| c(j, i) / det))
}

/// RGB → XYZ of primaries `xy` and white `w` (the normalised primary matrix).
pub fn npm(xy: [[f64; 2]; 3], w: [f64; 2]) -> Mat3 {
    let xyz = |[x, y]: [f64; 2]| [x / y, 1.0, (1.0 - x - y) / y];
    let cols = xy.map(xyz);
    let p: Mat3 = std::array::from_fn(|i| std::array::from_fn(|j| cols[j][i]));
    let s = apply(&inverse(&p), xyz(w));
    std::array::from_fn(|i| std::array::from_fn(|j| p[i][j] * s[j]))
}

/// Linear BT.709 → linear BT.2020 (both D65): BT.2020's NPM⁻¹ · BT.709's.
pub fn bt709_to_bt2020() -> Mat3 {
    mul(&inverse(&npm(BT2020_XY, D65_XY)), &npm(BT709_XY, D65_XY))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bt709_to_bt2020_is_bt2087s_matrix_and_keeps_white() {
        // ITU-R BT.2087's matrix, to its four decimals.
        let want = [
            [0.6274, 0.3293, 0.0433],
            [0.0691, 0.9195, 0.0114],
            [0.0164, 0.0880, 0.8956],
        ];
        let m = bt709_to_bt2020();
        for i in 0..3 {
            for j in 0..3 {
                assert!((m[i][j] - want[i][j]).abs() < 1e-4, "{i},{j}: {}", m[i][j]);
            }
            let sum: f64 = m[i].iter().sum();
            assert!((sum - 1.0).abs() < 1e-12, "row {i} sums to {sum}");
        }
    }
}
