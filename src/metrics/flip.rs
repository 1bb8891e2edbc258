//! FLIP (Andersson et al. 2020): NVIDIA's perceptual difference of two 8-bit
//! sRGB images as seen from `ppd` pixels per degree, computed by NVIDIA's own
//! C++ implementation through the `nv-flip` crate, not a port.
//!
//! The crate's FLIP runs on one thread; a frame is cut into bands of rows,
//! each given the rows its filters reach into as a halo, and the bands run in
//! parallel. FLIP's filters clamp at the image edge, so a band's own rows see
//! exactly the neighbours they see in the whole image: the map is the same,
//! bit for bit (tested), on any number of threads.

use super::raster::{check_pair, Raster};
use super::MetricsError;
use crate::image::{Image, Rgb8Image};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// FLIP's default viewing condition, a 0.7 m wide 4K display seen from 0.7 m:
/// `calculatePPD(0.7, 3840, 0.7)` as NVIDIA's tool computes it (in f32).
/// (nv-flip's own constant rounds it to 67.)
pub const DEFAULT_PPD: f64 = 67.020_645_141_601_56;

/// Rows per parallel band (before the halo): large enough that the halo's
/// repeated work stays small, small enough that a Full HD frame keeps both
/// cores busy.
const BAND_ROWS: u32 = 128;

/// How far (in pixels) FLIP's filters reach at `ppd`: the larger of the
/// colour pipeline's spatial filter, ceil(3·√(max b / 2π²)·ppd) with
/// max b = 0.04, and the feature detectors' Gaussian, ceil(3·0.5·0.082·ppd)
/// (FLIP's constants, sharedflip.h), plus one row of margin.
fn filter_reach(ppd: f64) -> u32 {
    let spatial = (3.0 * (0.04 / (2.0 * std::f64::consts::PI.powi(2))).sqrt() * ppd).ceil();
    let feature = (3.0 * 0.5 * 0.082 * ppd).ceil();
    spatial.max(feature) as u32 + 1
}

/// The per-pixel FLIP map of two images with its pooled statistics.
#[derive(Clone, Debug)]
pub struct Flip {
    /// FLIP error per pixel, in [0, 1].
    pub map: Image<f32>,
    /// The pixels per degree it was computed at.
    pub ppd: f64,
}

/// FLIP's statistics as reports carry them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FlipStats {
    /// Mean of the map (f64 sum): what FLIP's tool calls the FLIP error.
    pub mean: f64,
    /// Median of the map's values.
    pub median: f64,
    pub max: f64,
    /// FLIP's weighted quartiles (values weighted by themselves, from its
    /// 100-bucket histogram): 25th, 50th and 75th.
    pub weighted_quartiles: [f64; 3],
    pub ppd: f64,
}

impl Flip {
    /// The mean error.
    pub fn mean(&self) -> f64 {
        let sum: f64 = self.map.pixels.iter().map(|&v| f64::from(v)).sum();
        sum / self.map.pixels.len() as f64
    }

    /// FLIP's weighted percentile `p` (0..=1), as its tool reports the
    /// weighted median and quartiles. A map with no error at all has no
    /// weight to distribute: 0, where FLIP's histogram would answer a
    /// fraction of its first bucket's width.
    pub fn weighted_percentile(&self, p: f64) -> f64 {
        if self.map.pixels.iter().all(|&v| v == 0.0) {
            return 0.0;
        }
        self.pool().get_weighted_percentile(p.clamp(0.0, 1.0))
    }

    fn pool(&self) -> nv_flip::FlipPool {
        let image =
            nv_flip::FlipImageFloat::with_data(self.map.width, self.map.height, &self.map.pixels);
        nv_flip::FlipPool::from_image(&image)
    }

    /// Mean, median, maximum and weighted quartiles.
    pub fn stats(&self) -> FlipStats {
        let mut sorted = self.map.pixels.clone();
        sorted.sort_unstable_by(f32::total_cmp);
        let n = sorted.len();
        let median = if n % 2 == 1 {
            f64::from(sorted[n / 2])
        } else {
            0.5 * (f64::from(sorted[n / 2 - 1]) + f64::from(sorted[n / 2]))
        };
        FlipStats {
            mean: self.mean(),
            median,
            max: sorted.last().map(|&v| f64::from(v)).unwrap_or(0.0),
            weighted_quartiles: [0.25, 0.5, 0.75].map(|p| self.weighted_percentile(p)),
            ppd: self.ppd,
        }
    }

    /// The map coloured with FLIP's magma ramp (black = no difference), the
    /// way FLIP's tool shows it.
    pub fn magma_image(&self) -> Rgb8Image {
        let lut = nv_flip::magma_lut().to_vec();
        let pixels = self
            .map
            .pixels
            .iter()
            .map(|&v| {
                let i = (v.clamp(0.0, 1.0) * 255.0).round() as usize * 3;
                [lut[i], lut[i + 1], lut[i + 2]]
            })
            .collect();
        Rgb8Image {
            width: self.map.width,
            height: self.map.height,
            pixels,
        }
    }
}

/// Tightly packed RGB8 of rows `y0..y1` (grey replicated, alpha dropped).
fn rgb_rows(r: &Raster, y0: u32, y1: u32) -> Vec<u8> {
    let mut out = Vec::with_capacity((y1 - y0) as usize * r.width as usize * 3);
    let row = r.row_len();
    for y in y0..y1 {
        let line = &r.samples[y as usize * row..(y as usize + 1) * row];
        match r.channels {
            3 => out.extend_from_slice(line),
            1 => out.extend(line.iter().flat_map(|&v| [v, v, v])),
            _ => out.extend(
                line.chunks_exact(r.channels)
                    .flat_map(|p| [p[0], p[1], p[2]]),
            ),
        }
    }
    out
}

/// FLIP of `test` against `reference` (both 8-bit sRGB) at `ppd` pixels per
/// degree.
pub fn flip(test: Raster, reference: Raster, ppd: f64) -> Result<Flip, MetricsError> {
    check_pair(&test, &reference)?;
    if !(ppd.is_finite() && ppd > 0.0) {
        return Err(MetricsError::BadParameter {
            name: "ppd",
            detail: format!("pixels per degree must be a finite number > 0, got {ppd}"),
        });
    }
    let (width, height) = (test.width, test.height);
    let halo = filter_reach(ppd);
    let bands: Vec<u32> = (0..height).step_by(BAND_ROWS as usize).collect();
    let parts: Vec<Vec<f32>> = bands
        .par_iter()
        .map(|&y0| {
            let y1 = (y0 + BAND_ROWS).min(height);
            let (h0, h1) = (y0.saturating_sub(halo), (y1 + halo).min(height));
            let rows = h1 - h0;
            let t = nv_flip::FlipImageRgb8::with_data(width, rows, &rgb_rows(&test, h0, h1));
            let r = nv_flip::FlipImageRgb8::with_data(width, rows, &rgb_rows(&reference, h0, h1));
            let map = nv_flip::flip(r, t, ppd as f32).to_vec();
            let skip = (y0 - h0) as usize * width as usize;
            map[skip..skip + (y1 - y0) as usize * width as usize].to_vec()
        })
        .collect();
    Ok(Flip {
        map: Image {
            width,
            height,
            pixels: parts.concat(),
        },
        ppd,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(width: u32, height: u32, seed: u32) -> Vec<u8> {
        (0..width * height * 3)
            .map(|i| {
                let x = (i / 3) % width;
                let y = (i / 3) / width;
                let noise = (i.wrapping_mul(2654435761) ^ seed.wrapping_mul(0x9E37_79B9)) >> 27;
                ((x * 3 + y * 5 + (i % 3) * 40 + noise) % 256) as u8
            })
            .collect()
    }

    /// The whole image through nv-flip in one call.
    fn unbanded(test: &[u8], reference: &[u8], width: u32, height: u32, ppd: f64) -> Vec<f32> {
        let t = nv_flip::FlipImageRgb8::with_data(width, height, test);
        let r = nv_flip::FlipImageRgb8::with_data(width, height, reference);
        nv_flip::flip(r, t, ppd as f32).to_vec()
    }

    #[test]
    fn bands_give_the_whole_image_map_bit_for_bit() {
        for (width, height, ppd) in [(61, 300, DEFAULT_PPD), (40, 290, 120.0), (33, 257, 20.0)] {
            let a = frame(width, height, 1);
            let b = frame(width, height, 2);
            let ta = Raster::new(width, height, 3, &a).unwrap();
            let tb = Raster::new(width, height, 3, &b).unwrap();
            let banded = flip(ta, tb, ppd).unwrap();
            let whole = unbanded(&a, &b, width, height, ppd);
            assert!(banded.mean() > 0.001, "the pair differs: {}", banded.mean());
            assert!(
                banded
                    .map
                    .pixels
                    .iter()
                    .zip(&whole)
                    .all(|(x, y)| x.to_bits() == y.to_bits()),
                "{width}x{height} at {ppd} ppd: the banded map differs from the whole-image map"
            );
        }
    }

    #[test]
    fn identical_images_have_zero_error_and_statistics() {
        let a = frame(24, 20, 7);
        let r = Raster::new(24, 20, 3, &a).unwrap();
        let f = flip(r, r, DEFAULT_PPD).unwrap();
        let s = f.stats();
        assert_eq!((s.mean, s.median, s.max), (0.0, 0.0, 0.0));
        assert_eq!(s.weighted_quartiles, [0.0; 3]);
    }

    #[test]
    fn grey_and_rgba_are_compared_as_rgb() {
        let grey: Vec<u8> = (0..16 * 16).map(|i| (i * 7 % 256) as u8).collect();
        let grey2: Vec<u8> = grey.iter().map(|&v| v.saturating_add(20)).collect();
        let rgb: Vec<u8> = grey.iter().flat_map(|&v| [v, v, v]).collect();
        let rgb2: Vec<u8> = grey2.iter().flat_map(|&v| [v, v, v]).collect();
        let rgba2: Vec<u8> = grey2.iter().flat_map(|&v| [v, v, v, 9]).collect();
        let g = flip(
            Raster::new(16, 16, 1, &grey2).unwrap(),
            Raster::new(16, 16, 1, &grey).unwrap(),
            DEFAULT_PPD,
        )
        .unwrap();
        let c = flip(
            Raster::new(16, 16, 4, &rgba2).unwrap(),
            Raster::new(16, 16, 3, &rgb).unwrap(),
            DEFAULT_PPD,
        );
        // Channel counts must match, as for every metric.
        assert!(matches!(c, Err(MetricsError::ChannelMismatch { .. })));
        let c = flip(
            Raster::new(16, 16, 3, &rgb2).unwrap(),
            Raster::new(16, 16, 3, &rgb).unwrap(),
            DEFAULT_PPD,
        )
        .unwrap();
        assert_eq!(g.map.pixels, c.map.pixels);
        assert!(g.mean() > 0.0);
    }

    #[test]
    fn a_bad_ppd_is_an_error() {
        let a = frame(16, 16, 1);
        let r = Raster::new(16, 16, 3, &a).unwrap();
        for ppd in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(
                flip(r, r, ppd),
                Err(MetricsError::BadParameter { name: "ppd", .. })
            ));
        }
    }
}
