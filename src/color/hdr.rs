//! BT.2100's transfer functions (docs/display.md#hdr-output): PQ (SMPTE
//! ST 2084) and HLG, in f64, as colour-science writes them
//! (`tests/display` locks them to it).

/// The highest luminance PQ encodes, cd/m².
pub const PQ_PEAK: f64 = 10_000.0;

/// BT.2100's luminance weights (BT.2020 primaries), which HLG's OOTF uses.
pub const BT2100_LUMINANCE: [f64; 3] = [0.2627, 0.6780, 0.0593];

const M1: f64 = 2610.0 / 16384.0;
const M2: f64 = 2523.0 / 4096.0 * 128.0;
const C1: f64 = 3424.0 / 4096.0;
const C2: f64 = 2413.0 / 4096.0 * 32.0;
const C3: f64 = 2392.0 / 4096.0 * 32.0;

/// ST 2084's inverse EOTF: cd/m² (negative as 0) to PQ signal, 1 at
/// 10000 cd/m² (and beyond 1 past it, as the formula and colour-science
/// have it). 0 cd/m² gives c1^m2 = 7.3e-7, as the formula does.
pub fn pq_encode(nits: f64) -> f64 {
    let y = libm::pow(nits.max(0.0) / PQ_PEAK, M1);
    libm::pow((C1 + C2 * y) / (1.0 + C3 * y), M2)
}

/// ST 2084's EOTF: PQ signal (clamped to [0, 1]) to cd/m²; every signal up
/// to c1^m2 is 0 cd/m².
pub fn pq_decode(signal: f64) -> f64 {
    let p = libm::pow(signal.clamp(0.0, 1.0), 1.0 / M2);
    PQ_PEAK * libm::pow((p - C1).max(0.0) / (C2 - C3 * p), 1.0 / M1)
}

/// The 16-bit full-range code of a signal in [0, 1] (NaN as 0): ⌊65535·s + 0.5⌋.
pub fn code16(signal: f64) -> u16 {
    let s = if signal.is_nan() {
        0.0
    } else {
        signal.clamp(0.0, 1.0)
    };
    (s * 65535.0 + 0.5).floor() as u16
}

const HLG_A: f64 = 0.178_832_77;
const HLG_B: f64 = 1.0 - 4.0 * HLG_A;

fn hlg_c() -> f64 {
    0.5 - HLG_A * libm::log(4.0 * HLG_A)
}

/// HLG's OETF: normalised scene light E in [0, 1] to signal E′.
pub fn hlg_oetf(e: f64) -> f64 {
    let e = e.max(0.0);
    if e <= 1.0 / 12.0 {
        libm::sqrt(3.0 * e)
    } else {
        HLG_A * libm::log(12.0 * e - HLG_B) + hlg_c()
    }
}

/// HLG's system gamma for a display of nominal peak `peak` cd/m²:
/// 1.2 + 0.42·log10(peak/1000) (BT.2100, its extension beyond 1000 cd/m²).
pub fn hlg_gamma(peak: f64) -> f64 {
    1.2 + 0.42 * libm::log10(peak / 1000.0)
}

/// HLG's inverse EOTF for a display of peak `peak` cd/m² and black 0:
/// display light (BT.2020 RGB, cd/m²) through the inverse OOTF, E =
/// (Y_D/α)^((1 − γ)/γ)·F_D/α with α = `peak`, to scene light, then the OETF.
pub fn hlg_inverse_eotf(rgb_nits: [f64; 3], peak: f64) -> [f64; 3] {
    let gamma = hlg_gamma(peak);
    let f = rgb_nits.map(|v| v.max(0.0));
    let y = super::luminance_with(f, BT2100_LUMINANCE);
    if y <= 0.0 {
        return [0.0; 3];
    }
    let scale = libm::pow(y / peak, (1.0 - gamma) / gamma) / peak;
    f.map(|v| hlg_oetf(v * scale))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pq_and_hlg_meet_their_anchor_points() {
        // BT.2100's table: 100 cd/m² is PQ 0.5081, 1000 cd/m² 0.7518.
        assert!((pq_encode(100.0) - 0.508_078).abs() < 1e-6);
        assert!((pq_encode(1000.0) - 0.751_827).abs() < 1e-6);
        assert!((pq_encode(PQ_PEAK) - 1.0).abs() < 1e-15);
        for nits in [1e-4, 0.1, 1.0, 203.0, 4000.0] {
            let back = pq_decode(pq_encode(nits));
            assert!((back - nits).abs() <= 1e-12 * nits, "{nits}: {back}");
        }
        assert_eq!(pq_decode(0.0), 0.0);
        // HLG: E = 1/12 is the knee at 0.5; the peak white is 1.
        assert!((hlg_oetf(1.0 / 12.0) - 0.5).abs() < 1e-15);
        assert!((hlg_oetf(1.0) - 1.0).abs() < 1e-6);
        let white = hlg_inverse_eotf([1000.0; 3], 1000.0);
        assert!(white.iter().all(|v| (v - 1.0).abs() < 1e-6), "{white:?}");
        // BT.2408: HDR reference white (203 cd/m²) is HLG 75 % on a
        // 1000 cd/m² display.
        let grey = hlg_inverse_eotf([203.0; 3], 1000.0);
        assert!((grey[0] - 0.75).abs() < 0.005, "{grey:?}");
        assert_eq!(hlg_inverse_eotf([0.0; 3], 1000.0), [0.0; 3]);
    }
}
