//! Tone-mapping one flat HDR image: the job behind `tonegate tonemap` and
//! `POST /tonemap`. The caller says what it wants back ([`OutputKind`]) and
//! on what ([`RendererPool`] or the CPU reference); the job picks the path:
//! the pixelwise plan wherever the stage plan is statistics and `tonemap`
//! alone (on the CPU, for every output), the staged reference otherwise, or
//! the GPU. Its [`ToneReport`] is what both callers serialise.

pub mod display;
mod operator_params;
pub mod settings;

pub use display::{Display, HdrOutput, HdrReport};
pub use operator_params::OperatorParams;
pub use settings::{Preset, Resolved, ToneSettings};

use crate::error::{Error, Result};
#[cfg(feature = "gpu")]
use crate::gpu::{GpuConfig, GpuContext, RendererPool};
use crate::image::{HdrImage, Rgb8Image};
use crate::io::LoadReport;
#[cfg(feature = "gpu")]
use crate::plan::StagePlan;
use crate::reference::luminance_stats::LuminanceStats;
use crate::reference::tonemap::ToneParams;
#[cfg(feature = "gpu")]
use crate::reference::Pipeline;
use crate::reference::PixelwiseTone;
use serde::Serialize;
use std::path::Path;

/// What a tone-map hands back.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum OutputKind {
    /// The encoded 8-bit frame (a PNG).
    Encoded,
    /// The linear display-referred image, before the encoding (an HDR file:
    /// OpenEXR, Radiance or PFM).
    Linear,
    /// The 16-bit PQ or HLG image (a PNG with its cICP chunk).
    Hdr(HdrOutput),
}

impl OutputKind {
    /// What a file of this name holds: `.png` the encoded frame; `.exr`,
    /// `.hdr` and `.pfm` the linear image.
    pub fn of_path(path: &Path) -> Result<OutputKind> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        match ext.as_str() {
            "png" => Ok(OutputKind::Encoded),
            "exr" | "hdr" | "pfm" => Ok(OutputKind::Linear),
            _ => Err(Error::Invalid(format!(
                "{}: the output must be .png (encoded), or .exr, .hdr or .pfm (linear)",
                path.display()
            ))),
        }
    }
}

/// Which way the job went.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TonePath {
    /// The CPU reference a pixel at a time from the input: statistics and
    /// `tonemap` alone, the staged path's bits without its full-frame copies.
    Pixelwise,
    /// The CPU reference stage by stage (bloom or grade in the plan).
    Staged,
    /// The GPU pipeline.
    Gpu,
}

/// What a tone-map did: with the input's [`LoadReport`], the `tonemap`
/// command's `--json` and the API's answer (and its `X-Tonegate-*`
/// headers), both through [`FileReport`].
#[derive(Clone, Debug, Serialize)]
pub struct ToneReport {
    /// The adapter's name, or `cpu-reference`.
    pub adapter: String,
    pub path: TonePath,
    /// The stages that ran.
    pub plan: Vec<&'static str>,
    pub stats: LuminanceStats,
    pub tone: ToneParams,
    /// The PQ or HLG output, when that is what was made.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hdr: Option<HdrReport>,
}

/// A decoded file's tone-map, as the command line and the API report it.
#[derive(Serialize)]
pub struct FileReport<'a> {
    /// What the decoder found in the input.
    pub input: &'a LoadReport,
    #[serde(flatten)]
    pub toned: &'a ToneReport,
}

/// The tone-mapped image, in the form the job made it.
pub enum TonedImage<'i> {
    /// The encoded 8-bit frame.
    Encoded(Rgb8Image),
    /// The linear display image, narrowed to f32 as an HDR file stores it.
    Linear(HdrImage),
    /// The linear display image of the pixelwise path, computed from the
    /// input as it is written: a PFM is streamed a band of rows at a time.
    Mapped {
        tone: Box<PixelwiseTone>,
        input: &'i HdrImage,
    },
    /// The 16-bit PQ or HLG image and the chunks that say so.
    Hdr(crate::io::Rgb16Image, crate::io::HdrPngInfo),
}

impl TonedImage<'_> {
    /// Writes the image to `path` in the format its extension names.
    pub fn write(&self, path: &Path) -> Result<()> {
        let kind = OutputKind::of_path(path)?;
        let pfm = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("pfm"));
        match (self, kind) {
            (TonedImage::Encoded(frame), OutputKind::Encoded) => {
                Ok(crate::io::write_png8(path, frame)?)
            }
            (TonedImage::Hdr(img, info), OutputKind::Encoded) => {
                Ok(crate::io::write_hdr_png(path, img, info)?)
            }
            (TonedImage::Linear(img), OutputKind::Linear) => {
                Ok(crate::io::write_image_hdr(path, img)?)
            }
            // A PFM streams the pixelwise display values a band at a time.
            (TonedImage::Mapped { tone, input }, OutputKind::Linear) if pfm => {
                Ok(crate::io::write_pfm_mapped(path, input, |c| tone.map(c))?)
            }
            (TonedImage::Mapped { .. }, OutputKind::Linear) => match self.linear() {
                Some(display) => Ok(crate::io::write_image_hdr(path, &display)?),
                None => Err(self.wrong_kind(path)),
            },
            _ => Err(self.wrong_kind(path)),
        }
    }

    /// The encoded frame, when that is what the job made.
    pub fn encoded(&self) -> Option<&Rgb8Image> {
        match self {
            TonedImage::Encoded(frame) => Some(frame),
            _ => None,
        }
    }

    /// The linear display image, computed now if the job left it to be
    /// computed as it is written; None for an encoded frame.
    pub fn linear(&self) -> Option<std::borrow::Cow<'_, HdrImage>> {
        match self {
            TonedImage::Encoded(_) | TonedImage::Hdr(..) => None,
            TonedImage::Linear(img) => Some(std::borrow::Cow::Borrowed(img)),
            TonedImage::Mapped { tone, input } => {
                Some(std::borrow::Cow::Owned(input.par_map(|c| tone.map(c))))
            }
        }
    }

    fn wrong_kind(&self, path: &Path) -> Error {
        Error::Invalid(format!(
            "{}: this tone-map made {} image; ask for the output kind the file needs",
            path.display(),
            match self {
                TonedImage::Encoded(_) => "an encoded 8-bit",
                TonedImage::Hdr(..) => "a 16-bit HDR",
                _ => "a linear",
            }
        ))
    }
}

/// A tone-mapped flat image and what was done to make it.
pub struct Toned<'i> {
    pub report: ToneReport,
    pub image: TonedImage<'i>,
}

#[cfg(feature = "gpu")]
/// Tone-maps `img` into `want` with the CPU reference, or on the GPU when a
/// context is given: one image, so the GPU's textures have its own size and
/// nothing is kept.
pub fn tone_map<'i>(
    img: &'i HdrImage,
    pipeline: &Pipeline,
    gpu: Option<(&GpuContext, GpuConfig)>,
    want: OutputKind,
) -> Result<Toned<'i>> {
    let mut kept = gpu.map(|(ctx, config)| (RendererPool::new(ctx).exact_sizes(), config));
    let gpu = kept.as_mut().map(|(r, config)| (r, *config));
    tone_map_until(img, pipeline, gpu, want, &|| false)?
        .ok_or_else(|| Error::Invalid("the tone-map stopped before its end".into()))
}

#[cfg(feature = "gpu")]
/// [`tone_map`] on renderers kept between images (a server's GPU worker),
/// asking `stop` between stages (the CPU reference) or before and after the
/// device's work (the GPU, which runs the plan in one submission): `None`
/// when it said stop.
pub fn tone_map_until<'i>(
    img: &'i HdrImage,
    pipeline: &Pipeline,
    gpu: Option<(&mut RendererPool, GpuConfig)>,
    want: OutputKind,
    stop: &dyn Fn() -> bool,
) -> Result<Option<Toned<'i>>> {
    // PQ and HLG are encoded here from the display-referred image, whichever
    // renderer made it.
    if let OutputKind::Hdr(hdr) = want {
        let Some(toned) = tone_map_until(img, pipeline, gpu, OutputKind::Linear, stop)? else {
            return Ok(None);
        };
        let display = toned
            .image
            .linear()
            .ok_or_else(|| Error::Invalid("the tone-map made no display image".into()))?;
        let (image, info, hdr_report) = hdr.encode(&display);
        drop(display);
        let mut report = toned.report;
        report.hdr = Some(hdr_report);
        return Ok(Some(Toned {
            report,
            image: TonedImage::Hdr(image, info),
        }));
    }
    let report = |adapter: String, path, plan: &StagePlan, stats, tone| ToneReport {
        adapter,
        path,
        plan: plan.names(),
        stats,
        tone,
        hdr: None,
    };
    let cpu = crate::render::CPU_REFERENCE.to_owned();
    match gpu {
        Some(_) if stop() => Ok(None),
        Some((renderers, config)) => {
            let adapter = renderers.ctx().adapter.name.clone();
            let gpu = gpu_flat(img, pipeline, renderers, config, want)?;
            Ok((!stop()).then(|| Toned {
                report: report(adapter, TonePath::Gpu, &gpu.plan, gpu.stats, gpu.tone),
                image: gpu.image,
            }))
        }
        None => {
            if let Some(t) = crate::reference::pixelwise_tone(img, pipeline) {
                let t = t?;
                if stop() {
                    return Ok(None);
                }
                let toned = match want {
                    OutputKind::Encoded => {
                        let plan = StagePlan::build(
                            crate::plan::Input::Flat,
                            pipeline.operator,
                            pipeline.bloom,
                            pipeline.grade,
                        );
                        let frame = t.frame(img, pipeline.encoding);
                        Toned {
                            report: report(
                                cpu,
                                TonePath::Pixelwise,
                                &plan,
                                t.stats,
                                t.tone.params.clone(),
                            ),
                            image: TonedImage::Encoded(frame),
                        }
                    }
                    OutputKind::Linear | OutputKind::Hdr(_) => Toned {
                        report: report(
                            cpu,
                            TonePath::Pixelwise,
                            &t.plan,
                            t.stats,
                            t.tone.params.clone(),
                        ),
                        image: TonedImage::Mapped {
                            tone: Box::new(t),
                            input: img,
                        },
                    },
                };
                return Ok(Some(toned));
            }
            match want {
                OutputKind::Linear | OutputKind::Hdr(_) => {
                    let out = crate::reference::render_flat_display_until(img, pipeline, stop)?;
                    Ok(out.map(|out| Toned {
                        report: report(cpu, TonePath::Staged, &out.plan, out.stats, out.tone),
                        image: TonedImage::Linear(out.display),
                    }))
                }
                OutputKind::Encoded => {
                    let out = crate::reference::render_flat_until(img, pipeline, stop)?;
                    out.map(|(plan, out)| {
                        Ok(Toned {
                            report: report(cpu, TonePath::Staged, &plan, out.stats, out.tone),
                            image: TonedImage::Encoded(eight_bit(out.frame)?),
                        })
                    })
                    .transpose()
                }
            }
        }
    }
}

#[cfg(feature = "gpu")]
/// What the GPU made of a flat image.
struct GpuToned<'i> {
    plan: StagePlan,
    stats: LuminanceStats,
    tone: ToneParams,
    image: TonedImage<'i>,
}

#[cfg(feature = "gpu")]
fn gpu_flat<'i>(
    img: &HdrImage,
    pipeline: &Pipeline,
    renderers: &mut RendererPool,
    config: GpuConfig,
    want: OutputKind,
) -> Result<GpuToned<'i>> {
    let plan = StagePlan::build(
        crate::plan::Input::Flat,
        pipeline.operator,
        pipeline.bloom,
        pipeline.grade,
    );
    // The display image is a staged output: fused kernels never store it.
    // An output that keeps it (HDR, or a linear file) needs no `encode`.
    let mut config = config;
    let plan = if want == OutputKind::Encoded {
        plan
    } else {
        config.execution = crate::gpu::Execution::Staged;
        plan.without_encode()
    };
    let rendered = renderers
        .renderer(img, &plan, pipeline, config)
        .and_then(|r| {
            let out = r.render(want == OutputKind::Encoded)?;
            let display = match want {
                OutputKind::Linear | OutputKind::Hdr(_) => Some(
                    r.read_output("display")?
                        .map(|d| d.to_hdr())
                        .unwrap_or_else(|| img.clone()),
                ),
                OutputKind::Encoded => None,
            };
            Ok((out, display))
        });
    // Whatever the outcome, a renderer over the budget is not kept.
    renderers.release_oversize();
    let (out, display) = rendered?;
    let s = out.stats;
    let tone = pipeline.operator.gpu_resolved(s.tone);

    let image = match (display, out.frame) {
        (Some(display), _) => TonedImage::Linear(display),
        (None, Some(frame)) => TonedImage::Encoded(eight_bit(frame)?),
        (None, None) => {
            return Err(crate::gpu::GpuError::Readback("the frame was not read back".into()).into())
        }
    };
    Ok(GpuToned {
        plan,
        stats: s.luminance_stats(),
        tone,
        image,
    })
}

#[cfg(feature = "gpu")]
/// A tone-map's encoded frame, which its settings make 8-bit (PQ and HLG
/// files are encoded from the display image instead).
fn eight_bit(frame: crate::image::Frame) -> Result<Rgb8Image> {
    let kind = frame.kind();
    frame.into_rgb8().ok_or_else(|| {
        Error::Invalid(format!(
            "the tone-map made a {kind} frame where an 8-bit one was asked for"
        ))
    })
}
