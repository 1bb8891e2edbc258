//! Built-in HDR environments, generated deterministically at any resolution so
//! that the main job needs no files.
//!
//! Each one is a function of the direction through a texel centre, evaluated
//! with `libm` so that every machine produces the same bits.

use crate::conventions::equirect_direction;
use crate::image::HdrImage;
use rayon::prelude::*;
use std::fmt;

/// The built-in environments. Luminance ranges are BT.709 Y, in the map's units.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BuiltinEnv {
    /// Gradient sky over a dark ground with a sun disc ~10⁵ times the sky:
    /// Y from 0.03 (ground) through 0.4–1.2 (sky) to 1.2·10⁵ (sun).
    Sky,
    /// Dark room (walls 0.005–0.05) with a bright window (~200) crossed by dark
    /// mullions: about 10⁴:1 between window and walls.
    Interior,
    /// Mostly near-black (10⁻⁴–10⁻³) with five small lamps of 20–600: the case
    /// `reinhard-auto-key`'s weighted log-average exists for.
    Night,
    /// High-frequency checkerboard (0.02 and 1.0, tinted) crossed by thin bright
    /// lines (8.0): exercises aliasing and filtering.
    Grid,
    /// Twelve fully saturated hues in three rows (0.25, 2.5 and 25 times
    /// their RGB) around the horizon, between grey (0.18) and dark (0.02):
    /// colours outside most displays' gamuts, for gamut and hue handling.
    Colours,
}

impl BuiltinEnv {
    pub const ALL: [BuiltinEnv; 5] = [
        Self::Sky,
        Self::Interior,
        Self::Night,
        Self::Grid,
        Self::Colours,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Self::Sky => "sky",
            Self::Interior => "interior",
            Self::Night => "night",
            Self::Grid => "grid",
            Self::Colours => "colours",
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|e| e.name() == name)
    }

    /// One line for `tonegate env --list`.
    pub fn description(self) -> &'static str {
        match self {
            Self::Sky => "gradient sky, dark ground, sun disc; Y 0.03 .. 1.2e5",
            Self::Interior => "dark room with a bright mullioned window; Y 0.005 .. 200 (~1e4:1)",
            Self::Night => "near-black with five small lamps; Y 1e-4 .. 600",
            Self::Grid => "high-frequency checker with thin bright lines; Y 0.02 .. 8",
            Self::Colours => {
                "twelve saturated hues at three levels on grey and dark; Y 0.019 .. 23"
            }
        }
    }

    /// Radiance in the direction `d` (unit length).
    fn radiance(self, d: [f64; 3]) -> [f64; 3] {
        match self {
            Self::Sky => sky(d),
            Self::Interior => interior(d),
            Self::Night => night(d),
            Self::Grid => grid(d),
            Self::Colours => colours(d),
        }
    }

    /// Generates the map at `width`×`height` (both ≥ 1).
    pub fn generate(self, width: u32, height: u32) -> HdrImage {
        let mut pixels = vec![[0.0f32; 3]; width as usize * height as usize];
        pixels
            .par_chunks_mut(width.max(1) as usize)
            .enumerate()
            .for_each(|(y, row)| {
                let v = (y as f64 + 0.5) / height as f64;
                for (x, px) in row.iter_mut().enumerate() {
                    let u = (x as f64 + 0.5) / width as f64;
                    let c = self.radiance(equirect_direction(u, v));
                    *px = [c[0] as f32, c[1] as f32, c[2] as f32];
                }
            });
        HdrImage {
            width,
            height,
            pixels,
        }
    }
}

impl fmt::Display for BuiltinEnv {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn normalize(a: [f64; 3]) -> [f64; 3] {
    let n = dot(a, a).sqrt();
    [a[0] / n, a[1] / n, a[2] / n]
}

fn scale(c: [f64; 3], k: f64) -> [f64; 3] {
    [c[0] * k, c[1] * k, c[2] * k]
}

fn lerp(a: [f64; 3], b: [f64; 3], t: f64) -> [f64; 3] {
    [
        a[0] + (b[0] - a[0]) * t,
        a[1] + (b[1] - a[1]) * t,
        a[2] + (b[2] - a[2]) * t,
    ]
}

/// Unit direction at elevation `el` and azimuth `az` (radians; azimuth 0 is −z,
/// positive towards +x), matching `equirect_direction`.
fn dir(el: f64, az: f64) -> [f64; 3] {
    let c = libm::cos(el);
    [c * libm::sin(az), libm::sin(el), -c * libm::cos(az)]
}

fn sky(d: [f64; 3]) -> [f64; 3] {
    let sun = dir(25f64.to_radians(), 20f64.to_radians());
    // The sun: a 1.5° disc. Its Y is ~1.2e5, 10⁵ times the sky near it.
    if dot(d, sun) > libm::cos(1.5f64.to_radians()) {
        return [1.3e5, 1.2e5, 1.05e5];
    }
    if d[1] < 0.0 {
        // Ground, slightly brighter towards the horizon.
        let t = (-d[1]).min(1.0);
        return lerp([0.06, 0.05, 0.04], [0.03, 0.03, 0.025], t);
    }
    let horizon = [1.1, 1.15, 1.25];
    let zenith = [0.25, 0.4, 0.9];
    let t = libm::pow(d[1], 0.5);
    let base = lerp(horizon, zenith, t);
    // A soft aureole around the sun, so bloom has something smooth to spread.
    let glow = 2.0 * libm::exp(-(1.0 - dot(d, sun)) * 40.0);
    [base[0] + glow, base[1] + glow * 0.95, base[2] + glow * 0.8]
}

fn interior(d: [f64; 3]) -> [f64; 3] {
    let el = libm::asin(d[1].clamp(-1.0, 1.0));
    let az = libm::atan2(d[0], -d[2]);
    // Window: azimuth ±35°, elevation −5°..40°, with a cross of mullions.
    let (az_half, el_lo, el_hi) = (35f64.to_radians(), (-5f64).to_radians(), 40f64.to_radians());
    if az.abs() < az_half && el > el_lo && el < el_hi {
        let mullion_az = az.abs() < 1.2f64.to_radians();
        let mullion_el = (el - 0.5 * (el_lo + el_hi)).abs() < 1.2f64.to_radians();
        if mullion_az || mullion_el {
            return [0.004, 0.0035, 0.003];
        }
        return [190.0, 200.0, 215.0];
    }
    // Walls lit by the window: brighter facing it, with panel seams.
    let facing = 0.5 * (1.0 + dot(d, dir(0.3, 0.0)));
    let mut wall = 0.005 + 0.045 * facing * facing;
    let seam = (libm::fmod(
        (az + std::f64::consts::PI) * 12.0 / std::f64::consts::PI,
        1.0,
    )) < 0.04;
    if seam {
        wall *= 0.5;
    }
    if d[1] < -0.3 {
        // Floor boards: warmer.
        return [wall * 1.2, wall, wall * 0.7];
    }
    [wall, wall, wall * 1.05]
}

fn night(d: [f64; 3]) -> [f64; 3] {
    // A faint sky glow near the horizon over a darker ground.
    let base = if d[1] >= 0.0 {
        let t = 1.0 - d[1];
        scale([0.6, 0.7, 1.2], 1e-4 + 9e-4 * t * t * t)
    } else {
        [1.2e-4, 1.0e-4, 0.9e-4]
    };
    // Five small lamps (elevation, azimuth, angular radius, luminance).
    const LAMPS: [(f64, f64, f64, f64); 5] = [
        (2.0, -40.0, 1.2, 600.0),
        (5.0, 10.0, 0.8, 150.0),
        (-3.0, 60.0, 1.0, 300.0),
        (12.0, 120.0, 0.6, 20.0),
        (1.0, -150.0, 1.5, 80.0),
    ];
    for (el, az, radius, y) in LAMPS {
        let c = dir(el.to_radians(), az.to_radians());
        if dot(d, normalize(c)) > libm::cos(radius.to_radians()) {
            // Warm sodium-ish colour scaled so that Y = y.
            let tint = [1.25, 0.95, 0.55];
            let k = y / crate::color::luminance(tint);
            return scale(tint, k);
        }
    }
    base
}

fn grid(d: [f64; 3]) -> [f64; 3] {
    let (u, v) = crate::conventions::equirect_uv(d);
    // 48×24 checker cells, so cells are square on the map.
    let cu = (u * 48.0).floor() as i64;
    let cv = (v * 24.0).floor() as i64;
    let light = (cu + cv).rem_euclid(2) == 0;
    let line_u = libm::fmod(u * 96.0, 1.0) < 0.08;
    let line_v = libm::fmod(v * 48.0, 1.0) < 0.08;
    if line_u || line_v {
        return [8.0, 8.0, 8.0];
    }
    if light {
        [1.0, 0.95, 0.85]
    } else {
        [0.02, 0.025, 0.03]
    }
}

/// Twelve fully saturated hues (every 30° from red) in three rows of
/// intensity around the horizon, on a mid-grey upper half and a dark lower
/// one: colours outside most displays' gamuts at display levels and far
/// above them.
fn colours(d: [f64; 3]) -> [f64; 3] {
    let (u, v) = crate::conventions::equirect_uv(d);
    if !(0.3..0.7).contains(&v) {
        return if v < 0.5 {
            [0.18, 0.18, 0.18]
        } else {
            [0.02, 0.02, 0.02]
        };
    }
    // Rows from the top: 25, 2.5 and 0.25 times the hue's own RGB; a thin
    // grey gap between swatches keeps their edges apart.
    let row = ((v - 0.3) / 0.4 * 3.0).floor().min(2.0);
    let k = 25.0 * libm::pow(0.1, row);
    let cell = u * 12.0;
    if libm::fmod(cell, 1.0) < 0.06 {
        return [0.18, 0.18, 0.18];
    }
    let hue = cell.floor() * 30.0;
    // HSV with S = V = 1, piecewise linear in the hue; a floor of 0.004 so
    // that no channel is 0.
    let channel = |offset: f64| {
        let h = libm::fmod(hue + offset, 360.0);
        let x = if h < 60.0 {
            1.0
        } else if h < 120.0 {
            (120.0 - h) / 60.0
        } else if h < 240.0 {
            0.0
        } else if h < 300.0 {
            (h - 240.0) / 60.0
        } else {
            1.0
        };
        x.max(0.004) * k
    };
    [channel(0.0), channel(240.0), channel(120.0)]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::color::luminance;

    fn y_range(img: &HdrImage) -> (f64, f64) {
        img.pixels.iter().fold((f64::MAX, f64::MIN), |(lo, hi), p| {
            let y = luminance([p[0] as f64, p[1] as f64, p[2] as f64]);
            (lo.min(y), hi.max(y))
        })
    }

    #[test]
    fn documented_luminance_ranges_hold() {
        // (env, min Y at least, max Y at least, dynamic range at least)
        let cases = [
            (BuiltinEnv::Sky, 0.02, 1.0e5, 1.0e5),
            (BuiltinEnv::Interior, 0.002, 150.0, 1.0e4),
            (BuiltinEnv::Night, 5e-5, 500.0, 1.0e5),
            (BuiltinEnv::Grid, 0.01, 7.0, 100.0),
            (BuiltinEnv::Colours, 0.004, 20.0, 1.0e3),
        ];
        for (env, lo, hi, range) in cases {
            let img = env.generate(1024, 512);
            let (min, max) = y_range(&img);
            assert!(
                min >= lo && max >= hi && max / min >= range,
                "{env}: Y {min} .. {max}"
            );
            assert!(img
                .pixels
                .iter()
                .flatten()
                .all(|c| c.is_finite() && *c > 0.0));
        }
    }

    #[test]
    fn generation_is_deterministic_and_any_size_works() {
        for env in BuiltinEnv::ALL {
            assert_eq!(env.generate(37, 19), env.generate(37, 19));
            assert_eq!(env.generate(1, 1).pixels.len(), 1);
        }
    }

    #[test]
    fn names_round_trip() {
        for env in BuiltinEnv::ALL {
            assert_eq!(BuiltinEnv::from_name(env.name()), Some(env));
        }
        assert_eq!(BuiltinEnv::from_name("moon"), None);
    }
}
