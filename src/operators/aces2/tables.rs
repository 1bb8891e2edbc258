//! The tables ACES 2.0's gamut compression reads, built once per display
//! by OpenColorIO's own searches, in f64 (docs/operators.md#aces2): the
//! reach's M at J_max per degree, a hue table with every gamut corner an
//! entry, the limiting gamut's cusp at each, and the upper hull's γ.

use super::cam::{JmhSpace, ToneScale, REFERENCE_LUMINANCE};
use super::gamut::*;

const CORNERS: usize = 6;

/// The unit cube's six corners in hue order: R, Y, G, C, B, M.
fn unit_corner(i: usize) -> [f64; 3] {
    let on = |k: usize| if (i + k) % CORNERS < 3 { 1.0 } else { 0.0 };
    [on(1), on(5), on(3)]
}

/// The six corners' RGB and JMh as a cycle from the lowest hue, with the
/// last before it and the first after it (hues shifted by ∓360°).
fn corner_cycle(
    rgb: [[f64; 3]; CORNERS],
    jmh: [[f64; 3]; CORNERS],
) -> ([[f64; 3]; 8], [[f64; 3]; 8]) {
    let lowest = (0..CORNERS)
        .min_by(|&a, &b| jmh[a][2].total_cmp(&jmh[b][2]))
        .unwrap_or(0);
    let mut out_rgb = [[0.0; 3]; 8];
    let mut out_jmh = [[0.0; 3]; 8];
    for i in 0..CORNERS {
        out_rgb[i + 1] = rgb[(i + lowest) % CORNERS];
        out_jmh[i + 1] = jmh[(i + lowest) % CORNERS];
    }
    out_rgb[0] = out_rgb[CORNERS];
    out_rgb[CORNERS + 1] = out_rgb[1];
    out_jmh[0] = out_jmh[CORNERS];
    out_jmh[CORNERS + 1] = out_jmh[1];
    out_jmh[0][2] -= 360.0;
    out_jmh[CORNERS + 1][2] += 360.0;
    (out_rgb, out_jmh)
}

/// The reach gamut's corners where their J reaches `limit_j` (a bisection
/// on the achromatic response, to 1e-3 of the scale).
fn reach_corners(reach: &JmhSpace, limit_j: f64, maximum: f64) -> [[f64; 3]; 8] {
    let limit_a = reach.j_to_a(limit_j);
    let mut jmh = [[0.0; 3]; CORNERS];
    for (i, out) in jmh.iter_mut().enumerate() {
        let v = unit_corner(i);
        let (mut lower, mut upper) = (0.0, maximum);
        while upper - lower > 1e-3 {
            let test = (lower + upper) / 2.0;
            let a = reach.rgb_to_aab(v.map(|c| c * test))[0];
            if a < limit_a {
                lower = test;
            } else {
                upper = test;
            }
            if a == limit_a {
                break;
            }
        }
        *out = reach.rgb_to_jmh(v.map(|c| c * upper));
    }
    corner_cycle([[0.0; 3]; CORNERS], jmh).1
}

/// The limiting gamut's corners at the display's peak.
fn display_corners(display: &JmhSpace, peak: f64) -> ([[f64; 3]; 8], [[f64; 3]; 8]) {
    let rgb: [[f64; 3]; CORNERS] =
        std::array::from_fn(|i| unit_corner(i).map(|c| c * peak / REFERENCE_LUMINANCE));
    let jmh = rgb.map(|c| display.rgb_to_jmh(c));
    corner_cycle(rgb, jmh)
}

/// The two cycles' hues merged, in order, each once.
fn merged_hues(reach: &[[f64; 3]; 8], display: &[[f64; 3]; 8]) -> Vec<f64> {
    let mut out = Vec::with_capacity(2 * CORNERS);
    let (mut r, mut d) = (1, 1);
    while r < CORNERS + 1 || d < CORNERS + 1 {
        // Past its end a cycle's next hue is its first + 360°, above the
        // other's remaining ones.
        let rh = reach[r][2];
        let dh = display[d][2];
        if rh == dh {
            out.push(rh);
            r += 1;
            d += 1;
        } else if rh < dh {
            out.push(rh);
            r += 1;
        } else {
            out.push(dh);
            d += 1;
        }
    }
    out
}

/// The hue table: 360 entries as evenly spread as they can be while every
/// corner's hue is an entry.
fn hue_table(sorted: &[f64]) -> [f64; TOTAL] {
    let mut table = [0.0; TOTAL];
    let mut counts = vec![0usize; sorted.len()];
    let mut last = usize::MAX;
    let mut min_index = if sorted[0] == 0.0 { 0 } else { 1 };
    for (k, &h) in sorted.iter().enumerate() {
        let mut nominal = (h.round().max(0.0) as usize)
            .max(min_index)
            .min(NOMINAL - 1);
        if last == nominal {
            // Two hues on one entry: move the previous one down if there is
            // room, else this one up.
            if k > 1 && counts[k - 2] + 1 != counts[k - 1] {
                counts[k - 1] -= 1;
            } else {
                nominal += 1;
            }
        }
        counts[k] = nominal.min(NOMINAL - 1);
        last = nominal;
        min_index = nominal;
    }
    let mut fill = |samples: usize, lower: f64, upper: f64, base: usize| {
        let delta = (upper - lower) / samples as f64;
        for i in 0..samples {
            table[base + i] = lower + i as f64 * delta;
        }
    };
    let mut total = counts[0];
    fill(counts[0], 0.0, sorted[0], FIRST);
    for k in 1..sorted.len() {
        let samples = counts[k] - counts[k - 1];
        fill(samples, sorted[k - 1], sorted[k], total + FIRST);
        total += samples;
    }
    fill(
        NOMINAL - total,
        sorted[sorted.len() - 1],
        360.0,
        total + FIRST,
    );
    table[0] = table[LAST] - 360.0;
    table[UPPER_WRAP] = table[FIRST] + 360.0;
    table[UPPER_WRAP + 1] = table[FIRST + 1] + 360.0;
    table
}

/// The limiting gamut's cusp (J, M) at `hue`: a bisection along the cube
/// edge between the two corners around it, to 1e-7 of the edge. `previous`
/// carries the edge and position of the last search, where the next one
/// on the same edge starts.
fn display_cusp(
    hue: f64,
    rgb: &[[f64; 3]; 8],
    jmh: &[[f64; 3]; 8],
    display: &JmhSpace,
    previous: &mut (usize, f64),
) -> [f64; 2] {
    let upper = (1..8).find(|&i| jmh[i][2] > hue).unwrap_or(1);
    let lower = upper - 1;
    if jmh[lower][2] == hue {
        return [jmh[lower][0], jmh[lower][1]];
    }
    let mut lo = if upper == previous.0 { previous.1 } else { 0.0 };
    let mut hi = 1.0;
    while hi - lo > 1e-7 {
        let t = (lo + hi) / 2.0;
        let h = display.rgb_to_jmh(lerp3(rgb[lower], rgb[upper], t))[2];
        if h < jmh[lower][2] {
            hi = t;
        } else if h >= jmh[upper][2] || h <= hue {
            lo = t;
        } else {
            hi = t;
        }
    }
    let t = (lo + hi) / 2.0;
    let c = display.rgb_to_jmh(lerp3(rgb[lower], rgb[upper], t));
    *previous = (upper, t);
    [c[0], c[1]]
}

/// The reach gamut's M at `limit_j` for each whole degree: where a JMh
/// colour first gets a negative AP1 component (steps of 50 up to 1300,
/// then a bisection to 1e-2).
fn reach_table(reach: &JmhSpace, limit_j: f64) -> [f64; TOTAL] {
    let mut table = [0.0; TOTAL];
    let outside = |m: f64, hue: f64| reach.jmh_to_rgb([limit_j, m, hue]).iter().any(|&c| c < 0.0);
    for i in 0..NOMINAL {
        let hue = i as f64;
        let (mut low, mut high) = (0.0, 50.0);
        while high < 1300.0 && !outside(high, hue) {
            low = high;
            high += 50.0;
        }
        while high - low > 1e-2 {
            let m = (high + low) / 2.0;
            if outside(m, hue) {
                high = m;
            } else {
                low = m;
            }
        }
        table[i + FIRST] = high;
    }
    table[0] = table[LAST];
    table[UPPER_WRAP] = table[FIRST];
    table[UPPER_WRAP + 1] = table[FIRST + 1];
    table
}

/// Where the search for a hue's entry may start and end, relative to its
/// uniform position.
fn search_range(cusps: &[[f64; 3]; TOTAL]) -> [i64; 2] {
    let mut range = [0i64, 1];
    for (i, c) in cusps.iter().enumerate().take(UPPER_WRAP).skip(FIRST) {
        let pos = FIRST as i64 + c[2] as i64;
        let delta = i as i64 - pos;
        range[0] = range[0].min(delta);
        range[1] = range[1].max(delta + 1);
    }
    range
}

impl GamutTables {
    /// The tables for a display of `peak` cd/m² whose limiting gamut is
    /// `display`'s, with AP1 (`reach`) as the reach; `input` is the scene
    /// side's model (AP0), `ts` the tone scale.
    pub fn new(
        input: &JmhSpace,
        display: &JmhSpace,
        reach: &JmhSpace,
        ts: &ToneScale,
    ) -> GamutTables {
        let peak = ts.peak;
        let limit_j = input.y_to_j(peak);
        let reach_m = reach_table(reach, limit_j);
        let mid_j = input.y_to_j(ts.c_t * REFERENCE_LUMINANCE);
        let focus_dist = FOCUS_DISTANCE + FOCUS_DISTANCE * FOCUS_DISTANCE_SCALING * ts.log_peak;
        let lower_gamma_inv = 1.0 / (1.14 + 0.07 * ts.log_peak);

        let reach_jmh = reach_corners(reach, limit_j, ts.forward_limit);
        let (disp_rgb, disp_jmh) = display_corners(display, peak);
        let hues = hue_table(&merged_hues(&reach_jmh, &disp_jmh));
        let mut cusps = [[0.0; 3]; TOTAL];
        let mut previous = (0, 0.0);
        for i in FIRST..UPPER_WRAP {
            let jm = display_cusp(hues[i], &disp_rgb, &disp_jmh, display, &mut previous);
            cusps[i] = [jm[0], jm[1] * (1.0 + SMOOTH_M * SMOOTH_CUSPS), hues[i]];
        }
        let wrap = |cusps: &mut [[f64; 3]; TOTAL]| {
            cusps[0] = cusps[LAST];
            cusps[UPPER_WRAP] = cusps[FIRST];
            cusps[UPPER_WRAP + 1] = cusps[FIRST + 1];
        };
        wrap(&mut cusps);
        for (i, h) in [
            (0, hues[0]),
            (UPPER_WRAP, hues[UPPER_WRAP]),
            (UPPER_WRAP + 1, hues[UPPER_WRAP + 1]),
        ] {
            cusps[i][2] = h;
        }
        let search = search_range(&cusps);
        let mut tables = GamutTables {
            limit_j,
            limit_a: input.j_to_a(limit_j),
            reach_m,
            hues,
            cusps,
            search,
            mid_j,
            focus_dist,
            lower_gamma_inv,
        };
        for i in FIRST..UPPER_WRAP {
            let gamma_inv = tables.upper_gamma_inv(i, display, peak);
            tables.cusps[i][2] = gamma_inv;
        }
        let g = [
            tables.cusps[LAST][2],
            tables.cusps[FIRST][2],
            tables.cusps[FIRST + 1][2],
        ];
        tables.cusps[0][2] = g[0];
        tables.cusps[UPPER_WRAP][2] = g[1];
        tables.cusps[UPPER_WRAP + 1][2] = g[2];
        tables
    }

    /// 1/γ of the upper hull at entry `i`: the smallest γ (searched in
    /// steps of 0.4 to 5, then bisected to 1e-5) for which five test
    /// points from the cusp to the top all land outside the display's
    /// cube.
    fn upper_gamma_inv(&self, i: usize, display: &JmhSpace, peak: f64) -> f64 {
        let hue = self.hues[i];
        let cusp = [self.cusps[i][0], self.cusps[i][1]];
        let at = self.with_cusp(cusp, 0.0);
        let tests: Vec<(f64, f64, f64)> = [0.01, 0.1, 0.5, 0.8, 0.99]
            .iter()
            .map(|&p| {
                let j = lerp(cusp[0], self.limit_j, p);
                let gain = focus_gain(j, at.threshold, self.limit_j, self.focus_dist);
                let j_source = solve_j_intersect(j, cusp[1], at.focus_j, self.limit_j, gain);
                (
                    j_source,
                    vector_slope(j_source, at.focus_j, self.limit_j, gain),
                    solve_j_intersect(cusp[0], cusp[1], at.focus_j, self.limit_j, gain),
                )
            })
            .collect();
        let limit = peak / REFERENCE_LUMINANCE;
        let (sin_h, cos_h) = hue.to_radians().sin_cos();
        let fits = |gamma: f64| {
            tests.iter().all(|&(j_source, slope, j_cusp)| {
                let m = boundary_m(
                    cusp,
                    self.limit_j,
                    1.0 / gamma,
                    self.lower_gamma_inv,
                    j_source,
                    slope,
                    j_cusp,
                );
                let j = j_source + slope * m;
                display
                    .jm_to_rgb(j, m, cos_h, sin_h)
                    .iter()
                    .any(|&c| c > limit)
            })
        };
        const STEP: f64 = 0.4;
        let (mut low, mut high) = (0.0, STEP);
        while high < 5.0 && !fits(high) {
            low = high;
            high += STEP;
        }
        while high - low > 1e-5 {
            let g = (high + low) / 2.0;
            if fits(g) {
                high = g;
            } else {
                low = g;
            }
        }
        1.0 / high
    }
}
