//! The knobs `tradeoff` sweeps: what one configuration is, its label, the
//! sweep over a scene, and the scene variants the TAA and operator knobs
//! make.

use crate::gpu::{EnvFilter, HdrFormat, ReductionMethod};
use crate::scene::{BlendSpace, FeedbackRule, HistoryFilter, Scene, Taa, TaaParams, TaaVariant};
use serde::Serialize;

/// One configuration of the knobs.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Knobs {
    pub hdr_format: HdrFormat,
    pub reduction: ReductionMethod,
    pub env_filter: EnvFilter,
    /// Bloom downsample factor (None for scenes without bloom); the blur is
    /// rescaled to keep its full-resolution extent (see [`super::with_downsample`]).
    pub bloom_downsample: Option<u32>,
    pub spp: u32,
    /// TAA on the 1-spp frames (None: the scene's own setting).
    pub taa: Option<TaaKnob>,
    /// One of the operator's speed knobs (None: the scene's own values).
    pub operator: Option<OperatorKnob>,
}

/// A parameter of the scene's operator set to a value that trades accuracy
/// for speed ([`crate::operators::ToneOperator::speed_knobs`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct OperatorKnob {
    pub param: &'static str,
    pub value: crate::operators::Value,
}

/// The TAA knobs of a 1-spp configuration: every key of the stage.
pub type TaaKnob = TaaParams;

/// The TAA configurations the sweep adds at 1 spp: no AA; every history
/// filter × feedback rule × clipping box at the other keys' defaults (the
/// luminance rule at the thesis's 0.88..0.97); and the defaults with the
/// blend linear instead of tone-mapped, and with the sharpen at the
/// normalised kernel's 0.25.
pub fn taa_knobs() -> Vec<TaaKnob> {
    let defaults = TaaParams::default();
    let mut all = vec![TaaParams {
        variant: TaaVariant::Off,
        ..defaults
    }];
    for history_filter in [HistoryFilter::Bilinear, HistoryFilter::CatmullRom] {
        for feedback in [FeedbackRule::Luminance, FeedbackRule::Motion] {
            for variant in [
                TaaVariant::Clip,
                TaaVariant::EdgeAware,
                TaaVariant::Variance,
            ] {
                all.push(TaaParams {
                    variant,
                    history_filter,
                    feedback,
                    ..defaults
                });
            }
        }
    }
    all.push(TaaParams {
        blend: BlendSpace::Linear,
        ..defaults
    });
    all.push(TaaParams {
        sharpen: 0.25,
        ..defaults
    });
    all
}

impl Knobs {
    /// A short, stable name: "f32 block manual ds2 1spp".
    pub fn label(&self) -> String {
        let f = match self.hdr_format {
            HdrFormat::Rgba32Float => "f32",
            HdrFormat::Rgba16Float => "f16",
        };
        let r = match self.reduction {
            ReductionMethod::BlockPartials => "block",
            ReductionMethod::PingPong => "pingpong",
            ReductionMethod::Tree => "tree",
            ReductionMethod::SubgroupTree => "subgroup",
            ReductionMethod::Auto => "auto",
        };
        let e = match self.env_filter {
            EnvFilter::Manual => "manual",
            EnvFilter::Hardware => "hardware",
        };
        let ds = self
            .bloom_downsample
            .map(|d| format!(" ds{d}"))
            .unwrap_or_default();
        let taa = match self.taa {
            None => String::new(),
            Some(t) if t.variant == TaaVariant::Off => " noaa".into(),
            Some(t) => format!(
                " taa {} {} {}{}{}",
                t.variant.name(),
                match t.history_filter {
                    HistoryFilter::Bilinear => "bilinear",
                    HistoryFilter::CatmullRom => "cr",
                },
                match t.feedback {
                    FeedbackRule::Luminance => format!("lum{}-{}", t.feedback_min, t.feedback_max),
                    FeedbackRule::Motion => "motion".to_owned(),
                },
                match t.blend {
                    BlendSpace::Linear => " linear",
                    BlendSpace::Tonemapped => " tm",
                },
                if t.sharpen > 0.0 {
                    format!(" s{}", t.sharpen)
                } else {
                    String::new()
                }
            ),
        };
        let op = self
            .operator
            .map(|k| format!(" {}={}", k.param, k.value))
            .unwrap_or_default();
        format!("{f} {r} {e}{ds} {}spp{taa}{op}", self.spp)
    }
}

/// The sweep: the product of every knob's values.
pub fn sweep(scene: &Scene, spps: &[u32], downsamples: &[u32]) -> Vec<Knobs> {
    let ds: Vec<Option<u32>> = if scene.bloom.is_some() {
        downsamples.iter().map(|&d| Some(d)).collect()
    } else {
        vec![None]
    };
    let mut all = Vec::new();
    for hdr_format in [HdrFormat::Rgba32Float, HdrFormat::Rgba16Float] {
        for reduction in [
            ReductionMethod::BlockPartials,
            ReductionMethod::PingPong,
            ReductionMethod::Tree,
            ReductionMethod::SubgroupTree,
        ] {
            for env_filter in [EnvFilter::Manual, EnvFilter::Hardware] {
                for &bloom_downsample in &ds {
                    for &spp in spps {
                        all.push(Knobs {
                            hdr_format,
                            reduction,
                            env_filter,
                            bloom_downsample,
                            spp,
                            taa: None,
                            operator: None,
                        });
                    }
                }
            }
        }
    }
    // TAA at 1 spp, the other knobs at their defaults: how close 1 spp +
    // TAA gets to the many-sample reference, at what cost.
    if spps.contains(&1) {
        for taa in taa_knobs() {
            all.push(Knobs {
                hdr_format: HdrFormat::Rgba32Float,
                reduction: ReductionMethod::BlockPartials,
                env_filter: EnvFilter::Manual,
                bloom_downsample: ds.first().copied().flatten(),
                spp: 1,
                taa: Some(taa),
                operator: None,
            });
        }
    }
    // The operator's own speed knobs, one at a time, at every spp and the
    // other knobs at their defaults.
    for &(param, value) in scene.operator.definition().speed_knobs() {
        for &spp in spps {
            all.push(Knobs {
                hdr_format: HdrFormat::Rgba32Float,
                reduction: ReductionMethod::BlockPartials,
                env_filter: EnvFilter::Manual,
                bloom_downsample: ds.first().copied().flatten(),
                spp,
                taa: None,
                operator: Some(OperatorKnob { param, value }),
            });
        }
    }
    all
}

/// `scene` with `knob`'s operator value.
pub fn with_operator_knob(scene: &Scene, knob: Option<OperatorKnob>) -> Result<Scene, String> {
    let mut variant = scene.clone();
    if let Some(k) = knob {
        variant.operator = scene
            .operator
            .with_value(k.param, k.value)
            .map_err(|e| e.to_string())?;
    }
    Ok(variant)
}

/// `scene` with `knob`'s TAA (a scene's reset frames are kept).
pub fn with_taa(scene: &Scene, knob: Option<TaaKnob>) -> Result<Scene, String> {
    let mut variant = scene.clone();
    if let Some(k) = knob {
        let resets = scene
            .taa
            .as_ref()
            .map(|t| t.reset_frames.clone())
            .unwrap_or_default();
        variant.taa = Some(Taa::from_params(&k, resets)?);
    }
    Ok(variant)
}
