//! The CPU reference renderer: one function per stage, in f64, named as the
//! WGSL files and GPU passes are. `run_plan` executes a [`StagePlan`] and keeps
//! every stage's output so each can be compared with the GPU's on its own.

pub mod adaptation;
pub mod bloom_blur;
pub mod bloom_bright;
pub mod bloom_composite;
pub mod bloom_downsample;
pub mod encode;
pub mod grade;
pub mod grade_stats;
pub mod histogram;
pub mod luminance_stats;
#[cfg(feature = "reference")]
mod scene_frame;
pub mod sphere;
pub mod taa;
pub mod taa_sobel;
pub mod tonemap;

#[cfg(feature = "reference")]
pub use scene_frame::{render_carried_frame, render_frame, render_taa_frame, scene_camera};

use crate::image::{Frame, HdrImage, LinearImage, Rgb8Image};
use crate::operators::Operator;
use crate::operators::Tone;
use crate::plan::{BloomSource, PlanError, Stage, StagePlan};
#[cfg(feature = "reference")]
use crate::scene::Scene;
use crate::scene::{Bloom, Encoding, Grade, Metering};
use luminance_stats::LuminanceStats;
use serde::Serialize;
use tonemap::ToneParams;

/// Bump when any reference stage changes its output: the golden manifest
/// records it, and goldens of another version are stale.
pub const REFERENCE_VERSION: u32 = 1;

/// The parameters of the stages after `sphere`.
#[derive(Clone, Copy, Debug)]
pub struct Pipeline<'a> {
    pub operator: &'a Operator,
    pub bloom: Option<&'a Bloom>,
    pub grade: Option<&'a Grade>,
    pub encoding: Encoding,
}

impl<'a> Pipeline<'a> {
    #[cfg(feature = "reference")]
    pub fn of_scene(scene: &'a Scene) -> Self {
        Pipeline {
            operator: &scene.operator,
            bloom: scene.bloom.as_ref(),
            grade: scene.grade.as_ref(),
            encoding: scene.encoding,
        }
    }
}

/// Every stage's output for one frame.
#[derive(Clone, Debug)]
pub struct FrameOutputs {
    /// The HDR input of the statistics and operator (the `sphere` output, or
    /// the flat image).
    pub hdr: LinearImage,
    pub stats: LuminanceStats,
    pub tone: ToneParams,
    /// `tonemap`'s output.
    pub toned: LinearImage,
    /// `bloom_blur`'s output at low resolution, when bloom runs.
    pub bloom: Option<LinearImage>,
    /// `grade_stats`'s mean luminance, when contrast needs it.
    pub grade_mean: Option<f64>,
    /// Linear display-referred frame entering `encode`.
    pub display: LinearImage,
    /// `encode`'s frame (8-bit, or 16-bit PQ).
    pub frame: Frame,
    /// What the sequence is adapted to after this frame, when the plan has
    /// `adaptation` (then `stats` holds the adapted values).
    pub adapted: Option<adaptation::Adapted>,
}

/// Summary of a frame for reports.
#[derive(Clone, Debug, Serialize)]
pub struct FrameSummary {
    pub stats: LuminanceStats,
    pub tone: ToneParams,
}

/// Executes the stages of `plan` after `sphere` on `hdr`. A stage whose
/// input or parameters are missing is a [`PlanError`], as on the GPU.
pub fn run_plan(
    plan: &StagePlan,
    hdr: LinearImage,
    p: &Pipeline,
) -> Result<FrameOutputs, PlanError> {
    run_plan_until(plan, hdr, p, &|| false)?.ok_or(PlanError::Incomplete { missing: "encode" })
}

/// [`run_plan`] for a frame of a sequence with `adaptation`, which adapts
/// from `before`, what the frames before it adapted to (None: the first
/// frame, or a reset).
pub fn run_plan_adapted(
    plan: &StagePlan,
    hdr: LinearImage,
    p: &Pipeline,
    before: Option<&adaptation::Adapted>,
) -> Result<FrameOutputs, PlanError> {
    let made = run_stages_until(plan, hdr, p, &|| false, true, before)?
        .ok_or(PlanError::Incomplete { missing: "encode" })?;
    outputs(made)
}

/// [`run_plan`], asking `stop` before every stage: `None` when it said stop
/// (the work's requester is gone), with what was made so far dropped.
pub fn run_plan_until(
    plan: &StagePlan,
    hdr: LinearImage,
    p: &Pipeline,
    stop: &dyn Fn() -> bool,
) -> Result<Option<FrameOutputs>, PlanError> {
    let Some(made) = run_stages_until(plan, hdr, p, stop, true, None)? else {
        return Ok(None);
    };
    outputs(made).map(Some)
}

fn outputs(made: Made) -> Result<FrameOutputs, PlanError> {
    Ok(FrameOutputs {
        frame: made
            .frame
            .ok_or(PlanError::Incomplete { missing: "encode" })?,
        hdr: made
            .hdr
            .ok_or(PlanError::Incomplete { missing: "sphere" })?,
        stats: made.stats,
        tone: made.tone,
        bloom: made.bloom,
        grade_mean: made.grade_mean,
        display: made.display.unwrap_or_else(|| made.toned.clone()),
        toned: made.toned,
        adapted: made.adapted,
    })
}

/// What [`run_stages_until`] made: [`FrameOutputs`], with the 8-bit frame
/// only when the plan encodes.
struct Made {
    /// The HDR input, when asked to keep it.
    hdr: Option<LinearImage>,
    stats: LuminanceStats,
    tone: ToneParams,
    toned: LinearImage,
    bloom: Option<LinearImage>,
    grade_mean: Option<f64>,
    /// `None` when no stage after `tonemap` changed the image.
    display: Option<LinearImage>,
    frame: Option<Frame>,
    adapted: Option<adaptation::Adapted>,
}

/// Runs `plan`'s stages on `hdr`. Without `keep_hdr`, `tonemap` works in
/// `hdr`'s buffer when no later stage reads the HDR input (one full-size f64
/// image less to allocate and fault in).
fn run_stages_until(
    plan: &StagePlan,
    hdr: LinearImage,
    p: &Pipeline,
    stop: &dyn Fn() -> bool,
    keep_hdr: bool,
    before: Option<&adaptation::Adapted>,
) -> Result<Option<Made>, PlanError> {
    let hdr_read_after_tonemap = plan.stages().iter().any(|s| {
        matches!(
            s,
            Stage::BloomBright {
                source: BloomSource::Hdr
            }
        )
    });
    let mut hdr = Some(hdr);
    let hdr_gone = || PlanError::Incomplete { missing: "sphere" };
    let lum = p.operator.luminance();
    let (weights, delta) = (lum.weights, lum.delta);
    let bloom_of = |stage| {
        p.bloom.ok_or(PlanError::NoParameters {
            stage,
            what: "bloom",
        })
    };
    let mut stats = LuminanceStats::default();
    let mut tone = None;
    let mut toned: Option<LinearImage> = None;
    let mut bright = None;
    let mut low = None;
    let mut bloom = None;
    let mut display: Option<LinearImage> = None;
    let mut grade_mean = None;
    let mut frame = None;
    let mut adapted = None;
    let mut metered_histogram = None;
    // Adaptation's auto-exposure of the operator's input, when it gives one.
    let mut exposure = None;
    for stage in plan.stages() {
        if stop() {
            return Ok(None);
        }
        let name = stage.name();
        let tonemap_first = || PlanError::order(name, "tonemap");
        match stage {
            // The TAA stages run before the plan's loop, in `render_taa_frame`:
            // they carry the history from frame to frame.
            Stage::Sphere { .. } | Stage::TaaSobel | Stage::Taa(_) => {}
            Stage::LuminanceStats(needs) => {
                let hdr = hdr.as_ref().ok_or_else(hdr_gone)?;
                stats = luminance_stats::luminance_stats(hdr, *needs, weights, delta);
            }
            Stage::Histogram(a) => {
                let hdr = hdr.as_ref().ok_or_else(hdr_gone)?;
                metered_histogram = Some(histogram::histogram(hdr, weights, &a.adaptation));
            }
            Stage::Adaptation(a) => {
                let measured = match a.adaptation.metering {
                    Metering::LogAverage if stats.log_average.is_none() => {
                        return Err(PlanError::order(name, "luminance_stats"));
                    }
                    Metering::LogAverage => adaptation::Metered::log_average(&stats),
                    Metering::Histogram => adaptation::Metered::histogram(
                        metered_histogram
                            .as_ref()
                            .ok_or_else(|| PlanError::order(name, "histogram"))?,
                        &a.adaptation,
                        a.operator_needs,
                    ),
                };
                let measured = measured.with_white(&stats, &a.adaptation, a.operator_needs);
                let next = adaptation::adapt(measured, before, &a.adaptation, a.frame_seconds);
                stats = next.statistics(&stats);
                exposure = (!a.operator_needs.keys_on_average())
                    .then(|| next.exposure(&a.adaptation, a.operator_needs));
                adapted = Some(next);
            }
            Stage::Tonemap { .. } => {
                let resolved = p.operator.resolve(&stats)?;
                toned = Some(match exposure {
                    Some(e) => {
                        let hdr = hdr.as_ref().ok_or_else(hdr_gone)?;
                        tonemap::tonemap_into(hdr.map(|c| c.map(|v| v * e)), &resolved)
                    }
                    None if keep_hdr || hdr_read_after_tonemap => {
                        tonemap::tonemap(hdr.as_ref().ok_or_else(hdr_gone)?, &resolved)
                    }
                    None => tonemap::tonemap_into(hdr.take().ok_or_else(hdr_gone)?, &resolved),
                });
                tone = Some(resolved.params);
                // The display image is `toned` until a stage replaces it.
                display = None;
            }
            Stage::BloomBright { source } => {
                let b = bloom_of(name)?;
                let src = match source {
                    BloomSource::Hdr => hdr.as_ref().ok_or_else(hdr_gone)?,
                    BloomSource::Toned => toned.as_ref().ok_or_else(tonemap_first)?,
                };
                let lmax = stats.max.unwrap_or(0.0);
                bright = Some(bloom_bright::bloom_bright(
                    src,
                    b.bright_pass,
                    b.threshold.get(),
                    lmax,
                    weights,
                ));
            }
            Stage::BloomDownsample { factor } => {
                let src = bright
                    .take()
                    .ok_or(PlanError::order(name, "bloom_bright"))?;
                low = Some(bloom_downsample::bloom_downsample(&src, *factor));
            }
            Stage::BloomBlur { radius } => {
                let b = bloom_of(name)?;
                let src = low
                    .take()
                    .ok_or(PlanError::order(name, "bloom_downsample"))?;
                bloom = Some(bloom_blur::bloom_blur(&src, *radius, b.sigma.get()));
            }
            Stage::BloomComposite => {
                let b = bloom_of(name)?;
                let base = display
                    .as_ref()
                    .or(toned.as_ref())
                    .ok_or_else(tonemap_first)?;
                let blurred = bloom.as_ref().ok_or(PlanError::order(name, "bloom_blur"))?;
                display = Some(bloom_composite::bloom_composite(
                    base,
                    blurred,
                    b.strength.get(),
                ));
            }
            Stage::GradeStats => {
                grade_mean = Some(grade_stats::grade_stats(
                    display
                        .as_ref()
                        .or(toned.as_ref())
                        .ok_or_else(tonemap_first)?,
                ));
            }
            Stage::Grade => {
                let g = p.grade.ok_or(PlanError::NoParameters {
                    stage: name,
                    what: "grade",
                })?;
                let base = display
                    .as_ref()
                    .or(toned.as_ref())
                    .ok_or_else(tonemap_first)?;
                // Without contrast the mean is not used, and not measured.
                display = Some(grade::grade(base, g, grade_mean.unwrap_or(0.0)));
            }
            Stage::Encode => {
                frame = Some(
                    encode::encode_frame(
                        display
                            .as_ref()
                            .or(toned.as_ref())
                            .ok_or_else(tonemap_first)?,
                        p.encoding,
                        p.operator.display_levels(),
                    )
                    .map_err(|what| PlanError::NoParameters { stage: name, what })?,
                );
            }
        }
    }
    let (Some(toned), Some(tone)) = (toned, tone) else {
        return Err(PlanError::Incomplete { missing: "tonemap" });
    };
    Ok(Some(Made {
        tone,
        display,
        frame,
        hdr,
        stats,
        toned,
        bloom,
        grade_mean,
        adapted,
    }))
}

/// Tone-maps a flat HDR image (no sphere stage).
pub fn render_flat(img: &HdrImage, p: &Pipeline) -> Result<(StagePlan, FrameOutputs), PlanError> {
    render_flat_until(img, p, &|| false)?.ok_or(PlanError::Incomplete { missing: "encode" })
}

/// A flat image tone-mapped to the display-referred linear image that
/// `encode` would take, without encoding it: what an HDR output file holds.
pub struct FlatDisplay {
    /// The plan that ran: [`render_flat`]'s without `encode`.
    pub plan: StagePlan,
    pub stats: LuminanceStats,
    pub tone: ToneParams,
    /// Narrowed to f32 (rounded to nearest), as an HDR file stores it.
    pub display: HdrImage,
}

/// [`render_flat`] up to `encode`, which is left out, stopping between
/// stages when `stop` says so (`None`).
pub fn render_flat_display_until(
    img: &HdrImage,
    p: &Pipeline,
    stop: &dyn Fn() -> bool,
) -> Result<Option<FlatDisplay>, PlanError> {
    let plan =
        StagePlan::build(crate::plan::Input::Flat, p.operator, p.bloom, p.grade).without_encode();
    if stop() {
        return Ok(None);
    }
    if let Some(t) = pixelwise_tone(img, p) {
        let t = t?;
        let display = img.par_map(|c| t.map(c));
        return Ok(Some(FlatDisplay {
            plan: t.plan,
            stats: t.stats,
            tone: t.tone.params,
            display,
        }));
    }
    let made = run_stages_until(&plan, img.to_linear(), p, stop, false, None)?;
    Ok(made.map(|m| FlatDisplay {
        plan,
        stats: m.stats,
        tone: m.tone,
        display: m.display.unwrap_or(m.toned).to_hdr(),
    }))
}

/// A flat image's tone map whose plan is statistics and `tonemap` alone
/// (no bloom, no grade), resolved: the display image is then a function of
/// each input pixel ([`PixelwiseTone::map`]), with the same bits as the
/// staged path (each pixel widened to f64, tone-mapped and narrowed), and
/// needs neither of the staged path's two full-frame f64 copies, which cost
/// the CPU path most of its time in page faults.
pub struct PixelwiseTone {
    /// [`render_flat`]'s plan without `encode`.
    pub plan: StagePlan,
    pub stats: LuminanceStats,
    /// The resolved operator, with its curve.
    pub tone: Tone,
}

impl PixelwiseTone {
    /// The display-referred pixel of input pixel `c`, in f64 (what `encode`
    /// takes).
    #[inline]
    pub fn display(&self, c: [f32; 3]) -> [f64; 3] {
        self.tone.pixel(c.map(f64::from))
    }

    /// [`PixelwiseTone::display`] narrowed to f32, as an HDR file stores it.
    #[inline]
    pub fn map(&self, c: [f32; 3]) -> [f32; 3] {
        self.display(c).map(|v| v as f32)
    }

    /// `encode`'s 8-bit frame of `img`, from each input pixel: the bytes of
    /// the staged path's frame without its full-frame images.
    pub fn frame(&self, img: &HdrImage, encoding: Encoding) -> Rgb8Image {
        let encoder = encode::Encoder::new(encoding);
        img.par_map(|c| self.display(c).map(|v| encoder.channel(v)))
    }
}

/// The pixelwise tone map of `img` under `p`, or `None` when its plan has
/// more than statistics and `tonemap` (an error when the statistics cannot
/// resolve the operator).
pub fn pixelwise_tone(img: &HdrImage, p: &Pipeline) -> Option<Result<PixelwiseTone, PlanError>> {
    let plan =
        StagePlan::build(crate::plan::Input::Flat, p.operator, p.bloom, p.grade).without_encode();
    let pixelwise = plan
        .stages()
        .iter()
        .all(|s| matches!(s, Stage::LuminanceStats(_) | Stage::Tonemap { .. }));
    if !pixelwise {
        return None;
    }
    let lum = p.operator.luminance();
    let mut stats = LuminanceStats::default();
    for stage in plan.stages() {
        if let Stage::LuminanceStats(needs) = stage {
            stats = luminance_stats::luminance_stats_of(
                &img.pixels,
                img.width,
                |c: [f32; 3]| c.map(f64::from),
                *needs,
                lum.weights,
                lum.delta,
            );
        }
    }
    Some(
        p.operator
            .resolve(&stats)
            .map(|tone| PixelwiseTone { plan, stats, tone })
            .map_err(PlanError::from),
    )
}

/// [`render_flat`], stopping between stages when `stop` says so (`None`).
pub fn render_flat_until(
    img: &HdrImage,
    p: &Pipeline,
    stop: &dyn Fn() -> bool,
) -> Result<Option<(StagePlan, FrameOutputs)>, PlanError> {
    let plan = StagePlan::build(crate::plan::Input::Flat, p.operator, p.bloom, p.grade);
    if stop() {
        return Ok(None);
    }
    let out = run_plan_until(&plan, img.to_linear(), p, stop)?;
    Ok(out.map(|out| (plan, out)))
}
