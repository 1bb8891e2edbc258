//! [`ToneMapper`]: tonegate's tone mapper inside someone else's wgpu
//! application, on the caller's device and queue, recorded into the
//! caller's command encoder, from the caller's HDR texture to the caller's
//! 8-bit texture (docs/embedding.md).
//!
//! It runs the stages tonegate's own renderer runs for a flat image with no
//! bloom or grade: the luminance statistics (when the operator needs them),
//! the operator (its resolve step, then its curve), and the display
//! encoding. The same shaders and pipelines, so the same bits: an input
//! texture in `Rgba32Float` gives the bytes `tonegate tonemap --gpu` writes on the
//! same adapter.

use super::config::ReductionMethod;
use super::stages::{extent_buffer, hdr_texture, shared_buffer, Dispatch, Extent};
use super::tonemap::ToneParams;
use super::{GpuContext, GpuError, GpuStats, HdrFormat};
use crate::operators::Operator;
use crate::scene::Encoding;

/// The format of the texture [`ToneMapper::record`] writes: 8-bit sRGB- (or
/// gamma-) encoded values, alpha 255. A storage texture cannot be an `…Srgb`
/// format; a caller that samples it through an `Rgba8UnormSrgb` view
/// (`view_formats`) gets linear values back.
pub const OUTPUT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

/// The HDR formats [`ToneMapper::record`] reads (linear, scene-referred).
pub const INPUT_FORMATS: [wgpu::TextureFormat; 2] = [
    wgpu::TextureFormat::Rgba32Float,
    wgpu::TextureFormat::Rgba16Float,
];

/// Which of the two textures a [`ToneMapperError`] is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TextureRole {
    /// The HDR texture read.
    Input,
    /// The 8-bit texture written.
    Output,
}

impl std::fmt::Display for TextureRole {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            TextureRole::Input => "input",
            TextureRole::Output => "output",
        })
    }
}

/// Why a [`ToneMapper`] refused its settings or a pair of textures, before
/// anything was recorded. Each variant carries what a caller needs to act
/// on it; the messages say the same in words.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ToneMapperError {
    /// PQ frames are 16-bit; the output texture is 8-bit.
    #[error("encoding pq: a PQ frame is 16-bit, and the tone mapper writes an Rgba8Unorm texture; use the sRGB transfer or a gamma")]
    PqIntoEightBits,
    /// The input is not one of [`INPUT_FORMATS`].
    #[error("the input texture is {format:?}; the tone mapper reads Rgba32Float or Rgba16Float (linear HDR)")]
    InputFormat {
        /// The input's format.
        format: wgpu::TextureFormat,
    },
    /// The output is not [`OUTPUT_FORMAT`].
    #[error("the output texture is {format:?}; the tone mapper writes Rgba8Unorm (sRGB-encoded values; a storage texture cannot be Rgba8UnormSrgb)")]
    OutputFormat {
        /// The output's format.
        format: wgpu::TextureFormat,
    },
    /// A texture lacks a usage the mapper binds it with.
    #[error("the {texture} texture lacks {} usage", usage_name(*.usage))]
    MissingUsage {
        /// Which texture.
        texture: TextureRole,
        /// The usage it lacks.
        usage: wgpu::TextureUsages,
    },
    /// A texture that is not one 2-D layer with one sample.
    #[error("the {texture} texture must be a single 2-D layer, not multisampled")]
    NotSingleLayer {
        /// Which texture.
        texture: TextureRole,
    },
    /// The two textures differ in size.
    #[error("the input texture is {}x{} and the output {}x{}; they must be the same size", .input.0, .input.1, .output.0, .output.1)]
    SizeMismatch {
        /// The input's width and height.
        input: (u32, u32),
        /// The output's width and height.
        output: (u32, u32),
    },
    /// Over the device's limits ([`GpuError::TooLarge`] or
    /// [`GpuError::FrameTooLarge`]).
    #[error(transparent)]
    Limits(GpuError),
}

fn usage_name(usage: wgpu::TextureUsages) -> String {
    let names: Vec<&str> = usage.iter_names().map(|(name, _)| name).collect();
    names.join(" | ")
}

/// How a [`ToneMapper`] maps: the operator with its parameters, and the
/// display encoding.
#[derive(Clone, Debug)]
pub struct ToneMapperSettings {
    /// The operator (`Operator::named("agx", &[])`, or a caller's own after
    /// `operators::register`).
    pub operator: Operator,
    /// The display encoding: the sRGB transfer or a gamma (a PQ encoding is
    /// refused by [`ToneMapper::new`]: its output texture is 8-bit).
    pub encoding: Encoding,
}

impl Default for ToneMapperSettings {
    /// `reinhard-global` at its defaults, sRGB-encoded: what `tonegate
    /// tonemap` does with no flags.
    fn default() -> ToneMapperSettings {
        ToneMapperSettings {
            operator: Operator::default(),
            encoding: Encoding::Srgb,
        }
    }
}

/// The resources that depend on the textures of one [`ToneMapper::record`]
/// call: kept while the caller passes the same two textures.
struct Bound {
    input: wgpu::Texture,
    output: wgpu::Texture,
    dispatches: Vec<Dispatch>,
}

/// Tone-maps a caller's HDR texture into a caller's 8-bit texture on the
/// caller's device.
///
/// ```no_run
/// # fn demo(device: &wgpu::Device, queue: &wgpu::Queue, hdr: &wgpu::Texture, ldr: &wgpu::Texture) -> Result<(), tonegate::gpu::ToneMapperError> {
/// use tonegate::gpu::{ToneMapper, ToneMapperSettings};
/// let mut mapper = ToneMapper::new(device, queue, ToneMapperSettings::default())?;
/// // Every pipeline now, not in the first frame.
/// mapper.prepare();
/// let mut encoder = device.create_command_encoder(&Default::default());
/// mapper.record(&mut encoder, hdr, ldr)?;
/// queue.submit([encoder.finish()]);
/// # Ok(()) }
/// ```
pub struct ToneMapper {
    ctx: GpuContext,
    settings: ToneMapperSettings,
    reduction: ReductionMethod,
    params: ToneParams,
    stats: wgpu::Buffer,
    bound: Option<Bound>,
}

impl ToneMapper {
    /// A tone mapper on the caller's `device` and `queue`, or why not (a PQ
    /// encoding). Pipelines are compiled by [`ToneMapper::prepare`], or else
    /// on the first [`ToneMapper::record`], and kept; the operator's
    /// parameters are written to a uniform through `queue` here.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        settings: ToneMapperSettings,
    ) -> Result<ToneMapper, ToneMapperError> {
        check_settings(&settings)?;
        let ctx = GpuContext::from_device(device, queue);
        // The reduction tonegate's own renderer picks on this adapter.
        let reduction = ReductionMethod::Auto.resolve(ctx.traits());
        let params = ToneParams::new(&ctx, &settings.operator, None);
        let stats = shared_buffer(
            &ctx,
            "tonegate.luminance_stats",
            std::mem::size_of::<GpuStats>() as u64,
        );
        Ok(ToneMapper {
            ctx,
            settings,
            reduction,
            params,
            stats,
            bound: None,
        })
    }

    /// What it maps with.
    pub fn settings(&self) -> &ToneMapperSettings {
        &self.settings
    }

    /// Compiles every pipeline the current settings need, so that the
    /// first [`ToneMapper::record`] does not (a frame's hitch otherwise).
    /// The pipelines do not depend on the frame's size: a one-pixel pair
    /// is wired and dropped, and the pipelines stay in the mapper's cache.
    pub fn prepare(&self) {
        let texture = |format, usage| {
            self.ctx.device.create_texture(&wgpu::TextureDescriptor {
                label: Some("tonegate.tone_mapper.prepare"),
                size: wgpu::Extent3d {
                    width: 1,
                    height: 1,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let input = texture(INPUT_FORMATS[0], wgpu::TextureUsages::TEXTURE_BINDING);
        let output = texture(OUTPUT_FORMAT, wgpu::TextureUsages::STORAGE_BINDING);
        drop(self.wire(&input, &output));
    }

    /// How many pipelines the mapper has compiled so far (each operator,
    /// operator constants and stage once): what a caller counts to see that
    /// a settings change compiled nothing.
    pub fn compiled_pipelines(&self) -> usize {
        self.ctx.cached_pipelines()
    }

    /// Maps with `settings` from the next [`ToneMapper::record`] on. The
    /// same operator with other parameters held in its uniform (the
    /// exposure, a Reinhard key, …) is one uniform write through the
    /// queue: nothing is compiled and the bindings stay. A parameter that
    /// is one of the operator's shader constants, or another operator, is
    /// a new pipeline, compiled once (on the next `prepare` or `record`)
    /// and kept, so switching back compiles nothing.
    pub fn set_settings(&mut self, settings: ToneMapperSettings) -> Result<(), ToneMapperError> {
        check_settings(&settings)?;
        let (op, was) = (&settings.operator, &self.settings.operator);
        let config = ToneParams::config_of(op);
        let same_shader = op.definition().wgsl() == self.params.module
            && ToneParams::constants_of(op, None) == self.params.constants
            && op.needs() == was.needs()
            && op.luminance() == was.luminance()
            && settings.encoding == self.settings.encoding
            && (config.len() * 4) as u64 == self.params.config.size();
        if same_shader {
            self.ctx
                .queue
                .write_buffer(&self.params.config, 0, bytemuck::cast_slice(&config));
        } else {
            self.params = ToneParams::new(&self.ctx, op, None);
            self.bound = None;
        }
        self.settings = settings;
        Ok(())
    }

    /// Records the tone mapping of `input` into `output` as one compute pass
    /// of `encoder`; nothing is submitted.
    ///
    /// `input`: one of [`INPUT_FORMATS`], with `TEXTURE_BINDING`. `output`:
    /// [`OUTPUT_FORMAT`], with `STORAGE_BINDING`, the same size. Either
    /// being otherwise is an error that says which and why, before anything
    /// is recorded. Resources for a pair of textures are kept until another
    /// pair is passed.
    pub fn record(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        input: &wgpu::Texture,
        output: &wgpu::Texture,
    ) -> Result<(), ToneMapperError> {
        let reuse = self
            .bound
            .as_ref()
            .is_some_and(|b| b.input == *input && b.output == *output);
        if !reuse {
            check_textures(&self.ctx, input, output)?;
            let dispatches = self.wire(input, output);
            self.bound = Some(Bound {
                input: input.clone(),
                output: output.clone(),
                dispatches,
            });
        }
        let bound = self.bound.as_ref().expect("bound above");
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("tonegate.tone_mapper"),
            timestamp_writes: None,
        });
        for d in &bound.dispatches {
            d.record(&mut pass);
        }
        Ok(())
    }

    /// The dispatches from `input` to `output`: statistics, tone map,
    /// encode, with an intermediate texture for the tone-mapped frame.
    fn wire(&self, input: &wgpu::Texture, output: &wgpu::Texture) -> Vec<Dispatch> {
        let ctx = &self.ctx;
        // Intermediates in f32, as tonegate's renderer keeps them by default.
        let format = HdrFormat::Rgba32Float;
        let (width, height) = (input.width(), input.height());
        let extent = extent_buffer(
            ctx,
            Extent {
                frame: [width, height],
                low: [width.div_ceil(2).max(1), height.div_ceil(2).max(1)],
            },
        );
        let op = &self.settings.operator;
        let mut dispatches = Vec::new();
        let needs = op.needs();
        if needs.any() {
            let lum = op.luminance();
            dispatches.extend(super::luminance_stats::luminance_stats(
                ctx,
                format,
                self.reduction,
                needs,
                lum.weights,
                lum.delta,
                input,
                &self.stats,
                &extent,
            ));
        }
        let toned = hdr_texture(ctx, "tonegate.tonemap", width, height, format);
        dispatches.extend(super::tonemap::tonemap(
            ctx,
            format,
            &self.params,
            &self.stats,
            input,
            &toned,
            &extent,
        ));
        dispatches.push(super::encode::encode_to_texture(
            ctx,
            format,
            self.settings.encoding,
            &toned,
            output,
            &extent,
        ));
        dispatches
    }
}

/// Refuses settings a [`ToneMapper`] cannot map with.
fn check_settings(settings: &ToneMapperSettings) -> Result<(), ToneMapperError> {
    match settings.encoding {
        Encoding::Pq => Err(ToneMapperError::PqIntoEightBits),
        _ => Ok(()),
    }
}

/// Refuses textures [`ToneMapper::record`] cannot use, naming which and why.
fn check_textures(
    ctx: &GpuContext,
    input: &wgpu::Texture,
    output: &wgpu::Texture,
) -> Result<(), ToneMapperError> {
    use wgpu::TextureUsages as U;
    if !INPUT_FORMATS.contains(&input.format()) {
        return Err(ToneMapperError::InputFormat {
            format: input.format(),
        });
    }
    if output.format() != OUTPUT_FORMAT {
        return Err(ToneMapperError::OutputFormat {
            format: output.format(),
        });
    }
    for (texture, t, usage) in [
        (TextureRole::Input, input, U::TEXTURE_BINDING),
        (TextureRole::Output, output, U::STORAGE_BINDING),
    ] {
        if !t.usage().contains(usage) {
            return Err(ToneMapperError::MissingUsage { texture, usage });
        }
        if t.dimension() != wgpu::TextureDimension::D2
            || t.depth_or_array_layers() != 1
            || t.sample_count() != 1
        {
            return Err(ToneMapperError::NotSingleLayer { texture });
        }
    }
    if input.size() != output.size() {
        return Err(ToneMapperError::SizeMismatch {
            input: (input.width(), input.height()),
            output: (output.width(), output.height()),
        });
    }
    ctx.check_frame(input.width(), input.height())
        .map_err(ToneMapperError::Limits)
}
