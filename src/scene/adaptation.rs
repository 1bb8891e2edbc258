//! Eye adaptation (docs/adaptation.md): the luminance an operator keys on,
//! metered each frame (a log average, or a log2 histogram with its darkest
//! and brightest fractions dropped), mapped through a compensation curve,
//! clamped to an EV range, and carried from frame to frame at a speed in
//! stops per second (or with a time constant) up and down.

use super::units::Positive;
use serde::{Deserialize, Serialize};

/// How a frame's luminance is measured for adaptation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Metering {
    /// The log average of the statistics (docs/statistics.md), with the
    /// operator's weights and δ: what the Reinhard operators key on.
    LogAverage,
    /// A 64-bin log2 histogram over [`Adaptation::min_ev`, `max_ev`],
    /// weighted by the [`Mask`]; the mean EV of what is left after the
    /// darkest `low` and brightest 1 − `high` of the weight are dropped.
    Histogram,
}

/// How each pixel is weighted in the histogram.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Mask {
    /// Every pixel weighs 1.
    Uniform,
    /// A pyramid: each axis in four bands from the edge in, weighing 1 to
    /// 4, a pixel the product (1 at the corners, 16 at the centre).
    Centre,
}

/// How the adapted value moves toward a frame's target.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Speed {
    /// At most `stops_up` (`stops_down`) stops a second; within
    /// `transition` stops of the target, exponentially at that speed over
    /// the transition (bevy's rule).
    Stops,
    /// By the fraction 1 − e^(−Δt/τ) of the gap, τ = `up` (`down`) seconds.
    TimeConstant,
}

/// The histogram's bins over [`Adaptation::min_ev`, `max_ev`].
pub const HISTOGRAM_BINS: usize = 64;

/// The most points a compensation curve has.
pub const COMPENSATION_POINTS: usize = 8;

/// A piecewise-linear curve from metered EV to stops of compensation
/// (positive brightens the frame), flat beyond its first and last point;
/// no points: none.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "Vec<[f64; 2]>", into = "Vec<[f64; 2]>")]
pub struct Compensation {
    points: [[f64; 2]; COMPENSATION_POINTS],
    len: usize,
}

impl TryFrom<Vec<[f64; 2]>> for Compensation {
    type Error = String;
    fn try_from(v: Vec<[f64; 2]>) -> Result<Compensation, String> {
        if v.len() > COMPENSATION_POINTS {
            return Err(format!(
                "must have at most {COMPENSATION_POINTS} points, got {}",
                v.len()
            ));
        }
        for (i, [ev, stops]) in v.iter().enumerate() {
            if !(ev.abs() <= MAX_EV && stops.abs() <= MAX_COMPENSATION) {
                return Err(format!(
                    "point {}: [{ev}, {stops}]: EV must be within ±{MAX_EV} and stops within ±{MAX_COMPENSATION}",
                    i + 1
                ));
            }
            if i > 0 && v[i - 1][0] >= *ev {
                return Err(format!(
                    "point {}: EV {ev} is not above the point before's {}",
                    i + 1,
                    v[i - 1][0]
                ));
            }
        }
        let mut points = [[0.0; 2]; COMPENSATION_POINTS];
        points[..v.len()].copy_from_slice(&v);
        Ok(Compensation {
            points,
            len: v.len(),
        })
    }
}

impl From<Compensation> for Vec<[f64; 2]> {
    fn from(c: Compensation) -> Vec<[f64; 2]> {
        c.points().to_vec()
    }
}

impl Compensation {
    pub fn points(&self) -> &[[f64; 2]] {
        &self.points[..self.len]
    }

    /// Stops of compensation at metered `ev`.
    pub fn at(&self, ev: f64) -> f64 {
        let p = self.points();
        match p {
            [] => 0.0,
            [first, ..] if ev <= first[0] => first[1],
            [.., last] if ev >= last[0] => last[1],
            _ => {
                let i = p.iter().position(|q| q[0] > ev).unwrap_or(p.len() - 1);
                let ([x0, y0], [x1, y1]) = (p[i - 1], p[i]);
                y0 + (y1 - y0) * (ev - x0) / (x1 - x0)
            }
        }
    }
}

/// The widest EV a range or curve may name: 2^±64 is well inside f32.
pub const MAX_EV: f64 = 64.0;
/// The most stops a compensation curve may add or take.
pub const MAX_COMPENSATION: f64 = 16.0;

/// Eye adaptation's parameters; EV is log2 of the scene's luminance (not
/// EV100), as bevy's range is.
///
/// Each frame is metered (`metering`); its EV, less the `compensation` at
/// it, clamped to [`min_ev`, `max_ev`], is the target, and the adapted EV
/// moves toward it (`speed`); the first frame (and the first after a reset)
/// takes the target as it is. A frame whose measurement is not finite (a
/// NaN or infinite pixel in a log average; a histogram with no weight left)
/// leaves the adapted value unchanged. The adapted luminance replaces the
/// log average wherever the operator reads one; an operator that reads none
/// has its input scaled by `key` / adapted (auto-exposure).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Adaptation {
    pub metering: Metering,
    /// EV: the histogram's range and the clamp of the target, low end.
    pub min_ev: f64,
    /// EV: the histogram's range and the clamp of the target, high end.
    pub max_ev: f64,
    /// The fraction of the histogram's weight dropped from the dark end.
    pub low: f64,
    /// The fraction kept from the dark end (1 − the fraction dropped from
    /// the bright end).
    pub high: f64,
    pub mask: Mask,
    pub compensation: Compensation,
    /// Whether the white point an operator reads from the frame's largest
    /// luminance (`reinhard-global`) follows it at the same speed, so one
    /// bright pixel cannot swing a frame; false: each frame's own.
    pub adapt_white: bool,
    pub speed: Speed,
    /// Stops per second as the scene brightens (`speed = "stops"`).
    pub stops_up: Positive,
    /// Stops per second as it darkens.
    pub stops_down: Positive,
    /// Stops from the target below which the speed turns exponential; 0:
    /// linear all the way.
    pub transition: f64,
    /// Seconds: the time constant as the scene brightens
    /// (`speed = "time-constant"`).
    pub up: Positive,
    /// Seconds: the time constant as it darkens.
    pub down: Positive,
    /// The grey an operator that keys on nothing maps the adapted
    /// luminance to.
    pub key: Positive,
}

/// Seconds: light adaptation's default time constant.
pub const DEFAULT_UP: f64 = 0.4;
/// Seconds: dark adaptation's, four times slower.
pub const DEFAULT_DOWN: f64 = 1.6;
/// Middle grey.
pub const DEFAULT_ADAPTATION_KEY: f64 = 0.18;

impl Default for Adaptation {
    /// Histogram metering over −6…8 EV with 10 %…90 % kept, no
    /// compensation, 12 stops a second up and 3 down, exponential within
    /// 1.5 stops (docs/adaptation.md says why each differs from bevy's).
    fn default() -> Adaptation {
        Adaptation {
            metering: Metering::Histogram,
            min_ev: -6.0,
            max_ev: 8.0,
            low: 0.1,
            high: 0.9,
            mask: Mask::Uniform,
            compensation: Compensation::default(),
            adapt_white: true,
            speed: Speed::Stops,
            stops_up: Positive(12.0),
            stops_down: Positive(3.0),
            transition: 1.5,
            up: Positive(DEFAULT_UP),
            down: Positive(DEFAULT_DOWN),
            key: Positive(DEFAULT_ADAPTATION_KEY),
        }
    }
}

impl Adaptation {
    /// The first model: the log average followed with time constants `up`
    /// and `down` seconds, mapped to `key`, unclamped (±64 EV), each
    /// frame's own white point; or which is out of range.
    pub fn new(up: f64, down: f64, key: f64) -> Result<Adaptation, (&'static str, String)> {
        Ok(Adaptation {
            metering: Metering::LogAverage,
            min_ev: -MAX_EV,
            max_ev: MAX_EV,
            speed: Speed::TimeConstant,
            adapt_white: false,
            up: Positive::try_from(up).map_err(|e| ("up", e))?,
            down: Positive::try_from(down).map_err(|e| ("down", e))?,
            key: Positive::try_from(key).map_err(|e| ("key", e))?,
            ..Adaptation::default()
        })
    }

    /// bevy's `AutoExposure` defaults: histogram metering over −8…8 EV,
    /// 10 %…90 % kept, no compensation, 3 stops a second as the scene
    /// brightens and 1 as it darkens, exponential within 1.5 stops.
    pub fn bevy() -> Adaptation {
        Adaptation {
            min_ev: -8.0,
            max_ev: 8.0,
            stops_up: Positive(3.0),
            stops_down: Positive(1.0),
            ..Adaptation::default()
        }
    }

    /// What is wrong with the parameters together: the key and why.
    pub fn check(&self) -> Result<(), (&'static str, String)> {
        let ev = |v: f64| v.is_finite() && v.abs() <= MAX_EV;
        if !(ev(self.min_ev) && ev(self.max_ev) && self.min_ev < self.max_ev) {
            return Err((
                "min_ev",
                format!(
                    "min_ev {} and max_ev {} must be within ±{MAX_EV}, min_ev below max_ev",
                    self.min_ev, self.max_ev
                ),
            ));
        }
        if !((0.0..1.0).contains(&self.low) && self.high > self.low && self.high <= 1.0) {
            return Err((
                "low",
                format!(
                    "low {} and high {} must be fractions with 0 <= low < high <= 1",
                    self.low, self.high
                ),
            ));
        }
        if !(self.transition.is_finite() && (0.0..=MAX_EV).contains(&self.transition)) {
            return Err((
                "transition",
                format!("must be within 0…{MAX_EV} stops, got {}", self.transition),
            ));
        }
        Ok(())
    }

    /// The fractions of the gap one frame of `dt` seconds closes under the
    /// time-constant model, (up, down): 1 − e^(−Δt/τ), from `exp_m1` so
    /// that a short frame keeps its digits.
    pub fn steps(&self, dt: f64) -> (f64, f64) {
        let step = |tau: f64| -(-dt / tau).exp_m1();
        (step(self.up.get()), step(self.down.get()))
    }

    /// The target, in natural logarithms, of a frame metered at `m` (ln):
    /// less the compensation, clamped to the EV range.
    pub fn target(&self, m: f64) -> f64 {
        let ln2 = std::f64::consts::LN_2;
        let t = m - self.compensation.at(m / ln2) * ln2;
        t.clamp(self.min_ev * ln2, self.max_ev * ln2)
    }

    /// The adapted value (ln) one frame of `dt` seconds after `a` (ln), with
    /// target `t` (ln).
    pub fn follow(&self, a: f64, t: f64, dt: f64) -> f64 {
        let gap = t - a;
        match self.speed {
            Speed::TimeConstant => {
                let (up, down) = self.steps(dt);
                a + gap * if gap > 0.0 { up } else { down }
            }
            Speed::Stops => {
                let (most, exp) = self.stop_steps(dt);
                let rate = if gap > 0.0 { most.0 } else { most.1 };
                let near = if gap > 0.0 { exp.0 } else { exp.1 };
                a + gap.signum() * gap.abs().min(rate).min(gap.abs() * near)
            }
        }
    }

    /// Under `speed = "stops"`, for a frame of `dt` seconds: the most the
    /// adapted value moves (ln, up and down) and the fraction of the gap
    /// it moves within the transition (up and down; unbounded when the
    /// transition is 0).
    pub fn stop_steps(&self, dt: f64) -> ((f64, f64), (f64, f64)) {
        let ln2 = std::f64::consts::LN_2;
        let up = self.stops_up.get() * dt * ln2;
        let down = self.stops_down.get() * dt * ln2;
        let near = |most: f64| {
            if self.transition > 0.0 {
                most / (self.transition * ln2)
            } else {
                f64::INFINITY
            }
        };
        ((up, down), (near(up), near(down)))
    }
}
