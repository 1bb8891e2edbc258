//! Images a person looks at when a gate fails: the SSIM map and a difference
//! heat map (the `…-ssim.png` and `…-diff.png` artifacts).

use super::raster::{check_pair, Raster};
use super::ssim::Ssim;
use super::MetricsError;
use crate::image::Rgb8Image;

/// The SSIM map as grey: each pixel is round(clamp(S, 0, 1) · 255), so white
/// means structurally identical and black means S ≤ 0 (no, or inverted,
/// structure). Negative S is clamped because a grey level cannot say "less
/// than unrelated" usefully, and mid-grey must keep meaning S = 0.5.
pub fn ssim_map_image(ssim: &Ssim) -> Rgb8Image {
    ssim.map.map(|s| {
        let level = (s.clamp(0.0, 1.0) * 255.0).round() as u8;
        [level; 3]
    })
}

/// Stops of the heat-map ramp: (difference in LSB, colour). Between stops the
/// colour is interpolated linearly in the difference and rounded.
///
/// The stops are spaced roughly geometrically because the differences that
/// matter for a regression gate are small: a single LSB already shows as dark
/// blue on the black background, rounding-level noise (≤ 4 LSB) as blue, and
/// green → yellow → red mark 16, 64 and 255 LSB.
pub const HEATMAP_RAMP: [(u8, [u8; 3]); 6] = [
    (0, [0, 0, 0]),
    (1, [0, 0, 150]),
    (4, [0, 120, 255]),
    (16, [0, 200, 0]),
    (64, [255, 220, 0]),
    (255, [255, 0, 0]),
];

/// The colour [`HEATMAP_RAMP`] gives a difference of `d` LSB.
pub fn heatmap_colour(d: u8) -> [u8; 3] {
    let upper = HEATMAP_RAMP
        .iter()
        .position(|&(stop, _)| stop >= d)
        .unwrap_or(HEATMAP_RAMP.len() - 1);
    if upper == 0 {
        return HEATMAP_RAMP[0].1;
    }
    let (d0, c0) = HEATMAP_RAMP[upper - 1];
    let (d1, c1) = HEATMAP_RAMP[upper];
    let t = f64::from(d - d0) / f64::from(d1 - d0);
    std::array::from_fn(|i| {
        (f64::from(c0[i]) + t * (f64::from(c1[i]) - f64::from(c0[i]))).round() as u8
    })
}

/// Per-pixel difference heat map: the largest absolute channel difference of
/// each pixel through [`HEATMAP_RAMP`]; black means identical.
pub fn diff_heatmap(test: Raster, reference: Raster) -> Result<Rgb8Image, MetricsError> {
    check_pair(&test, &reference)?;
    let lut: [[u8; 3]; 256] = std::array::from_fn(|d| heatmap_colour(d as u8));
    let channels = test.channels;
    let pixels = test
        .samples
        .chunks_exact(channels)
        .zip(reference.samples.chunks_exact(channels))
        .map(|(t, r)| {
            let d = t.iter().zip(r).map(|(&a, &b)| a.abs_diff(b)).max();
            lut[usize::from(d.unwrap_or(0))]
        })
        .collect();
    Ok(Rgb8Image {
        width: test.width,
        height: test.height,
        pixels,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::Image;

    #[test]
    fn ramp_hits_its_stops_and_is_black_only_at_zero() {
        for (d, colour) in HEATMAP_RAMP {
            assert_eq!(heatmap_colour(d), colour, "stop {d}");
        }
        assert!((1..=255).all(|d| heatmap_colour(d) != [0, 0, 0]));
        // Halfway between 16 (green) and 64 (yellow).
        assert_eq!(heatmap_colour(40), [128, 210, 0]);
    }

    #[test]
    fn heatmap_uses_the_largest_channel_difference() {
        let reference = [10u8, 10, 10, 50, 50, 50];
        let test = [10u8, 10, 10, 51, 46, 50];
        let t = Raster::new(2, 1, 3, &test).unwrap();
        let r = Raster::new(2, 1, 3, &reference).unwrap();
        let img = diff_heatmap(t, r).unwrap();
        assert_eq!(img.pixels, vec![[0, 0, 0], heatmap_colour(4)]);
        let other = Raster::new(1, 2, 3, &reference).unwrap();
        assert!(diff_heatmap(t, other).is_err());
    }

    #[test]
    fn ssim_map_image_clamps_and_rounds() {
        let ssim = Ssim {
            mean: 0.0,
            map: Image {
                width: 4,
                height: 1,
                pixels: vec![1.0, 0.5, -0.3, 0.999],
            },
        };
        let img = ssim_map_image(&ssim);
        assert_eq!(
            img.pixels,
            vec![[255; 3], [128; 3], [0; 3], [255; 3]],
            "0.5·255 = 127.5 rounds away from zero"
        );
    }
}
