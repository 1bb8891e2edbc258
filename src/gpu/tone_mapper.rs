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

/// How a [`ToneMapper`] maps: the operator with its parameters, and the
/// display encoding.
#[derive(Clone, Debug)]
pub struct ToneMapperSettings {
    /// The operator (`Operator::named("agx", &[])`, or a caller's own after
    /// `operators::register`).
    pub operator: Operator,
    /// The display encoding: the sRGB transfer or a gamma (a PQ encoding is
    /// refused by [`ToneMapper::record`]: its output texture is 8-bit).
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
/// # fn demo(device: &wgpu::Device, queue: &wgpu::Queue, hdr: &wgpu::Texture, ldr: &wgpu::Texture) -> Result<(), tonegate::gpu::GpuError> {
/// use tonegate::gpu::{ToneMapper, ToneMapperSettings};
/// let mut mapper = ToneMapper::new(device, queue, ToneMapperSettings::default());
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
    /// A tone mapper on the caller's `device` and `queue`. Pipelines are
    /// compiled on the first [`ToneMapper::record`] and kept; the operator's
    /// parameters are written to a uniform through `queue` here.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        settings: ToneMapperSettings,
    ) -> ToneMapper {
        let ctx = GpuContext::from_device(device, queue);
        // The reduction tonegate's own renderer picks on this adapter.
        let reduction = ReductionMethod::Auto.resolve(ctx.traits());
        let params = ToneParams::new(&ctx, &settings.operator, None);
        let stats = shared_buffer(
            &ctx,
            "tonegate.luminance_stats",
            std::mem::size_of::<GpuStats>() as u64,
        );
        ToneMapper {
            ctx,
            settings,
            reduction,
            params,
            stats,
            bound: None,
        }
    }

    /// What it maps with.
    pub fn settings(&self) -> &ToneMapperSettings {
        &self.settings
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
    ) -> Result<(), GpuError> {
        if self.settings.encoding == Encoding::Pq {
            return Err(GpuError::Texture(
                "encoding pq: a PQ frame is 16-bit, and the tone mapper writes an Rgba8Unorm texture; use the sRGB transfer or a gamma".into(),
            ));
        }
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

/// Refuses textures [`ToneMapper::record`] cannot use, naming which and why.
fn check_textures(
    ctx: &GpuContext,
    input: &wgpu::Texture,
    output: &wgpu::Texture,
) -> Result<(), GpuError> {
    let bad = |what: String| Err(GpuError::Texture(what));
    if !INPUT_FORMATS.contains(&input.format()) {
        return bad(format!(
            "the input texture is {:?}; the tone mapper reads Rgba32Float or Rgba16Float (linear HDR)",
            input.format()
        ));
    }
    if !input.usage().contains(wgpu::TextureUsages::TEXTURE_BINDING) {
        return bad("the input texture lacks TEXTURE_BINDING usage".into());
    }
    if output.format() != OUTPUT_FORMAT {
        return bad(format!(
            "the output texture is {:?}; the tone mapper writes Rgba8Unorm (sRGB-encoded values; a storage texture cannot be Rgba8UnormSrgb)",
            output.format()
        ));
    }
    if !output
        .usage()
        .contains(wgpu::TextureUsages::STORAGE_BINDING)
    {
        return bad("the output texture lacks STORAGE_BINDING usage".into());
    }
    for (name, t) in [("input", input), ("output", output)] {
        if t.dimension() != wgpu::TextureDimension::D2
            || t.depth_or_array_layers() != 1
            || t.sample_count() != 1
        {
            return bad(format!(
                "the {name} texture must be a single 2-D layer, not multisampled"
            ));
        }
    }
    if input.size() != output.size() {
        return bad(format!(
            "the input texture is {}x{} and the output {}x{}; they must be the same size",
            input.width(),
            input.height(),
            output.width(),
            output.height()
        ));
    }
    ctx.check_frame(input.width(), input.height())
}
