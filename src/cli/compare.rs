//! `tonegate compare`: the metrics of two images, 8-bit or 16-bit PQ frame
//! PNGs or linear HDR files, named as FLIP's tool names them or by position.

use super::{invalid, write_json};
use clap::Args;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use tonegate::error::Result;
use tonegate::metrics::hdr_flip::FlipToneCurve;

#[derive(Args)]
pub struct CompareArgs {
    /// The image under test (positional form: the first image).
    #[arg(value_name = "TEST")]
    pub test_at: Option<PathBuf>,
    /// The reference (positional form: the second image).
    #[arg(value_name = "REFERENCE")]
    pub reference_at: Option<PathBuf>,
    /// The reference image (FLIP's -r): HDR-FLIP's exposures come from it.
    #[arg(short = 'r', long)]
    pub reference: Option<PathBuf>,
    /// The image under test (FLIP's -t).
    #[arg(short = 't', long)]
    pub test: Option<PathBuf>,
    /// Write the per-pixel SSIM map as a greyscale PNG (PU21-SSIM's for HDR inputs).
    #[arg(long)]
    pub ssim_map: Option<PathBuf>,
    /// Write a heat map of the absolute differences (8-bit inputs).
    #[arg(long)]
    pub diff: Option<PathBuf>,
    /// Write the FLIP error map (HDR-FLIP's for HDR inputs), magma-coloured.
    #[arg(long)]
    pub flip_map: Option<PathBuf>,
    /// FLIP's pixels per degree (default: a 0.7 m wide 4K display at 0.7 m, 67.02).
    #[arg(long)]
    pub ppd: Option<f64>,
    /// HDR inputs: the display peak in cd/m² that 1.0 maps to (PU21, delta E
    /// ITP; default 100).
    #[arg(long)]
    pub peak: Option<f64>,
    /// HDR-FLIP's tone mapper: aces (the default), hable or reinhard.
    #[arg(long, value_parser = super::by_name::<FlipToneCurve>)]
    pub tone_mapper: Option<FlipToneCurve>,
    /// HDR-FLIP's first exposure in stops (default: from the reference's maximum).
    #[arg(long, allow_hyphen_values = true)]
    pub start_exposure: Option<f64>,
    /// HDR-FLIP's last exposure in stops (default: from the reference's median).
    #[arg(long, allow_hyphen_values = true)]
    pub stop_exposure: Option<f64>,
    /// HDR-FLIP's number of exposures (default: one a stop, at least 2).
    #[arg(long)]
    pub exposures: Option<u32>,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

#[derive(serde::Serialize)]
struct LdrComparison<'p> {
    /// Which file was which, as the command understood its arguments.
    test: &'p Path,
    reference: &'p Path,
    #[serde(flatten)]
    metrics: tonegate::metrics::Metrics,
    flip: tonegate::metrics::flip::FlipStats,
    flip_definition: String,
}

fn is_png(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("png"))
}

impl CompareArgs {
    /// (test, reference), from the flags or the positions: a reference
    /// given by flag with one image by position makes that image the test.
    fn pair(&self) -> Result<(PathBuf, PathBuf)> {
        let mut positional = [&self.test_at, &self.reference_at]
            .into_iter()
            .flatten()
            .cloned();
        let test = self.test.clone().or_else(|| positional.next());
        let reference = self.reference.clone().or_else(|| positional.next());
        let extra = positional.next();
        match (test, reference, extra) {
            (Some(t), Some(r), None) => Ok((t, r)),
            (_, _, Some(extra)) => Err(invalid(format!(
                "{} is one image too many: give the test and the reference once each",
                extra.display()
            ))),
            _ => Err(invalid(
                "compare needs two images: -t TEST -r REFERENCE, or TEST REFERENCE by position",
            )),
        }
    }
}

pub fn compare(a: CompareArgs) -> Result<ExitCode> {
    let (test, reference) = a.pair()?;
    match (is_png(&test), is_png(&reference)) {
        (true, true) => compare_ldr(&a, &test, &reference),
        (false, false) => compare_hdr(&a, &test, &reference),
        _ => Err(invalid(format!(
            "{} and {} are not of one kind: compare two frame PNGs (8-bit, or 16-bit PQ) or two linear HDR files (.exr, .hdr, .pfm)",
            test.display(),
            reference.display()
        ))),
    }
}

fn compare_ldr(a: &CompareArgs, test: &Path, reference: &Path) -> Result<ExitCode> {
    use tonegate::image::Frame;
    // The HDR options mean nothing for frames: say so rather than seem to
    // apply them.
    let hdr_only: Vec<&str> = [
        (a.peak.is_some(), "--peak"),
        (a.tone_mapper.is_some(), "--tone-mapper"),
        (a.start_exposure.is_some(), "--start-exposure"),
        (a.stop_exposure.is_some(), "--stop-exposure"),
        (a.exposures.is_some(), "--exposures"),
    ]
    .iter()
    .filter(|(given, _)| *given)
    .map(|(_, name)| *name)
    .collect();
    if !hdr_only.is_empty() {
        eprintln!(
            "note: {} ignored: they set the HDR metrics, and {} and {} are frame PNGs",
            hdr_only.join(", "),
            test.display(),
            reference.display()
        );
    }
    use tonegate::metrics::{compare_frames, frame_diff_heatmap, frame_ssim};
    // 8-bit frames, or 16-bit PQ ones (a PQ scene's goldens and artifacts).
    let frame_a = tonegate::io::read_frame_png(test)?;
    let frame_b = tonegate::io::read_frame_png(reference)?;
    let (mut m, default_flip) = compare_frames(&frame_a, &frame_b)?;
    let mut flip_definition = tonegate::metrics::FLIP_DEFINITION.to_owned();
    let flip = match (a.ppd, &frame_a, &frame_b) {
        (None, ..) => default_flip,
        (Some(ppd), Frame::Rgb8(x), Frame::Rgb8(y)) => {
            // Every figure that says FLIP is at the asked distance: the
            // metrics' flip_mean and the definition too, not only the map.
            let flip = tonegate::metrics::flip::flip(x.raster(), y.raster(), ppd)?;
            m.flip_mean = flip.mean();
            flip_definition = flip_definition.replace(
                "at 67.02 pixels per degree (a 0.7 m wide 4K display seen from 0.7 m)",
                &format!("at {ppd} pixels per degree (compare --ppd)"),
            );
            flip
        }
        (Some(_), ..) => {
            return Err(invalid(
                "--ppd sets LDR FLIP's viewing distance; 16-bit PQ frames are compared with HDR-FLIP at its default",
            ))
        }
    };
    if let Some(path) = &a.ssim_map {
        let s = frame_ssim(&frame_a, &frame_b)?;
        tonegate::io::write_png8(path, &tonegate::metrics::ssim_map_image(&s))?;
    }
    if let Some(path) = &a.diff {
        tonegate::io::write_png8(path, &frame_diff_heatmap(&frame_a, &frame_b)?)?;
    }
    if let Some(path) = &a.flip_map {
        tonegate::io::write_png8(path, &flip.magma_image())?;
    }
    let stats = flip.stats();
    if a.json {
        let report = LdrComparison {
            test,
            reference,
            metrics: m,
            flip: stats,
            flip_definition,
        };
        write_json(Path::new("-"), "the metrics", &report)?;
    } else {
        println!("{m}");
        println!(
            "FLIP at {:.2} ppd: mean {:.5}, median {:.5}, max {:.5}, weighted quartiles {:.5} / {:.5} / {:.5}",
            stats.ppd,
            stats.mean,
            stats.median,
            stats.max,
            stats.weighted_quartiles[0],
            stats.weighted_quartiles[1],
            stats.weighted_quartiles[2]
        );
    }
    Ok(ExitCode::SUCCESS)
}

fn compare_hdr(a: &CompareArgs, test: &Path, reference: &Path) -> Result<ExitCode> {
    use tonegate::metrics::hdr::{compare_hdr, HdrOptions};
    use tonegate::metrics::hdr_flip::HdrFlipOptions;
    if a.diff.is_some() {
        return Err(invalid(
            "--diff is the 8-bit difference heat map; for HDR inputs use --flip-map or --ssim-map",
        ));
    }
    let load = tonegate::io::LoadOptions::default();
    let (img_a, _) = tonegate::io::load_hdr(test, &load)?;
    let (img_b, _) = tonegate::io::load_hdr(reference, &load)?;
    let opts = HdrOptions {
        peak: a.peak.unwrap_or(tonegate::metrics::pu21::DEFAULT_PEAK),
        flip: HdrFlipOptions {
            ppd: a.ppd.unwrap_or(tonegate::metrics::flip::DEFAULT_PPD),
            tone_mapper: a.tone_mapper.unwrap_or(FlipToneCurve::Aces),
            start: a.start_exposure,
            stop: a.stop_exposure,
            exposures: a.exposures,
        },
    };
    let c = compare_hdr(&img_a, &img_b, &opts)?;
    if let Some(path) = &a.flip_map {
        tonegate::io::write_png8(path, &c.flip.magma_image())?;
    }
    if let Some(path) = &a.ssim_map {
        tonegate::io::write_png8(path, &tonegate::metrics::ssim_map_image(&c.pu21.ssim))?;
    }
    let m = &c.metrics;
    if a.json {
        #[derive(serde::Serialize)]
        struct HdrComparison<'p> {
            test: &'p Path,
            reference: &'p Path,
            #[serde(flatten)]
            metrics: &'p tonegate::metrics::hdr::HdrMetrics,
        }
        let report = HdrComparison {
            test,
            reference,
            metrics: m,
        };
        write_json(Path::new("-"), "the HDR metrics", &report)?;
    } else {
        println!(
            "PU21-PSNR {:.4} dB  PU21-SSIM {:.6}  delta E ITP mean {:.4} max {:.4}  (1.0 = {} cd/m2)",
            m.pu21_psnr, m.pu21_ssim, m.delta_e_itp_mean, m.delta_e_itp_max, m.peak
        );
        let r = &m.hdr_flip_exposures;
        println!(
            "HDR-FLIP mean {:.5}, median {:.5}, max {:.5} over {} exposures {:.3} .. {:.3} stops ({:?})",
            m.hdr_flip.mean, m.hdr_flip.median, m.hdr_flip.max, r.count, r.start, r.stop, r.tone_mapper
        );
    }
    Ok(ExitCode::SUCCESS)
}
