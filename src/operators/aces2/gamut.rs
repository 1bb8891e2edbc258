//! ACES 2.0's gamut compression: M pulled in along a line towards a focus
//! point on the J axis until the colour is inside the limiting gamut's hull
//! (Rec.709 at the display's peak), with the hull approximated per hue by
//! its cusp and two gamma curves, from tables built once per display
//! (`tables.rs`). It follows OpenColorIO's ACES 2 fixed function, in f64
//! (docs/operators.md#aces2).

use super::cam::model_gamma;

/// Hue entries per table: one per degree.
pub const NOMINAL: usize = 360;
/// The entries stored: one below 0° and two above 360° so that a lookup
/// near either end needs no wrapping.
pub const TOTAL: usize = NOMINAL + 3;
pub(super) const FIRST: usize = 1;
pub(super) const UPPER_WRAP: usize = FIRST + NOMINAL;
pub(super) const LAST: usize = UPPER_WRAP - 1;

pub(super) const SMOOTH_CUSPS: f64 = 0.12;
pub(super) const SMOOTH_M: f64 = 0.27;
pub(super) const CUSP_MID_BLEND: f64 = 1.3;
pub(super) const FOCUS_GAIN_BLEND: f64 = 0.3;
pub(super) const FOCUS_DISTANCE: f64 = 1.35;
pub(super) const FOCUS_DISTANCE_SCALING: f64 = 1.75;
pub(super) const COMPRESSION_THRESHOLD: f64 = 0.75;

/// Everything the per-pixel gamut compression reads, built for one display.
#[derive(Clone, Debug)]
pub struct GamutTables {
    /// J of the display's peak: the top of every hull.
    pub limit_j: f64,
    /// The achromatic response of `limit_j`.
    pub limit_a: f64,
    /// The reach gamut's (AP1's) M at `limit_j`, per whole degree of hue.
    pub reach_m: [f64; TOTAL],
    /// The hue of each cusp entry, nearly uniform, with the limiting
    /// gamut's corners among them.
    pub hues: [f64; TOTAL],
    /// Per entry: the cusp's J, its M (widened by the smoothing), and
    /// 1/γ of the upper hull.
    pub cusps: [[f64; 3]; TOTAL],
    /// The band around the uniform position a hue's entry lies in.
    pub search: [i64; 2],
    /// J of the tone scale's middle grey.
    pub mid_j: f64,
    /// The focus distance.
    pub focus_dist: f64,
    /// 1/γ of the lower hull.
    pub lower_gamma_inv: f64,
}

/// The hue-dependent values of one pixel's compression.
#[derive(Clone, Copy, Debug)]
pub(super) struct AtHue {
    pub(super) cusp: [f64; 2],
    pub(super) gamma_top_inv: f64,
    pub(super) focus_j: f64,
    pub(super) threshold: f64,
}

pub(super) fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + t * (b - a)
}

pub(super) fn lerp3(a: [f64; 3], b: [f64; 3], t: f64) -> [f64; 3] {
    std::array::from_fn(|i| lerp(a[i], b[i], t))
}

impl GamutTables {
    /// The reach's M at `hue` (degrees in [0, 360]).
    #[inline]
    pub fn reach_m_at(&self, hue: f64) -> f64 {
        let base = hue as usize;
        let t = hue - base as f64;
        let lo = (base + FIRST).min(TOTAL - 2);
        lerp(self.reach_m[lo], self.reach_m[lo + 1], t)
    }

    /// The upper index of the hue table's interval holding `h`.
    fn interval(&self, h: f64) -> usize {
        let mut i = FIRST as i64 + h as i64;
        let mut lo = (i + self.search[0]).max(0);
        let mut hi = (i + self.search[1]).min(UPPER_WRAP as i64);
        while lo + 1 < hi {
            if h > self.hues[i as usize] {
                lo = i;
            } else {
                hi = i;
            }
            i = (lo + hi) / 2;
        }
        hi.max(1) as usize
    }

    fn at_hue(&self, h: f64) -> AtHue {
        let hi = self.interval(h);
        let t = (h - self.hues[hi - 1]) / (self.hues[hi] - self.hues[hi - 1]);
        let c = lerp3(self.cusps[hi - 1], self.cusps[hi], t);
        self.with_cusp([c[0], c[1]], c[2])
    }

    pub(super) fn with_cusp(&self, cusp: [f64; 2], gamma_top_inv: f64) -> AtHue {
        AtHue {
            cusp,
            gamma_top_inv,
            focus_j: focus_j(cusp[0], self.mid_j, self.limit_j),
            threshold: lerp(cusp[0], self.limit_j, FOCUS_GAIN_BLEND),
        }
    }

    /// J and M after compression into the limiting gamut, at hue `h`; the
    /// reach's M there is `reach_m`.
    #[inline]
    pub fn compress(&self, j: f64, m: f64, h: f64, reach_m: f64) -> [f64; 2] {
        if j <= 0.0 {
            return [0.0, 0.0];
        }
        if m <= 0.0 || j > self.limit_j {
            return [j, 0.0];
        }
        let at = self.at_hue(h);
        let slope_gain = focus_gain(j, at.threshold, self.limit_j, self.focus_dist);
        let j_source = solve_j_intersect(j, m, at.focus_j, self.limit_j, slope_gain);
        let slope = vector_slope(j_source, at.focus_j, self.limit_j, slope_gain);
        let j_cusp =
            solve_j_intersect(at.cusp[0], at.cusp[1], at.focus_j, self.limit_j, slope_gain);
        let boundary = boundary_m(
            at.cusp,
            self.limit_j,
            at.gamma_top_inv,
            self.lower_gamma_inv,
            j_source,
            slope,
            j_cusp,
        );
        if boundary <= 0.0 {
            return [j, 0.0];
        }
        let reach = line_meets_hull(
            j_source,
            slope,
            1.0 / model_gamma(),
            self.limit_j,
            reach_m,
            self.limit_j,
        );
        let m = remap_m(m, boundary, reach);
        [j_source + m * slope, m]
    }
}

pub(super) fn focus_j(cusp_j: f64, mid_j: f64, limit_j: f64) -> f64 {
    lerp(cusp_j, mid_j, (CUSP_MID_BLEND - cusp_j / limit_j).min(1.0))
}

pub(super) fn focus_gain(j: f64, threshold: f64, limit_j: f64, focus_dist: f64) -> f64 {
    let gain = limit_j * focus_dist;
    if j > threshold {
        let adjust = ((limit_j - threshold) / (limit_j - j).max(0.0001)).log10();
        gain * (adjust * adjust + 1.0)
    } else {
        gain
    }
}

/// Where the compression line through (J, M) meets the J axis.
pub(super) fn solve_j_intersect(j: f64, m: f64, focus_j: f64, max_j: f64, slope_gain: f64) -> f64 {
    let m_scaled = m / slope_gain;
    let a = m_scaled / focus_j;
    if j < focus_j {
        let b = 1.0 - m_scaled;
        let c = -j;
        let root = (b * b - 4.0 * a * c).sqrt();
        -2.0 * c / (b + root)
    } else {
        let b = -(1.0 + m_scaled + max_j * a);
        let c = max_j * m_scaled + j;
        let root = (b * b - 4.0 * a * c).sqrt();
        -2.0 * c / (b - root)
    }
}

pub(super) fn vector_slope(j_intersect: f64, focus_j: f64, limit_j: f64, slope_gain: f64) -> f64 {
    let scale = if j_intersect < focus_j {
        j_intersect
    } else {
        limit_j - j_intersect
    };
    scale * (j_intersect - focus_j) / (focus_j * slope_gain)
}

/// M where the line J = slope·M + J_axis meets the hull J = J_max·(M /
/// M_max)^(1/γ), approximated by shifting the intersection with the
/// inverse power and meeting the straight line to (M_max, J_max).
pub(super) fn line_meets_hull(
    j_axis: f64,
    slope: f64,
    gamma_inv: f64,
    j_max: f64,
    m_max: f64,
    j_ref: f64,
) -> f64 {
    let shifted = j_ref * (j_axis / j_ref).powf(gamma_inv);
    shifted * m_max / (j_max - slope * m_max)
}

pub(super) fn boundary_m(
    cusp: [f64; 2],
    j_max: f64,
    gamma_top_inv: f64,
    gamma_bottom_inv: f64,
    j_source: f64,
    slope: f64,
    j_cusp: f64,
) -> f64 {
    let lower = line_meets_hull(j_source, slope, gamma_bottom_inv, cusp[0], cusp[1], j_cusp);
    let upper = line_meets_hull(
        j_max - j_source,
        -slope,
        gamma_top_inv,
        j_max - cusp[0],
        cusp[1],
        j_max - j_cusp,
    );
    smooth_min(lower, upper, cusp[1])
}

/// A cubic smooth minimum over a width of 0.12 × `scale`.
pub(super) fn smooth_min(a: f64, b: f64, scale: f64) -> f64 {
    let s = SMOOTH_CUSPS * scale;
    let h = (s - (a - b).abs()).max(0.0) / s;
    a.min(b) - h * h * h * s / 6.0
}

/// M beyond a threshold inside the gamut boundary compressed so that the
/// reach's boundary lands on the gamut's (a Reinhard curve on the excess).
pub(super) fn remap_m(m: f64, gamut: f64, reach: f64) -> f64 {
    let proportion = (gamut / reach).max(COMPRESSION_THRESHOLD);
    let threshold = proportion * gamut;
    if m <= threshold || proportion >= 1.0 {
        return m;
    }
    let m_offset = m - threshold;
    let gamut_offset = gamut - threshold;
    let reach_offset = reach - threshold;
    let scale = reach_offset / (reach_offset / gamut_offset - 1.0);
    let nd = m_offset / scale;
    threshold + scale * nd / (1.0 + nd)
}
