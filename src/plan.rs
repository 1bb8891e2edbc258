//! The stage plan: the ordered list of stages a scene needs, and nothing else.
//!
//! Both renderers execute a plan; a stage that is not in it is neither built,
//! dispatched nor timed. `tonegate plan scene.toml` prints it.

use crate::operators::Operator;
#[cfg(feature = "reference")]
use crate::scene::Scene;
use crate::scene::{BrightPass, Encoding, Grade, TaaParams, TaaVariant};
use serde::Serialize;
use std::fmt;

pub use crate::operators::StatsNeeds;

/// Where the bright pass reads from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum BloomSource {
    /// The HDR frame (the `scaled` bright pass).
    Hdr,
    /// The tone-mapped frame (the `threshold` bright pass).
    Toned,
}

/// One stage. Names are the WGSL file names, the CPU reference function names
/// and the GPU pipeline labels (`tonegate.<name>`).
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "stage", rename_all = "snake_case")]
pub enum Stage {
    /// Renders the view of the rotating sphere (absent for flat images).
    Sphere {
        spp: u32,
    },
    /// The edge-aware TAA's Sobel pass: how aliased each pixel of the
    /// current (jittered) frame is (the TAA thesis §4.3.3,
    /// docs/bibliography.md).
    TaaSobel,
    /// Temporal anti-aliasing (the TAA thesis, docs/bibliography.md): the
    /// jittered frame resolved against its reprojected, clipped history, then
    /// sharpened. It sits on the HDR
    /// frame, before `luminance_stats`, so the operator measures the
    /// anti-aliased frame, as the accumulation reference's operator measures
    /// its supersampled one: after tone mapping, every frame's statistics
    /// would come from a single jittered sample set and the exposure would
    /// shimmer with the jitter.
    Taa(TaaParams),
    /// Reduces the HDR frame to the statistics the operator needs.
    LuminanceStats(StatsNeeds),
    /// Eye adaptation's metering by histogram (docs/adaptation.md): the
    /// frame's weighted log2-luminance histogram.
    Histogram(AdaptationStage),
    /// Eye adaptation (docs/adaptation.md): the frame's metered luminance
    /// (its log average or histogram), compensated and clamped, moved
    /// toward from the one the frames before adapted to, in place of the
    /// measurement.
    Adaptation(AdaptationStage),
    /// The operator, by name (its module is the pipeline's key).
    Tonemap {
        operator: &'static str,
    },
    BloomBright {
        source: BloomSource,
    },
    BloomDownsample {
        factor: u32,
    },
    /// Two 1-D passes, horizontal then vertical.
    BloomBlur {
        radius: u32,
    },
    BloomComposite,
    /// Mean luminance of the frame entering the grade (contrast needs it).
    GradeStats,
    Grade,
    Encode,
}

/// Stage names: one table gives [`Stage::NAMES`] and [`Stage::name`], so a
/// stage's name is written once.
macro_rules! stage_names {
    ($($stage:pat => $name:literal,)*) => {
        impl Stage {
            /// Every stage's name, in plan order.
            pub const NAMES: [&'static str; [$($name),*].len()] = [$($name),*];

            pub fn name(&self) -> &'static str {
                match self {
                    $($stage => $name,)*
                }
            }
        }
    };
}

stage_names! {
    Stage::Sphere { .. } => "sphere",
    Stage::TaaSobel => "taa_sobel",
    Stage::Taa(_) => "taa",
    Stage::LuminanceStats(_) => "luminance_stats",
    Stage::Histogram(_) => "histogram",
    Stage::Adaptation(_) => "adaptation",
    Stage::Tonemap { .. } => "tonemap",
    Stage::BloomBright { .. } => "bloom_bright",
    Stage::BloomDownsample { .. } => "bloom_downsample",
    Stage::BloomBlur { .. } => "bloom_blur",
    Stage::BloomComposite => "bloom_composite",
    Stage::GradeStats => "grade_stats",
    Stage::Grade => "grade",
    Stage::Encode => "encode",
}

/// What the `adaptation` stage runs with.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct AdaptationStage {
    pub adaptation: crate::scene::Adaptation,
    /// Seconds between frames.
    pub frame_seconds: f64,
    /// What the operator itself reads (the stage adapts those, or gives an
    /// operator that reads none its auto-exposure).
    pub operator_needs: StatsNeeds,
}

/// Where the frame comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Input {
    /// A view of the rotating environment sphere.
    Sphere { spp: u32 },
    /// A flat HDR image, tone-mapped as it is.
    Flat,
}

/// The ordered stages of one frame. Only [`StagePlan::build`] makes one, so
/// every plan is in an order both renderers can execute.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StagePlan {
    stages: Vec<Stage>,
}

/// A plan a renderer cannot execute. `build` never makes one; a renderer
/// that meets one reports it instead of panicking (a tonegate bug).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum PlanError {
    /// A stage's input was not made by an earlier stage.
    #[error("stage {stage} runs before {needs}, which makes its input (a tonegate bug)")]
    OutOfOrder {
        stage: &'static str,
        needs: &'static str,
    },
    /// The plan lacks a stage every frame needs.
    #[error("the plan has no {missing} stage, which every frame needs (a tonegate bug)")]
    Incomplete { missing: &'static str },
    /// The plan has a stage whose parameters the pipeline lacks.
    #[error("stage {stage} is in the plan but the pipeline has no {what} (a tonegate bug)")]
    NoParameters {
        stage: &'static str,
        what: &'static str,
    },
}

/// An operator that lacks a statistic was resolved before `luminance_stats`
/// measured it.
impl From<crate::operators::Unmeasured> for PlanError {
    fn from(_: crate::operators::Unmeasured) -> PlanError {
        PlanError::order("tonemap", "luminance_stats")
    }
}

impl PlanError {
    /// Shorthand for [`PlanError::OutOfOrder`].
    pub fn order(stage: &'static str, needs: &'static str) -> PlanError {
        PlanError::OutOfOrder { stage, needs }
    }
}

/// What the operator needs measured (fixed parameters need nothing), and
/// what the bloom's bright pass needs.
pub fn stats_needs(op: &Operator, bloom: Option<&crate::scene::Bloom>) -> StatsNeeds {
    let mut needs = op.needs();
    if let Some(b) = bloom {
        if b.bright_pass == BrightPass::Scaled {
            needs.max = true;
        }
    }
    needs
}

impl StagePlan {
    /// The plan for `scene` rendered from `input` (a sphere at the given spp,
    /// or a flat image).
    pub fn build(
        input: Input,
        operator: &Operator,
        bloom: Option<&crate::scene::Bloom>,
        grade: Option<&Grade>,
    ) -> StagePlan {
        let mut stages = Vec::new();
        if let Input::Sphere { spp } = input {
            stages.push(Stage::Sphere { spp });
        }
        let needs = stats_needs(operator, bloom);
        if needs.any() {
            stages.push(Stage::LuminanceStats(needs));
        }
        stages.push(Stage::Tonemap {
            operator: operator.name(),
        });
        if let Some(b) = bloom.filter(|b| b.strength.get() > 0.0) {
            let source = match b.bright_pass {
                BrightPass::Scaled => BloomSource::Hdr,
                BrightPass::Threshold => BloomSource::Toned,
            };
            stages.push(Stage::BloomBright { source });
            stages.push(Stage::BloomDownsample {
                factor: b.downsample.get(),
            });
            stages.push(Stage::BloomBlur {
                radius: b.radius.get(),
            });
            stages.push(Stage::BloomComposite);
        }
        if let Some(g) = grade.filter(|g| !g.is_neutral()) {
            if g.contrast.get() != 1.0 {
                stages.push(Stage::GradeStats);
            }
            stages.push(Stage::Grade);
        }
        stages.push(Stage::Encode);
        StagePlan { stages }
    }

    /// The plan of one scene frame at `spp` samples per pixel: a TAA scene's
    /// 1-spp frames get the TAA stages right after `sphere` (at more samples
    /// the scene is its own accumulation reference, with no TAA).
    #[cfg(feature = "reference")]
    pub fn for_scene(scene: &Scene, spp: u32) -> StagePlan {
        let mut plan = StagePlan::build(
            Input::Sphere { spp },
            &scene.operator,
            scene.bloom.as_ref(),
            scene.grade.as_ref(),
        );
        if let Some(taa) = scene.taa_active().filter(|_| spp == 1) {
            plan = plan.with_taa(taa.params());
        }
        if let Some(a) = scene.adaptation {
            plan = plan.with_adaptation(AdaptationStage {
                adaptation: a,
                frame_seconds: scene.frame_seconds(),
                operator_needs: scene.operator.needs(),
            });
        }
        plan
    }

    /// The plan with `adaptation` right after `luminance_stats`, which then
    /// measures the log average too (and runs for an operator that needs
    /// nothing measured) under log-average metering; under histogram
    /// metering with `histogram` and `adaptation` where the statistics are
    /// (or would be), the statistics left to what the operator needs.
    /// Unchanged when it has adaptation already.
    pub fn with_adaptation(mut self, stage: AdaptationStage) -> StagePlan {
        if self.contains("adaptation") {
            return self;
        }
        let by_histogram = stage.adaptation.metering == crate::scene::Metering::Histogram;
        let at = match self
            .stages
            .iter()
            .position(|s| matches!(s, Stage::LuminanceStats(_)))
        {
            Some(i) => {
                if let Stage::LuminanceStats(needs) = &mut self.stages[i] {
                    if !by_histogram {
                        *needs = needs.with_log_average();
                    }
                }
                i + 1
            }
            None => {
                let tonemap = self
                    .stages
                    .iter()
                    .position(|s| matches!(s, Stage::Tonemap { .. }))
                    .unwrap_or(0);
                if !by_histogram {
                    self.stages.insert(
                        tonemap,
                        Stage::LuminanceStats(StatsNeeds::default().with_log_average()),
                    );
                }
                tonemap + usize::from(!by_histogram)
            }
        };
        self.stages.insert(at, Stage::Adaptation(stage));
        if by_histogram {
            self.stages.insert(at, Stage::Histogram(stage));
        }
        self
    }

    /// The adaptation stage's parameters, when the plan has one.
    pub fn adaptation(&self) -> Option<AdaptationStage> {
        self.stages.iter().find_map(|s| match s {
            Stage::Adaptation(a) => Some(*a),
            _ => None,
        })
    }

    /// The plan with the TAA stages (`taa_sobel` for the edge-aware variant,
    /// then `taa`) first: right after `sphere`, which jitters its samples
    /// and reprojects by the camera, or at the start of a flat plan, whose
    /// frames come jittered from an application with their motion vectors
    /// (a `ToneMapper`'s input). Unchanged for `TaaVariant::Off` or when the
    /// plan has TAA already.
    pub fn with_taa(mut self, params: TaaParams) -> StagePlan {
        if params.variant == TaaVariant::Off || self.taa().is_some() {
            return self;
        }
        let at = match self.stages.first() {
            Some(Stage::Sphere { .. }) => 1,
            _ => 0,
        };
        let mut taa = Vec::new();
        if params.variant == TaaVariant::EdgeAware {
            taa.push(Stage::TaaSobel);
        }
        taa.push(Stage::Taa(params));
        self.stages.splice(at..at, taa);
        self
    }

    /// The TAA stage's parameters, when the plan has one.
    pub fn taa(&self) -> Option<TaaParams> {
        self.stages.iter().find_map(|s| match s {
            Stage::Taa(p) => Some(*p),
            _ => None,
        })
    }

    /// The stages, in execution order.
    pub fn stages(&self) -> &[Stage] {
        &self.stages
    }

    /// The plan up to the display-referred image: `encode` left out, for an
    /// output that keeps linear values (an HDR file).
    pub fn without_encode(mut self) -> StagePlan {
        self.stages.retain(|s| !matches!(s, Stage::Encode));
        self
    }

    pub fn contains(&self, name: &str) -> bool {
        self.stages.iter().any(|s| s.name() == name)
    }

    pub fn names(&self) -> Vec<&'static str> {
        self.stages.iter().map(Stage::name).collect()
    }
}

impl fmt::Display for StagePlan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, s) in self.stages.iter().enumerate() {
            let detail = match s {
                Stage::Sphere { spp } => format!("{spp} spp"),
                Stage::LuminanceStats(n) => {
                    let mut parts = Vec::new();
                    if n.log_average {
                        parts.push("log_average");
                    }
                    if n.weighted_log_average {
                        parts.push("weighted_log_average");
                    }
                    if n.min {
                        parts.push("min");
                    }
                    if n.max {
                        parts.push("max");
                    }
                    parts.join(", ")
                }
                Stage::Tonemap { operator } => (*operator).to_owned(),
                Stage::Histogram(a) => format!(
                    "{} bins over {}…{} EV, {:?} mask, {}…{} kept",
                    crate::scene::HISTOGRAM_BINS,
                    a.adaptation.min_ev,
                    a.adaptation.max_ev,
                    a.adaptation.mask,
                    a.adaptation.low,
                    a.adaptation.high
                )
                .to_lowercase(),
                Stage::Adaptation(a) => {
                    let speed = match a.adaptation.speed {
                        crate::scene::Speed::Stops => format!(
                            "{} stops/s up, {} down, exponential within {} stops",
                            a.adaptation.stops_up.get(),
                            a.adaptation.stops_down.get(),
                            a.adaptation.transition
                        ),
                        crate::scene::Speed::TimeConstant => format!(
                            "up {} s, down {} s",
                            a.adaptation.up.get(),
                            a.adaptation.down.get()
                        ),
                    };
                    format!(
                        "{speed}, clamp {}…{} EV, {:.4} s a frame",
                        a.adaptation.min_ev, a.adaptation.max_ev, a.frame_seconds
                    )
                }
                Stage::BloomBright { source } => format!("from {source:?}").to_lowercase(),
                Stage::BloomDownsample { factor } => format!("1/{factor}"),
                Stage::BloomBlur { radius } => format!("radius {radius}, 2 passes"),
                Stage::Taa(p) => format!(
                    "{}, feedback {}..{}, sharpen {}",
                    p.variant.name(),
                    p.feedback_min,
                    p.feedback_max,
                    p.sharpen
                ),
                _ => String::new(),
            };
            writeln!(f, "{:>2}. {:<17} {}", i + 1, s.name(), detail)?;
        }
        Ok(())
    }
}

/// The encoding as a short label for reports.
pub fn encoding_label(e: &Encoding) -> String {
    match e {
        Encoding::Srgb => "srgb".into(),
        Encoding::Gamma(g) => format!("gamma {}", g.get()),
        Encoding::Pq => "pq (16-bit)".into(),
    }
}

#[cfg(test)]
mod tests;
