//! `taa`: temporal anti-aliasing (§3.6 of the TAA thesis in
//! docs/bibliography.md; docs/taa.md), in f64.
//!
//! Each frame renders one jittered sample per pixel (`sphere`), and this
//! stage blends it with the history, the previous frame's resolved image:
//!
//! 1. **Reprojection**, exact in the gate's scenes: the camera is fixed at
//!    the sphere's centre and the sphere turns by a known rotation, so the
//!    point pixel p sees now was seen last frame at `conventions::reproject`
//!    (no velocity buffer). An application embedding the tone mapper gives
//!    motion vectors instead ([`Reprojection::Motion`]). The history is read
//!    there (texel centres at k + ½, clamped at the border); a point that was
//!    off the film has no history.
//! 2. **The clipping box** from the current frame's 3×3 and cross (+)
//!    neighbourhoods: `clip` averages their min and max (§3.6.3);
//!    `edge_aware` blends them by the pixel's aliasing amount a (Sobel, eq.
//!    4.15) and shrinks the box toward the current colour by a (eq. 4.16).
//!    The thesis's other two signals, depth edges and the model index, do not
//!    exist in a one-object sphere scene and are not faked: the terms are 0.
//! 3. **Clipping**, not clamping (§3.6.4): the history colour is moved along
//!    the line to the box centre until it is inside the box, so it keeps its
//!    hue instead of snapping to a corner.
//! 4. **Feedback** from the luminance difference between the clipped history
//!    and the current colour, biased toward the history (§3.6.3): with
//!    d = |Yc − Yh| / max(Yc, Yh), the history's weight is
//!    feedback_min + (feedback_max − feedback_min)·(1 − d)². The difference is
//!    relative, so the weight does not depend on the exposure of an HDR frame.
//! 5. The blend is the new history. The stage's output is the blend
//!    **sharpened** by the thesis's kernel at strength s (eq. 3.1, see
//!    `scene::Taa::sharpen`), limited to the cross neighbourhood's range (see
//!    [`sharpen`]); the history is kept unsharpened, or the sharpening would
//!    compound frame after frame.
//!
//! `shaders/taa.wgsl` does the same arithmetic in f32.

use super::taa_sobel::clamped;
use crate::color::{luminance, SMALLEST_NORMAL};
use crate::conventions::{reproject, Camera, Mat3};
use crate::image::{Image, LinearImage};
use crate::par::*;
use crate::scene::{BlendSpace, FeedbackRule, HistoryFilter, TaaParams, TaaVariant};

/// A TAA history: the resolved (unsharpened) colours and, per pixel, how
/// many frames each has averaged since its history last started.
#[derive(Clone, Debug, PartialEq)]
pub struct TaaHistory {
    pub colour: LinearImage,
    /// Frames in the pixel's history, 1 for a pixel that had none (a reset,
    /// or a point that was off the film), at most [`CONFIDENCE_CAP`]. The
    /// GPU keeps it in the history texture's alpha.
    pub confidence: Image<f64>,
}

/// Where a pixel's frame count stops growing: far beyond any weight it
/// sets (1/1024), and exact in f16.
pub const CONFIDENCE_CAP: f64 = 1024.0;

/// What one TAA frame resolves against.
pub struct TaaFrame<'a> {
    /// The previous frame's history; None on a reset.
    pub history: Option<&'a TaaHistory>,
    /// Where each pixel's history is.
    pub reprojection: Reprojection<'a>,
}

/// Where a pixel's centre was in the previous frame.
#[derive(Clone, Copy, Debug)]
pub enum Reprojection<'a> {
    /// The gate's sphere: `conventions::reprojection` from the previous
    /// frame's rotation to this one's, through the camera.
    Rotation { camera: Camera, matrix: Mat3 },
    /// An application's motion vectors (`gpu::ToneMapper` with TAA): pixel
    /// (i, j)'s centre was at (i + ½ + sx·vx, j + ½ + sy·vy), where (vx, vy)
    /// is its vector and (sx, sy) the `scale` that turns the vectors' units
    /// and sign into pixels toward the previous frame. A point outside the
    /// film, or not a number, has no history.
    Motion {
        vectors: &'a Image<[f64; 2]>,
        scale: [f64; 2],
    },
}

impl Reprojection<'_> {
    /// Where pixel (i, j)'s centre was, in pixels from the top-left
    /// corner, or None when it has no history.
    pub fn previous_point(&self, i: u32, j: u32) -> Option<(f64, f64)> {
        match self {
            Reprojection::Rotation { camera, matrix } => reproject(camera, matrix, i, j),
            Reprojection::Motion { vectors, scale } => {
                let v = vectors.get(i, j);
                let px = i as f64 + 0.5 + scale[0] * v[0];
                let py = j as f64 + 0.5 + scale[1] * v[1];
                let within = |p: f64, n: u32| (0.0..=n as f64).contains(&p);
                (within(px, vectors.width) && within(py, vectors.height)).then_some((px, py))
            }
        }
    }
}

/// The stage's two images.
pub struct TaaOutput {
    /// The blend and its frame counts: next frame's history.
    pub history: TaaHistory,
    /// The sharpened blend: what the later stages read.
    pub output: LinearImage,
}

/// The history read at film point (px, py) with `filter`, border clamped.
pub fn history_at(history: &LinearImage, px: f64, py: f64, filter: HistoryFilter) -> [f64; 3] {
    match filter {
        HistoryFilter::Bilinear => history_bilinear(history, px, py),
        HistoryFilter::CatmullRom => history_catmull_rom(history, px, py),
    }
}

/// Catmull-Rom weights of the four taps around a fraction t in [0, 1).
pub(crate) fn catmull_rom_weights(t: f64) -> [f64; 4] {
    let t2 = t * t;
    let t3 = t2 * t;
    [
        0.5 * (-t3 + 2.0 * t2 - t),
        0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
        0.5 * (-3.0 * t3 + 4.0 * t2 + t),
        0.5 * (t3 - t2),
    ]
}

/// The history over 4×4 texels with separable Catmull-Rom weights, each
/// channel clamped at 0 (the negative lobes can undershoot beside an edge).
fn history_catmull_rom(history: &LinearImage, px: f64, py: f64) -> [f64; 3] {
    let (x, y) = (px - 0.5, py - 0.5);
    let (x0, y0) = (x.floor(), y.floor());
    let (wx, wy) = (catmull_rom_weights(x - x0), catmull_rom_weights(y - y0));
    let (x0, y0) = (x0 as i64, y0 as i64);
    let mut out = [0.0; 3];
    for (b, wyb) in wy.iter().enumerate() {
        let mut row = [0.0; 3];
        for (a, wxa) in wx.iter().enumerate() {
            let p = clamped(history, x0 - 1 + a as i64, y0 - 1 + b as i64);
            for c in 0..3 {
                row[c] += wxa * p[c];
            }
        }
        for c in 0..3 {
            out[c] += wyb * row[c];
        }
    }
    [out[0].max(0.0), out[1].max(0.0), out[2].max(0.0)]
}

/// The history read bilinearly at film point (px, py), border clamped.
fn history_bilinear(history: &LinearImage, px: f64, py: f64) -> [f64; 3] {
    let (x, y) = (px - 0.5, py - 0.5);
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (x0, y0) = (x0 as i64, y0 as i64);
    let t = |dx, dy| clamped(history, x0 + dx, y0 + dy);
    let (p00, p10, p01, p11) = (t(0, 0), t(1, 0), t(0, 1), t(1, 1));
    let mut out = [0.0; 3];
    for c in 0..3 {
        let top = p00[c] * (1.0 - fx) + p10[c] * fx;
        let bottom = p01[c] * (1.0 - fx) + p11[c] * fx;
        out[c] = top * (1.0 - fy) + bottom * fy;
    }
    out
}

fn mix3(a: [f64; 3], b: [f64; 3], t: f64) -> [f64; 3] {
    [
        a[0] + (b[0] - a[0]) * t,
        a[1] + (b[1] - a[1]) * t,
        a[2] + (b[2] - a[2]) * t,
    ]
}

/// `history` clipped toward the centre of the box [lo, hi]: unchanged when
/// inside, else moved along the line to the centre onto the box's surface.
pub fn clip_to_box(history: [f64; 3], lo: [f64; 3], hi: [f64; 3]) -> [f64; 3] {
    let mut reach = 0.0f64;
    let mut centre = [0.0; 3];
    let mut v = [0.0; 3];
    for c in 0..3 {
        centre[c] = 0.5 * (lo[c] + hi[c]);
        let extent = 0.5 * (hi[c] - lo[c]);
        v[c] = history[c] - centre[c];
        let r = if extent > 0.0 {
            v[c].abs() / extent
        } else if v[c] != 0.0 {
            f64::INFINITY
        } else {
            0.0
        };
        reach = reach.max(r);
    }
    if reach <= 1.0 {
        history
    } else {
        // reach = ∞ (a flat box and a history off it) gives the centre.
        [
            centre[0] + v[0] / reach,
            centre[1] + v[1] / reach,
            centre[2] + v[2] / reach,
        ]
    }
}

/// The history's weight for current colour `c` and clipped history `h`.
pub fn feedback(c: [f64; 3], h: [f64; 3], p: &TaaParams) -> f64 {
    let (yc, yh) = (luminance(c), luminance(h));
    let top = yc.max(yh);
    let d = if top < SMALLEST_NORMAL {
        0.0
    } else {
        ((yc - yh).abs() / top).min(1.0)
    };
    let w = (1.0 - d) * (1.0 - d);
    p.feedback_min + (p.feedback_max - p.feedback_min) * w
}

/// The clipping box of pixel (x, y) of `current`: (lo, hi). `amount` is
/// the Sobel image for `edge_aware` (None for `clip`).
pub(crate) fn clip_box(
    current: &LinearImage,
    amount: Option<&Image<f64>>,
    x: i64,
    y: i64,
) -> ([f64; 3], [f64; 3]) {
    const CROSS: [(i64, i64); 5] = [(0, 0), (-1, 0), (1, 0), (0, -1), (0, 1)];
    const CORNERS: [(i64, i64); 4] = [(-1, -1), (1, -1), (-1, 1), (1, 1)];
    let mut lo_x = [f64::INFINITY; 3];
    let mut hi_x = [f64::NEG_INFINITY; 3];
    for (dx, dy) in CROSS {
        let p = clamped(current, x + dx, y + dy);
        for c in 0..3 {
            lo_x[c] = lo_x[c].min(p[c]);
            hi_x[c] = hi_x[c].max(p[c]);
        }
    }
    let (mut lo_9, mut hi_9) = (lo_x, hi_x);
    for (dx, dy) in CORNERS {
        let p = clamped(current, x + dx, y + dy);
        for c in 0..3 {
            lo_9[c] = lo_9[c].min(p[c]);
            hi_9[c] = hi_9[c].max(p[c]);
        }
    }
    match amount {
        None => (mix3(lo_x, lo_9, 0.5), mix3(hi_x, hi_9, 0.5)),
        Some(s) => {
            let a = aliased_value(s, x, y);
            let centre = clamped(current, x, y);
            let lo = mix3(lo_x, lo_9, a);
            let hi = mix3(hi_x, hi_9, a);
            (mix3(centre, lo, a), mix3(centre, hi, a))
        }
    }
}

/// The TAA thesis's aliasedValue (eqs. 4.12–4.14) with the model and depth
/// terms 0: the cross and 3×3 means of the Sobel amount, blended by the
/// pixel's own.
pub(crate) fn aliased_value(s: &Image<f64>, x: i64, y: i64) -> f64 {
    let at = |dx, dy| clamped(s, x + dx, y + dy);
    let centre = at(0, 0);
    let cross = centre + at(-1, 0) + at(1, 0) + at(0, -1) + at(0, 1);
    let all = cross + at(-1, -1) + at(1, -1) + at(-1, 1) + at(1, 1);
    let mixed = cross / 5.0 + (all / 9.0 - cross / 5.0) * centre.clamp(0.0, 1.0);
    mixed.clamp(0.0, 1.0)
}

/// The frame count of the history texel under film point (px, py), border
/// clamped (a count is not interpolated: the texel the point falls in).
pub fn confidence_at(confidence: &Image<f64>, px: f64, py: f64) -> f64 {
    clamped(confidence, px.floor() as i64, py.floor() as i64)
}

/// The current frame's weight in the blend under `FeedbackRule::Motion`,
/// for a pixel whose new history holds `frames` frames and which moved
/// `motion_px` pixels since the last frame.
pub fn motion_weight(frames: f64, motion_px: f64, p: &TaaParams) -> f64 {
    let from_motion = if motion_px < p.static_px {
        p.current_min
    } else {
        (p.current_moving + p.current_per_px * motion_px).min(p.current_max)
    };
    from_motion.max(1.0 / frames)
}

/// YCoCg (Malvar and Sullivan's lifting transform, as TAA clipping uses
/// it): Y = R/4 + G/2 + B/4, Co = (R − B)/2, Cg = (2G − R − B)/4.
pub fn to_ycocg(c: [f64; 3]) -> [f64; 3] {
    [
        0.25 * c[0] + 0.5 * c[1] + 0.25 * c[2],
        0.5 * c[0] - 0.5 * c[2],
        -0.25 * c[0] + 0.5 * c[1] - 0.25 * c[2],
    ]
}

/// The inverse of [`to_ycocg`].
pub fn from_ycocg(c: [f64; 3]) -> [f64; 3] {
    [c[0] + c[1] - c[2], c[0] + c[2], c[0] - c[1] - c[2]]
}

/// Variance clipping (Salvi 2016): `history` clipped, in YCoCg, toward the
/// mean of pixel (x, y)'s 3×3 neighbourhood onto the box mean ± γσ; back in
/// RGB, each channel at least 0.
pub fn clip_variance(
    current: &LinearImage,
    x: i64,
    y: i64,
    history: [f64; 3],
    gamma: f64,
) -> [f64; 3] {
    let mut sum = [0.0; 3];
    let mut sum_sq = [0.0; 3];
    for dy in -1..=1 {
        for dx in -1..=1 {
            let q = to_ycocg(clamped(current, x + dx, y + dy));
            for c in 0..3 {
                sum[c] += q[c];
                sum_sq[c] += q[c] * q[c];
            }
        }
    }
    let mut lo = [0.0; 3];
    let mut hi = [0.0; 3];
    for c in 0..3 {
        let mean = sum[c] / 9.0;
        let sigma = (sum_sq[c] / 9.0 - mean * mean).max(0.0).sqrt();
        lo[c] = mean - gamma * sigma;
        hi[c] = mean + gamma * sigma;
    }
    let clipped = from_ycocg(clip_to_box(to_ycocg(history), lo, hi));
    [
        clipped[0].max(0.0),
        clipped[1].max(0.0),
        clipped[2].max(0.0),
    ]
}

/// The blend of current colour `c` and clipped history `h` with the
/// history weighing `w`, in `space`.
pub fn blend(c: [f64; 3], h: [f64; 3], w: f64, space: BlendSpace) -> [f64; 3] {
    match space {
        BlendSpace::Linear => mix3(c, h, w),
        BlendSpace::Tonemapped => {
            let wc = (1.0 - w) / (1.0 + luminance(c));
            let wh = w / (1.0 + luminance(h));
            let t = wh / (wc + wh);
            mix3(c, h, t)
        }
    }
}

/// Resolves `current` (this frame's jittered `sphere` output) against
/// `frame`'s history. `amount` is `taa_sobel`'s output, required for
/// `edge_aware` and ignored otherwise.
pub fn taa(
    current: &LinearImage,
    amount: Option<&Image<f64>>,
    frame: &TaaFrame,
    p: &TaaParams,
) -> TaaOutput {
    let (w, h) = (current.width as usize, current.height as usize);
    let amount = amount.filter(|_| p.variant == TaaVariant::EdgeAware);
    let mut blended = vec![([0.0f64; 3], 1.0f64); w * h];
    blended.par_chunks_mut(w).enumerate().for_each(|(j, row)| {
        for (i, out) in row.iter_mut().enumerate() {
            let c = current.pixels[j * w + i];
            let previous = frame.history.and_then(|hist| {
                let point = frame.reprojection.previous_point(i as u32, j as u32);
                point.map(|(px, py)| {
                    let colour = history_at(&hist.colour, px, py, p.history_filter);
                    let frames =
                        (confidence_at(&hist.confidence, px, py) + 1.0).min(CONFIDENCE_CAP);
                    let motion = (px - (i as f64 + 0.5)).hypot(py - (j as f64 + 0.5));
                    (colour, frames, motion)
                })
            });
            *out = match previous {
                None => (c, 1.0),
                Some((hist, frames, motion)) => {
                    let (x, y) = (i as i64, j as i64);
                    let clipped = if p.variant == TaaVariant::Variance {
                        clip_variance(current, x, y, hist, p.variance_gamma)
                    } else {
                        let (lo, hi) = clip_box(current, amount, x, y);
                        clip_to_box(hist, lo, hi)
                    };
                    let weight = match p.feedback {
                        FeedbackRule::Luminance => feedback(c, clipped, p),
                        FeedbackRule::Motion => 1.0 - motion_weight(frames, motion, p),
                    };
                    // A static pixel is blended linearly whatever `p.blend`
                    // says: its history then converges on the plain mean of
                    // the jitter offsets, which is what an accumulation
                    // reference is.
                    let space = if motion < p.static_px {
                        BlendSpace::Linear
                    } else {
                        p.blend
                    };
                    (blend(c, clipped, weight, space), frames)
                }
            };
        }
    });
    let colour = Image {
        width: current.width,
        height: current.height,
        pixels: blended.iter().map(|b| b.0).collect(),
    };
    let confidence = Image {
        width: current.width,
        height: current.height,
        pixels: blended.iter().map(|b| b.1).collect(),
    };
    let output = sharpen(&colour, p.sharpen);
    TaaOutput {
        history: TaaHistory { colour, confidence },
        output,
    }
}

/// The TAA thesis's sharpen kernel at strength s:
/// b + s·(4b − N − S − E − W), limited to the range of the blend's cross
/// neighbourhood (per channel).
///
/// The limit is ours, not the thesis's: its frames are display-referred, where
/// the kernel's undershoot beside a bright edge is a dark fringe. On an HDR
/// frame a 100:1 edge at s = ¼ undershoots to −24 times the dark side; the
/// fringe is clamped to 0, and a frame of such zeros drags the log-average
/// the operator adapts to (measured on the grid: the whole frame 10 dB off
/// the reference). Inside the neighbourhood's range the kernel still
/// steepens every edge, and creates no colour the neighbourhood lacks.
pub fn sharpen(b: &LinearImage, s: f64) -> LinearImage {
    if s == 0.0 {
        return b.clone();
    }
    let w = b.width as usize;
    let mut out = vec![[0.0f64; 3]; b.pixel_count()];
    out.par_chunks_mut(w).enumerate().for_each(|(j, row)| {
        for (i, o) in row.iter_mut().enumerate() {
            let (x, y) = (i as i64, j as i64);
            let at = |dx, dy| clamped(b, x + dx, y + dy);
            let (c, n, so, e, we) = (at(0, 0), at(0, -1), at(0, 1), at(1, 0), at(-1, 0));
            for k in 0..3 {
                let lap = 4.0 * c[k] - n[k] - so[k] - e[k] - we[k];
                let lo = c[k].min(n[k]).min(so[k]).min(e[k]).min(we[k]);
                let hi = c[k].max(n[k]).max(so[k]).max(e[k]).max(we[k]);
                o[k] = (c[k] + s * lap).clamp(lo, hi);
            }
        }
    });
    Image {
        width: b.width,
        height: b.height,
        pixels: out,
    }
}

#[cfg(test)]
mod tests;
