//! What a [`ToneMapper`] maps with, and the settings it refuses.

use super::target::{storable, OutputPath, ToneMapperError};
use crate::gpu::encode::Texel;
use crate::operators::Operator;
use crate::scene::{Adaptation, Bloom, Encoding, Grade, Taa};

/// How a [`super::ToneMapper`] maps: the operator with its parameters, the display
/// encoding, the target's format and the path into it. A value: two
/// settings are equal when they map alike, and [`super::ToneMapper::set_settings`]
/// with equal settings does nothing.
#[derive(Clone, Debug, PartialEq)]
pub struct ToneMapperSettings {
    /// The operator (`Operator::named("agx", &[])`, or a caller's own after
    /// `operators::register`).
    pub operator: Operator,
    /// The display encoding: the sRGB transfer, a gamma, or PQ (into a
    /// 10-bit or scRGB target, for an operator with display levels).
    pub encoding: Encoding,
    /// The format of the views [`super::ToneMapper::record`] writes: one of
    /// [`super::TARGET_FORMATS`]. A swap chain's, typically.
    pub target: wgpu::TextureFormat,
    /// A compute pass, a render pass, or whichever the target allows.
    pub path: OutputPath,
    /// Eye adaptation: the log average the operator keys on (or, for one
    /// that keys on none, its exposure) follows the frames' measurements
    /// with a time constant up and down, instead of jumping with each
    /// frame (docs/adaptation.md). `None`: each frame on its own.
    pub adaptation: Option<Adaptation>,
    /// Bloom on the tone-mapped image (docs/display.md#bloom), as a
    /// scene's `[bloom]`.
    pub bloom: Option<Bloom>,
    /// The grade after it (docs/display.md#grade), as a scene's `[grade]`.
    pub grade: Option<Grade>,
    /// Temporal anti-aliasing, as a scene's `[taa]` (docs/taa.md): each
    /// frame, rendered by the application with a sub-pixel jitter, is
    /// resolved against the history its motion vectors find
    /// ([`super::ToneMapper::record_with_motion`]) before it is measured
    /// and mapped. The table's `reset_frames` are a scene's; an
    /// application calls [`super::ToneMapper::reset_history`].
    pub taa: Option<Taa>,
}

impl Default for ToneMapperSettings {
    /// `reinhard-global` at its defaults, sRGB-encoded into
    /// `Bgra8UnormSrgb`, the format most platforms' swap chains prefer
    /// (written by a fullscreen triangle: an sRGB format is no storage
    /// target): the curve and encoding `tonegate tonemap` uses with no
    /// flags, into a window's frame. A storage or offscreen target sets
    /// `target` (`Rgba8Unorm`, …).
    fn default() -> ToneMapperSettings {
        ToneMapperSettings {
            operator: Operator::default(),
            encoding: Encoding::Srgb,
            target: wgpu::TextureFormat::Bgra8UnormSrgb,
            path: OutputPath::Auto,
            adaptation: None,
            bloom: None,
            grade: None,
            taa: None,
        }
    }
}

/// Refuses settings a [`super::ToneMapper`] cannot map with on a device with
/// `features`.
pub(super) fn check_settings(
    settings: &ToneMapperSettings,
    features: wgpu::Features,
) -> Result<(), ToneMapperError> {
    let format = settings.target;
    let Some(texel) = Texel::of(format) else {
        return Err(ToneMapperError::TargetFormat { format });
    };
    if settings.encoding == Encoding::Pq {
        if texel.bits() == 8 {
            return Err(ToneMapperError::PqIntoEightBits { format });
        }
        if settings.operator.display_levels().is_none() {
            return Err(ToneMapperError::PqWithoutLevels {
                operator: settings.operator.name().to_owned(),
            });
        }
    }
    if settings.path == OutputPath::Compute && !storable(format, features) {
        return Err(ToneMapperError::ComputeTarget { format });
    }
    if let Some(b) = &settings.bloom {
        b.check()
            .map_err(|(key, reason)| ToneMapperError::Display {
                table: "bloom",
                key,
                reason,
            })?;
    }
    if let Some(a) = &settings.adaptation {
        a.check()
            .map_err(|(key, reason)| ToneMapperError::Display {
                table: "adaptation",
                key,
                reason,
            })?;
    }
    if let Some(g) = &settings.grade {
        g.check()
            .map_err(|(key, reason)| ToneMapperError::Display {
                table: "grade",
                key,
                reason,
            })?;
    }
    if let Some(t) = &settings.taa {
        let (lo, hi) = (t.feedback_min.get(), t.feedback_max.get());
        if lo > hi {
            return Err(ToneMapperError::Display {
                table: "taa",
                key: "feedback_min",
                reason: format!("{lo} exceeds feedback_max {hi}"),
            });
        }
    }
    Ok(())
}
