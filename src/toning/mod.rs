//! Tone-mapping one flat HDR image with user-chosen settings: the knobs the
//! `tonemap` command's flags and the HTTP API's `POST /tonemap` parameters
//! share (one definition, so the two cannot drift), and the CPU and GPU paths.

use crate::error::{Error, Result};
use crate::gpu::{GpuConfig, GpuContext};
use crate::image::{HdrImage, Rgb8Image};
use crate::plan::StagePlan;
use crate::reference::luminance_stats::LuminanceStats;
use crate::reference::tonemap::ToneParams;
use crate::reference::Pipeline;
use crate::scene::{
    Bloom, BrightPass, ColourPath, Encoding, Factor, Grade, Key, NonNegative, Operator,
    OperatorKind, Positive, Radius,
};
use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Preset {
    /// pfstmo_reinhard02 in global mode: pfstools' luminance, δ = 1e-5, Lwhite = max scaled.
    Reinhard02,
}

impl Preset {
    pub fn as_str(self) -> &'static str {
        match self {
            Preset::Reinhard02 => "reinhard02",
        }
    }
}

/// The operator, bloom, grade and encoding of a flat tone-map. As flags
/// (`--white-fraction`, with the `cli` feature the binary builds with) and as
/// API parameters (`white_fraction`); unknown API parameters are refused.
/// `Default` is what the flags default to (a test holds the two together).
/// The enums are the scene schema's own, so a flag takes the words a scene
/// file takes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
pub struct ToneSettings {
    /// A preset that fixes the operator (overrides --operator and --colour).
    #[cfg_attr(feature = "cli", arg(long, value_enum))]
    pub preset: Option<Preset>,
    #[cfg_attr(feature = "cli", arg(long, value_enum, default_value = "seed000"))]
    pub operator: OperatorKind,
    /// Key a (a number, or "auto" for seed001's automatic key).
    #[cfg_attr(feature = "cli", arg(long))]
    pub key: Option<String>,
    /// Seed000: fraction of the scene maximum that maps to white, (0, 1].
    #[cfg_attr(feature = "cli", arg(long))]
    pub white_fraction: Option<f64>,
    /// Reinhard02: absolute Lwhite (default: the maximum scaled luminance).
    #[cfg_attr(feature = "cli", arg(long))]
    pub white: Option<f64>,
    /// Fixed adaptation luminance instead of the measured log-average.
    #[cfg_attr(feature = "cli", arg(long))]
    pub log_average: Option<f64>,
    #[cfg_attr(feature = "cli", arg(long, value_enum, default_value = "ratio"))]
    pub colour: ColourPath,
    /// Bloom strength k (0 = no bloom).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = 0.0))]
    pub bloom: f64,
    #[cfg_attr(feature = "cli", arg(long, value_enum, default_value = "seed001"))]
    pub bloom_pass: BrightPass,
    #[cfg_attr(feature = "cli", arg(long, default_value_t = 1.0))]
    pub bloom_threshold: f64,
    #[cfg_attr(feature = "cli", arg(long, default_value_t = 2))]
    pub bloom_downsample: u32,
    #[cfg_attr(feature = "cli", arg(long, default_value_t = 6))]
    pub bloom_radius: u32,
    #[cfg_attr(feature = "cli", arg(long, default_value_t = 3.0))]
    pub bloom_sigma: f64,
    #[cfg_attr(feature = "cli", arg(long, default_value_t = 1.0))]
    pub brightness: f64,
    #[cfg_attr(feature = "cli", arg(long, default_value_t = 1.0))]
    pub contrast: f64,
    #[cfg_attr(feature = "cli", arg(long, default_value_t = 1.0))]
    pub saturation: f64,
    /// Encode with a 1/γ power instead of the sRGB OETF.
    #[cfg_attr(feature = "cli", arg(long))]
    pub gamma: Option<f64>,
}

impl Default for ToneSettings {
    fn default() -> Self {
        ToneSettings {
            preset: None,
            operator: OperatorKind::Seed000,
            key: None,
            white_fraction: None,
            white: None,
            log_average: None,
            colour: ColourPath::Ratio,
            bloom: 0.0,
            bloom_pass: BrightPass::Seed001,
            bloom_threshold: 1.0,
            bloom_downsample: 2,
            bloom_radius: 6,
            bloom_sigma: 3.0,
            brightness: 1.0,
            contrast: 1.0,
            saturation: 1.0,
            gamma: None,
        }
    }
}

/// Validated settings, ready to become a [`Pipeline`].
#[derive(Clone, Debug)]
pub struct Resolved {
    pub operator: Operator,
    pub bloom: Option<Bloom>,
    pub grade: Grade,
    pub encoding: Encoding,
}

impl Resolved {
    pub fn pipeline(&self) -> Pipeline<'_> {
        Pipeline {
            operator: &self.operator,
            bloom: self.bloom.as_ref(),
            grade: Some(&self.grade),
            encoding: self.encoding,
        }
    }
}

fn invalid(msg: impl Into<String>) -> Error {
    Error::Invalid(msg.into())
}

fn positive(name: &str, v: f64) -> Result<Positive> {
    Positive::try_from(v).map_err(|e| invalid(format!("{name}: {e}")))
}

fn non_negative(name: &str, v: f64) -> Result<NonNegative> {
    NonNegative::try_from(v).map_err(|e| invalid(format!("{name}: {e}")))
}

impl ToneSettings {
    /// Checks every value and builds the operator, bloom, grade and encoding;
    /// the error names the parameter and what it must be.
    pub fn resolve(&self) -> Result<Resolved> {
        Ok(Resolved {
            operator: self.operator()?,
            bloom: self.bloom()?,
            grade: Grade {
                brightness: non_negative("brightness", self.brightness)?,
                contrast: non_negative("contrast", self.contrast)?,
                saturation: non_negative("saturation", self.saturation)?,
            },
            encoding: match self.gamma {
                Some(g) => Encoding::Gamma(positive("gamma", g)?),
                None => Encoding::Srgb,
            },
        })
    }

    fn operator(&self) -> Result<Operator> {
        let colour = self.colour;
        let key = match self.key.as_deref() {
            None => None,
            Some("auto") => Some(Key::Auto),
            Some(s) => {
                let v: f64 = s.parse().map_err(|_| {
                    invalid(format!("key: expected a number or \"auto\", got {s:?}"))
                })?;
                Some(Key::Fixed(positive("key", v)?))
            }
        };
        let fixed_key = |k: Option<Key>| -> Result<Positive> {
            match k {
                None => positive("key", 0.18),
                Some(Key::Fixed(v)) => Ok(v),
                Some(Key::Auto) => Err(invalid("key auto applies to operator seed001 only")),
            }
        };
        // Every value is checked whether or not it applies, and one that
        // does not apply to the operator is refused rather than ignored.
        let log_average = self
            .log_average
            .map(|v| positive("log_average", v))
            .transpose()?;
        let white = self.white.map(|w| positive("white", w)).transpose()?;
        let white_fraction = self
            .white_fraction
            .map(|w| {
                if w > 0.0 && w <= 1.0 {
                    positive("white_fraction", w)
                } else {
                    Err(invalid(format!(
                        "white_fraction: must be in (0, 1], got {w}"
                    )))
                }
            })
            .transpose()?;
        let applies = |name: &str, given: bool, to: &[OperatorKind]| -> Result<()> {
            let op = self.operator;
            match self.preset {
                Some(p) if given => Err(invalid(format!(
                    "{name}: the preset {} fixes the operator's parameters; give only key",
                    p.as_str()
                ))),
                None if given && !to.contains(&op) => Err(invalid(format!(
                    "{name}: applies to operator {} only, not {}",
                    to.iter()
                        .map(|k| k.as_str())
                        .collect::<Vec<_>>()
                        .join(" and "),
                    op.as_str()
                ))),
                _ => Ok(()),
            }
        };
        applies("white", white.is_some(), &[OperatorKind::Reinhard02])?;
        applies(
            "white_fraction",
            white_fraction.is_some(),
            &[OperatorKind::Seed000],
        )?;
        applies(
            "log_average",
            log_average.is_some(),
            &[OperatorKind::Seed000, OperatorKind::Reinhard02],
        )?;
        if let Some(Preset::Reinhard02) = self.preset {
            return Operator::reinhard02_preset(fixed_key(key)?.get()).map_err(invalid);
        }
        Ok(match self.operator {
            OperatorKind::Seed000 => Operator::Seed000 {
                key: fixed_key(key)?,
                white_fraction: match white_fraction {
                    Some(w) => w,
                    None => positive("white_fraction", 0.8)?,
                },
                log_average,
                max_luminance: None,
                colour,
            },
            OperatorKind::Seed001 => Operator::Seed001 {
                key: key.unwrap_or(Key::Auto),
                colour,
            },
            OperatorKind::Reinhard02 => Operator::Reinhard02 {
                key: fixed_key(key)?,
                white,
                log_average,
                colour,
                pfs_compatible: false,
            },
        })
    }

    /// The bloom, None at strength 0; its other knobs are checked either way
    /// (a bad radius is a mistake even while bloom is off).
    fn bloom(&self) -> Result<Option<Bloom>> {
        let bloom = Bloom {
            bright_pass: self.bloom_pass,
            threshold: non_negative("bloom_threshold", self.bloom_threshold)?,
            downsample: Factor::try_from(self.bloom_downsample)
                .map_err(|e| invalid(format!("bloom_downsample: {e}")))?,
            radius: Radius::try_from(self.bloom_radius)
                .map_err(|e| invalid(format!("bloom_radius: {e}")))?,
            sigma: positive("bloom_sigma", self.bloom_sigma)?,
            strength: non_negative("bloom", self.bloom)?,
        };
        Ok((self.bloom != 0.0).then_some(bloom))
    }
}

/// A tone-mapped flat image: what the `tonemap` command and the API use.
pub struct Toned {
    pub plan: StagePlan,
    pub stats: LuminanceStats,
    pub tone: ToneParams,
    /// The linear display-referred image entering `encode`, narrowed to f32
    /// as an HDR file stores it, when asked for (an HDR output file); on the
    /// GPU it is one more full-size readback.
    pub display: Option<HdrImage>,
    /// `encode`'s 8-bit frame: always from the GPU; from the CPU reference
    /// only when the display image was not asked for (an HDR output never
    /// uses it, and the encode was 44 % of such a run).
    pub frame: Option<Rgb8Image>,
}

/// Tone-maps a flat image with the CPU reference, or on the GPU when a
/// context is given (statistics then from the GPU). Intermediates are
/// dropped as soon as they are not needed: a server holds little per job.
pub fn tone_map(
    img: &HdrImage,
    pipeline: &Pipeline,
    gpu: Option<(&GpuContext, GpuConfig)>,
    want_display: bool,
) -> Result<Toned> {
    // One image: textures of its own size, nothing kept for a class.
    let mut kept = gpu.map(|(ctx, config)| (GpuRenderers::new(ctx).exact_sizes(), config));
    let gpu = kept.as_mut().map(|(r, config)| (r, *config));
    tone_map_until(img, pipeline, gpu, want_display, &|| false)?
        .ok_or_else(|| invalid("the tone-map stopped before its end"))
}

/// Renderers kept between images on one device (the server's GPU worker):
/// an image of a size class, plan, settings and configuration seen before
/// is uploaded into that renderer's input ([`GpuRenderer::reload`]) instead
/// of creating its textures, buffers and bind groups again. A renderer's
/// textures have its class's size ([`size_class`]) and it renders any image
/// of the class in their top-left corner. At most [`GpuRenderers::KEEP`]
/// renderers and [`GpuRenderers::KEEP_PIXELS`] pixels of textures are kept
/// (by default), the least recently used dropped first; a renderer over the
/// pixel budget alone is dropped once its image is done.
pub struct GpuRenderers<'a> {
    ctx: &'a GpuContext,
    /// (key, renderer), the most recently used last.
    kept: Vec<(String, crate::gpu::GpuRenderer<'a>)>,
    keep: usize,
    keep_pixels: u64,
    /// Whether renderers are made for size classes (else for exact sizes).
    classes: bool,
}

/// The size class of a `width`×`height` image on an adapter whose textures
/// are at most `limit` wide and tall: each side rounded up to a multiple of
/// a sixteenth of its next power of two, and of 64 at least. A class's side
/// is at most 12.5 % or 63 pixels longer than any image's in it; there are
/// eight classes per doubling of a side beyond 1024, and multiples of 64 up
/// to it (1920×1080 is in 1920×1152).
pub fn size_class(width: u32, height: u32, limit: u32) -> (u32, u32) {
    let side = |d: u32| {
        let power = d.max(1).checked_next_power_of_two().unwrap_or(1 << 31);
        let step = (power / 16).max(64);
        d.div_ceil(step).saturating_mul(step).min(limit).max(d)
    };
    (side(width), side(height))
}

impl<'a> GpuRenderers<'a> {
    pub const KEEP: usize = 4;
    /// Two 4096×2048 frames' worth: a renderer holds several full-frame
    /// textures (16 bytes a pixel each in f32), so this bounds the device
    /// memory kept idle to a few hundred MiB.
    pub const KEEP_PIXELS: u64 = 2 * 4096 * 2048;

    pub fn new(ctx: &'a GpuContext) -> Self {
        Self::with_limits(ctx, Self::KEEP, Self::KEEP_PIXELS)
    }

    /// Keeps at most `keep` renderers and `keep_pixels` pixels among them.
    pub fn with_limits(ctx: &'a GpuContext, keep: usize, keep_pixels: u64) -> Self {
        GpuRenderers {
            ctx,
            kept: Vec::new(),
            keep: keep.max(1),
            keep_pixels,
            classes: true,
        }
    }

    /// Renderers made for each image's exact size, not its class: for one
    /// image, where nothing is reused.
    pub fn exact_sizes(mut self) -> Self {
        self.classes = false;
        self
    }

    /// The pixels of the kept renderers' textures (their capacities).
    pub fn pixels(&self) -> u64 {
        self.kept.iter().map(|(_, r)| capacity_pixels(r)).sum()
    }

    /// Drops a renderer larger than the pixel budget on its own: it served
    /// its image and is not kept idle on the device.
    pub fn release_oversize(&mut self) {
        let budget = self.keep_pixels;
        self.kept.retain(|(_, r)| capacity_pixels(r) <= budget);
    }

    pub fn ctx(&self) -> &'a GpuContext {
        self.ctx
    }

    /// How many renderers are kept now.
    pub fn len(&self) -> usize {
        self.kept.len()
    }

    pub fn is_empty(&self) -> bool {
        self.kept.is_empty()
    }

    /// A renderer of `plan` for `img` with `pipeline` and `config`: a kept
    /// one of its size class reloaded with `img`, or a new one, kept after
    /// the least recently used ones it has no room beside were dropped
    /// (before it is created, so the device never holds more than the budget
    /// and the new one).
    pub fn renderer(
        &mut self,
        img: &HdrImage,
        plan: &StagePlan,
        pipeline: &Pipeline,
        config: GpuConfig,
    ) -> Result<&crate::gpu::GpuRenderer<'a>> {
        // An image too large for the adapter is refused before any kept
        // renderer is dropped to make room for it.
        self.ctx.check_frame(img.width, img.height)?;
        let exact = (img.width, img.height);
        let class = match self.classes {
            true => size_class(
                img.width,
                img.height,
                self.ctx.limits.max_texture_dimension_2d,
            ),
            false => exact,
        };
        // A class that the budget or the adapter cannot hold gives way to
        // the image's own size: kept if that fits the budget, else rendered
        // once and dropped (`release_oversize`).
        let pixels = |(w, h): (u32, u32)| w as u64 * h as u64;
        let fits =
            |(w, h)| pixels((w, h)) <= self.keep_pixels && self.ctx.check_frame(w, h).is_ok();
        let class = if fits(class) { class } else { exact };
        let key = format!(
            "{}x{} {:?} {pipeline:?} {config:?}",
            class.0,
            class.1,
            plan.names()
        );
        if let Some(i) = self.kept.iter().position(|(k, _)| *k == key) {
            let (k, r) = self.kept.remove(i);
            if r.reload(img) {
                self.kept.push((k, r));
                return Ok(&self.kept[self.kept.len() - 1].1);
            }
        }
        let wanted = pixels(class);
        while !self.kept.is_empty()
            && (self.kept.len() >= self.keep || self.pixels() + wanted > self.keep_pixels)
        {
            self.kept.remove(0);
        }
        let r = crate::gpu::GpuRenderer::with_capacity(
            self.ctx,
            plan.clone(),
            crate::gpu::GpuInput::Flat(img),
            pipeline,
            config,
            class,
        )?;
        self.kept.push((key, r));
        Ok(&self.kept[self.kept.len() - 1].1)
    }
}

fn capacity_pixels(r: &crate::gpu::GpuRenderer) -> u64 {
    let (w, h) = r.capacity();
    w as u64 * h as u64
}

/// [`tone_map`], asking `stop` between stages (the CPU reference) or before
/// and after the device's work (the GPU, which runs the plan in one
/// submission): `None` when it said stop.
pub fn tone_map_until(
    img: &HdrImage,
    pipeline: &Pipeline,
    gpu: Option<(&mut GpuRenderers, GpuConfig)>,
    want_display: bool,
    stop: &dyn Fn() -> bool,
) -> Result<Option<Toned>> {
    match gpu {
        None if want_display => {
            let out = crate::reference::render_flat_display_until(img, pipeline, stop)?;
            Ok(out.map(|out| Toned {
                plan: out.plan,
                stats: out.stats,
                tone: out.tone,
                display: Some(out.display),
                frame: None,
            }))
        }
        None => {
            if let Some(t) = crate::reference::pixelwise_tone(img, pipeline) {
                // Statistics and `tonemap` alone: each 8-bit pixel straight
                // from its input pixel, the staged path's bytes (tested).
                let t = t?;
                if stop() {
                    return Ok(None);
                }
                let frame = t.frame(img, pipeline.encoding);
                let plan = StagePlan::build(
                    crate::plan::Input::Flat,
                    pipeline.operator,
                    pipeline.bloom,
                    pipeline.grade,
                );
                return Ok(Some(Toned {
                    plan,
                    stats: t.stats,
                    tone: t.tone,
                    display: None,
                    frame: Some(frame),
                }));
            }
            let Some((plan, out)) = crate::reference::render_flat_until(img, pipeline, stop)?
            else {
                return Ok(None);
            };
            Ok(Some(Toned {
                plan,
                stats: out.stats,
                tone: out.tone,
                display: None,
                frame: Some(out.frame),
            }))
        }
        Some(_) if stop() => Ok(None),
        Some((renderers, config)) => {
            let toned = gpu_flat(img, pipeline, renderers, config, want_display)?;
            Ok((!stop()).then_some(toned))
        }
    }
}

fn gpu_flat(
    img: &HdrImage,
    pipeline: &Pipeline,
    renderers: &mut GpuRenderers,
    config: GpuConfig,
    want_display: bool,
) -> Result<Toned> {
    let plan = StagePlan::build(
        crate::plan::Input::Flat,
        pipeline.operator,
        pipeline.bloom,
        pipeline.grade,
    );
    // The display image is a staged output: fused kernels never store it.
    let mut config = config;
    if want_display {
        config.execution = crate::gpu::Execution::Staged;
    }
    let rendered = renderers
        .renderer(img, &plan, pipeline, config)
        .and_then(|r| {
            let out = r.render(true)?;
            let display = match want_display {
                true => Some(
                    r.read_output("display")?
                        .map(|d| d.to_hdr())
                        .unwrap_or_else(|| img.clone()),
                ),
                false => None,
            };
            Ok((out, display))
        });
    // Whatever the outcome, a renderer over the budget is not kept.
    renderers.release_oversize();
    let (out, display) = rendered?;
    let s = out.stats;
    let (weights, _) = crate::reference::tonemap::operator_constants(pipeline.operator);
    let tone = ToneParams {
        key: s.key as f64,
        log_average: s.adaptation as f64,
        scale: s.scale as f64,
        white_sq: if s.white > 0.0 && s.white.is_finite() {
            (s.white as f64).powi(2)
        } else {
            f64::INFINITY
        },
        weights,
        colour: pipeline.operator.colour(),
    };
    let frame = Some(
        out.frame
            .ok_or_else(|| invalid("GPU frame was not read back"))?,
    );
    Ok(Toned {
        plan,
        stats: s.luminance_stats(),
        tone,
        display,
        frame,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_size_class_is_at_most_an_eighth_or_63_pixels_longer_on_a_side() {
        let limit = 16384;
        let mut classes = std::collections::BTreeSet::new();
        for d in 1..=limit {
            let (c, _) = size_class(d, 1, limit);
            assert!(c >= d && c <= limit, "{d} -> {c}");
            assert!(
                c as f64 <= (d as f64 * 1.125).max(d as f64 + 63.0),
                "{d} -> {c}"
            );
            // A class holds every size between its smaller neighbour and it.
            assert_eq!(size_class(c, 1, limit).0, c, "{d} -> {c}");
            classes.insert(c);
        }
        // Eight per doubling beyond 1024, multiples of 64 up to it.
        let octave = |lo: u32, hi: u32| classes.range(lo + 1..=hi).count();
        assert_eq!(octave(1024, 2048), 8);
        assert_eq!(octave(8192, 16384), 8);
        assert_eq!(octave(0, 1024), 16);
        assert_eq!(size_class(1000, 500, limit), (1024, 512));
        assert_eq!(size_class(1920, 1080, limit), (1920, 1152));
        assert_eq!(size_class(3840, 2160, limit), (3840, 2304));
        // Capped by the adapter's limit, never below the image.
        assert_eq!(size_class(8100, 10, 8192), (8192, 64));
        assert_eq!(size_class(8192, 8192, 8192), (8192, 8192));
    }

    #[cfg(feature = "cli")]
    #[test]
    fn defaults_of_flags_and_api_are_the_same() {
        use clap::Parser;
        #[derive(Parser)]
        struct Flags {
            #[command(flatten)]
            settings: ToneSettings,
        }
        let flags = Flags::try_parse_from(["x"]).unwrap();
        assert_eq!(flags.settings, ToneSettings::default());
        let api: ToneSettings = serde_json::from_str("{}").unwrap();
        assert_eq!(api, ToneSettings::default());
    }

    #[test]
    fn unknown_and_bad_parameters_are_refused_by_name() {
        let e = serde_json::from_str::<ToneSettings>(r#"{"kee": 0.2}"#).unwrap_err();
        assert!(e.to_string().contains("unknown field `kee`"), "{e}");
        let s = ToneSettings {
            white_fraction: Some(1.5),
            ..Default::default()
        };
        let e = s.resolve().unwrap_err().to_string();
        assert!(e.contains("white_fraction") && e.contains("1.5"), "{e}");
        let s = ToneSettings {
            key: Some("bright".into()),
            ..Default::default()
        };
        assert!(s.resolve().unwrap_err().to_string().contains("key"));
        let s = ToneSettings {
            gamma: Some(f64::NAN),
            ..Default::default()
        };
        assert!(s.resolve().unwrap_err().to_string().contains("gamma"));
    }

    /// Found by a hostile client: `white=-1` was ignored under the default
    /// operator but refused under reinhard02.
    #[test]
    fn a_value_is_checked_and_applies_to_its_operator_whatever_the_operator() {
        fn with(
            op: OperatorKind,
            f: impl FnOnce(&mut ToneSettings),
        ) -> std::result::Result<(), String> {
            let mut s = ToneSettings {
                operator: op,
                ..Default::default()
            };
            f(&mut s);
            s.resolve().map(|_| ()).map_err(|e| e.to_string())
        }
        for op in [
            OperatorKind::Seed000,
            OperatorKind::Seed001,
            OperatorKind::Reinhard02,
        ] {
            for bad in [-1.0, 0.0, f64::INFINITY, f64::NAN] {
                let e = with(op, |s| s.white = Some(bad)).unwrap_err();
                assert!(e.starts_with("white:"), "{op:?} {bad}: {e}");
                let e = with(op, |s| s.log_average = Some(bad)).unwrap_err();
                assert!(e.starts_with("log_average:"), "{op:?} {bad}: {e}");
                let e = with(op, |s| s.white_fraction = Some(bad)).unwrap_err();
                assert!(e.starts_with("white_fraction:"), "{op:?} {bad}: {e}");
            }
        }
        let e = with(OperatorKind::Seed000, |s| s.white = Some(4.0)).unwrap_err();
        assert!(
            e.contains("applies to operator reinhard02 only, not seed000"),
            "{e}"
        );
        let e = with(OperatorKind::Reinhard02, |s| s.white_fraction = Some(0.5)).unwrap_err();
        assert!(e.contains("applies to operator seed000 only"), "{e}");
        let e = with(OperatorKind::Seed001, |s| s.log_average = Some(0.2)).unwrap_err();
        assert!(e.contains("seed000 and reinhard02"), "{e}");
        let e = with(OperatorKind::Seed000, |s| {
            s.preset = Some(Preset::Reinhard02);
            s.white = Some(4.0);
        })
        .unwrap_err();
        assert!(e.contains("preset reinhard02"), "{e}");
        with(OperatorKind::Reinhard02, |s| s.white = Some(4.0)).unwrap();
        with(OperatorKind::Seed000, |s| s.white_fraction = Some(0.5)).unwrap();
        with(OperatorKind::Seed000, |s| s.log_average = Some(0.2)).unwrap();
    }
}
