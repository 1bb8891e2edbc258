//! HDR output (docs/display.md#hdr-output): an operator that maps onto a
//! display of known black and peak (`bt2390`) can be written for a PQ or
//! HLG display as well as encoded for SDR. The display-relative output is
//! taken back to cd/m² on that display, converted from BT.709 (tonegate's
//! working primaries) to BT.2020 (BT.2100's), encoded with PQ or HLG and
//! quantised to 16 bits, in a PNG whose cICP chunk says so (with mDCV and
//! cLLI for PQ).

use crate::color::{bt709_to_bt2020, hlg_inverse_eotf, pq_encode, Mat3, BT709_XY, D65_XY};
use crate::image::HdrImage;
use crate::io::{Cicp, HdrPngInfo, LightLevel, Mastering, Rgb16Image};
use crate::operators::{DisplayLevels, Operator};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// The display a tone-map is encoded for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Display {
    /// An 8-bit PNG with the scene's encoding (the sRGB transfer, or a
    /// gamma): every operator.
    #[default]
    Sdr,
    /// A 16-bit PNG, BT.2020 primaries, SMPTE ST 2084 (PQ), absolute cd/m².
    Pq,
    /// A 16-bit PNG, BT.2020 primaries, HLG, for a display of the
    /// operator's peak (and black 0).
    Hlg,
}

impl Display {
    /// Its name as flags and the API spell it.
    pub fn as_str(self) -> &'static str {
        match self {
            Display::Sdr => "sdr",
            Display::Pq => "pq",
            Display::Hlg => "hlg",
        }
    }

    /// The HDR output of `operator` for this display; `None` for SDR, and an
    /// error saying why for a combination that has no meaning.
    pub fn hdr_output(self, operator: &Operator) -> Result<Option<HdrOutput>, String> {
        if self == Display::Sdr {
            return Ok(None);
        }
        let Some(levels) = operator.display_levels() else {
            let able: Vec<&str> = crate::operators::all()
                .into_iter()
                .filter(|d| {
                    crate::operators::Operator::with(d.clone(), &[])
                        .is_ok_and(|o| o.display_levels().is_some())
                })
                .map(|d| d.name())
                .collect();
            return Err(format!(
                "display {}: operator {}'s output is relative to an SDR display's white, with no absolute level to encode; operators that map onto a display of known peak: {}",
                self.as_str(),
                operator.name(),
                able.join(", ")
            ));
        };
        if self == Display::Hlg && levels.black > 0.0 {
            return Err(format!(
                "display hlg: HLG output is for a display black of 0 cd/m², and the operator maps onto a black of {} cd/m²; use display pq, or a black of 0",
                levels.black
            ));
        }
        Ok(Some(HdrOutput {
            display: self,
            levels,
        }))
    }
}

/// A PQ or HLG output: the display and the levels of the display the
/// operator maps onto.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HdrOutput {
    /// `Pq` or `Hlg`.
    pub display: Display,
    /// The operator's display: its output 0 and 1 in cd/m².
    pub levels: DisplayLevels,
}

/// What an HDR output was, for reports.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct HdrReport {
    pub display: Display,
    /// The display's black and peak, cd/m².
    pub black_nits: f64,
    pub peak_nits: f64,
    /// CTA-861.3's MaxCLL and MaxFALL of the image, cd/m² (BT.2020 RGB).
    pub max_cll: f64,
    pub max_fall: f64,
}

pub use crate::color::code16;

impl HdrOutput {
    /// One display-relative BT.709 pixel as BT.2020 light on the display,
    /// cd/m² ([`DisplayLevels::bt2020_nits`]).
    pub fn nits(&self, m: &Mat3, c: [f64; 3]) -> [f64; 3] {
        self.levels.bt2020_nits(m, c)
    }

    /// The signal (in [0, 1]) of BT.2020 light `nits` on this display.
    pub fn signal(&self, nits: [f64; 3]) -> [f64; 3] {
        match self.display {
            Display::Hlg => hlg_inverse_eotf(nits, self.levels.peak),
            _ => nits.map(pq_encode),
        }
    }

    /// The 16-bit image and its PNG chunks, from the operator's
    /// display-relative output.
    pub fn encode(&self, display: &HdrImage) -> (Rgb16Image, HdrPngInfo, HdrReport) {
        const CHUNK: usize = 4096;
        let m = bt709_to_bt2020();
        let mut pixels = vec![[0u16; 3]; display.pixels.len()];
        // Each chunk's brightest channel and sum of brightest channels, in
        // order, so that MaxFALL's sum is the same on every run.
        let levels: Vec<(f64, f64)> = pixels
            .par_chunks_mut(CHUNK)
            .zip(display.pixels.par_chunks(CHUNK))
            .map(|(out, input)| {
                let (mut max, mut sum) = (0.0f64, 0.0f64);
                for (o, p) in out.iter_mut().zip(input) {
                    let nits = self.nits(&m, p.map(f64::from));
                    *o = self.signal(nits).map(code16);
                    let brightest = nits[0].max(nits[1]).max(nits[2]);
                    max = max.max(brightest);
                    sum += brightest;
                }
                (max, sum)
            })
            .collect();
        let max_cll = levels.iter().map(|l| l.0).fold(0.0, f64::max);
        let max_fall = levels.iter().map(|l| l.1).sum::<f64>() / display.pixels.len().max(1) as f64;
        let image = Rgb16Image {
            width: display.width,
            height: display.height,
            pixels,
        };
        // mDCV and cLLI describe PQ's absolute light; an HLG display scales
        // the signal to its own peak, so only cICP is written for it.
        let pq = self.display == Display::Pq;
        let info = HdrPngInfo {
            cicp: if pq {
                Cicp::BT2100_PQ
            } else {
                Cicp::BT2100_HLG
            },
            // The display the operator mapped onto; its primaries are taken
            // as BT.709's, the gamut tonegate's output stays within.
            mastering: pq.then_some(Mastering {
                primaries: BT709_XY,
                white: D65_XY,
                max_nits: self.levels.peak,
                min_nits: self.levels.black,
            }),
            light_level: pq.then_some(LightLevel { max_cll, max_fall }),
        };
        let report = HdrReport {
            display: self.display,
            black_nits: self.levels.black,
            peak_nits: self.levels.peak,
            max_cll,
            max_fall,
        };
        (image, info, report)
    }
}
