//! [`ToneMapper`]: tonegate's tone mapper inside someone else's wgpu
//! application, on the caller's device and queue, recorded into the
//! caller's command encoder, from a view of the caller's HDR texture to a
//! view of the caller's target (docs/embedding.md).
//!
//! It runs the plan tonegate's own renderer runs for a flat image
//! (`StagePlan::build`, with `with_adaptation`): the luminance statistics
//! (when the operator needs them), eye adaptation, the operator (its
//! resolve step, then its curve), bloom and grade, after TAA when the
//! application gives motion vectors (`with_taa`), each stage wired by the
//! renderer's own `Wiring::staged`; then the display encoding, written into
//! the target by a compute pass or a fullscreen triangle (`wire`). The same
//! code, shaders and pipelines, so the same bits: an input texture in
//! `Rgba32Float` gives the bytes `tonegate tonemap --gpu` writes on the
//! same adapter, in every 8-bit target and by either path.

mod cameras;
mod record;
mod settings;
mod taa;
mod target;
mod timing;
mod uniforms;
mod wire;

pub use cameras::MAX_CAMERAS;
pub use settings::ToneMapperSettings;
pub use taa::{MotionUnits, MotionVectors, MOTION_FORMATS};
pub use target::{
    OutputPath, SourceView, TargetView, TextureRole, ToneMapperError, INPUT_FORMATS, TARGET_FORMATS,
};
pub use timing::MapperTimings;

use super::adaptation::{adapted_buffer, steps_buffer};
use super::config::ReductionMethod;
use super::histogram::bins_buffer;
use super::stages::{shared_buffer, uniform_buffer, Dispatch, ImageView};
use super::tonemap::OperatorShader;
use super::{GpuContext, GpuStats};
use crate::scene::Encoding;
use settings::check_settings;
use target::storable;

/// What one input was wired for: its view, the image's size in it and,
/// with TAA, the motion vectors' view. The target is no part of it: every
/// target (a swap chain's new texture each frame among them) is written
/// from the same intermediates.
#[derive(Clone, PartialEq)]
struct WiredKey {
    input: wgpu::TextureView,
    size: (u32, u32),
    /// The motion vectors' view, with TAA.
    motion: Option<wgpu::TextureView>,
}

/// Where one record writes, checked: the view, where the image goes in it
/// and by which path.
struct Sink<'v> {
    view: &'v wgpu::TextureView,
    origin: (u32, u32),
    compute: bool,
}

/// The inputs a mapper keeps the resources of.
const KEPT_INPUTS: usize = 4;

/// The storage targets an input keeps the last dispatch into: a swap
/// chain's three and one more. A view not among them costs two bind
/// groups, nothing else.
const KEPT_TARGETS: usize = 4;

/// The resources of one input: kept for the [`KEPT_INPUTS`] used last.
struct Bound {
    key: WiredKey,
    wired: Wired,
}

/// An input's passes up to the display image, wired by the executor the
/// gate's renderer records with, and what writes that image into the
/// targets.
struct Wired {
    exec: super::exec::Executor,
    /// The display image the target is written from.
    display: wgpu::Texture,
    /// The image's extent uniform.
    extent: wgpu::Buffer,
    /// The TAA history the dispatches read and write.
    history: Option<super::taa::TaaResources>,
    /// The fullscreen triangle into a render attachment: its pipeline and
    /// its bind group (the display image, the origin uniform), made when
    /// first drawn.
    draw: Option<(wgpu::RenderPipeline, wgpu::BindGroup)>,
    /// The compute path's last dispatch into each storage target written
    /// lately, the newest last.
    stores: Vec<(wgpu::TextureView, Dispatch)>,
}

/// Tone-maps a caller's HDR texture into a caller's target on the caller's
/// device.
///
/// ```no_run
/// # fn demo(device: &wgpu::Device, queue: &wgpu::Queue, hdr: &wgpu::TextureView, swap: &wgpu::TextureView) -> Result<(), tonegate::gpu::ToneMapperError> {
/// use tonegate::gpu::{ToneMapper, ToneMapperSettings};
/// let mut mapper = ToneMapper::new(device, queue, ToneMapperSettings {
///     target: wgpu::TextureFormat::Bgra8UnormSrgb,
///     ..ToneMapperSettings::default()
/// })?;
/// // Every pipeline now, not in the first frame.
/// mapper.prepare()?;
/// let mut encoder = device.create_command_encoder(&Default::default());
/// mapper.record(&mut encoder, hdr, swap)?;
/// queue.submit([encoder.finish()]);
/// # Ok(()) }
/// ```
pub struct ToneMapper {
    ctx: GpuContext,
    settings: ToneMapperSettings,
    reduction: ReductionMethod,
    shader: OperatorShader,
    stats: wgpu::Buffer,
    /// The operator's uniform words for its current parameters.
    config: Vec<f32>,
    /// Where `config` holds the operator's exposure, and the range it is
    /// held to, for [`ToneMapper::set_exposure`].
    exposure: Option<(crate::operators::ExposureWord, (f64, f64))>,
    /// The inputs wired, the one used last at the end.
    bound: Vec<Bound>,
    /// Where the image goes in the target, written per record.
    origin: wgpu::Buffer,
    /// Each record's uniform values, copied in by its own encoder.
    ring: uniforms::UniformRing,
    /// What the frames are adapted to, carried between records.
    adapted: wgpu::Buffer,
    /// The adaptation's step, copied in by each record.
    steps: wgpu::Buffer,
    /// The histogram's bins, between its pass and adaptation's.
    bins: wgpu::Buffer,
    /// Seconds between frames, for the adaptation's step.
    frame_seconds: f64,
    /// Each camera's adapted state, and which the next records adapt.
    cameras: cameras::Cameras,
    /// Timestamp queries around the passes, once enabled.
    stamps: Option<timing::Stamps>,
    /// The TAA history, carried between records.
    history: taa::History,
}

/// The frame time a [`ToneMapper`] adapts with until told otherwise.
pub const DEFAULT_FRAME_SECONDS: f64 = 1.0 / 60.0;

impl ToneMapper {
    /// A tone mapper on the caller's `device` and `queue`, or why not.
    /// Pipelines are compiled by [`ToneMapper::prepare`], or else on the
    /// first [`ToneMapper::record`], and kept; the operator's parameters
    /// are written to a uniform through `queue` here.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        settings: ToneMapperSettings,
    ) -> Result<ToneMapper, ToneMapperError> {
        check_settings(&settings, device.features())?;
        Ok(ToneMapper::on_context(
            GpuContext::from_device(device, queue),
            settings,
        ))
    }

    /// A mapper on `ctx` with checked `settings`.
    fn on_context(ctx: GpuContext, settings: ToneMapperSettings) -> ToneMapper {
        // The reduction tonegate's own renderer picks on this adapter.
        let reduction = ReductionMethod::Auto.resolve(ctx.traits());
        let shader = OperatorShader::new(&ctx, &settings.operator, None);
        let stats = shared_buffer(
            &ctx,
            "tonegate.luminance_stats",
            std::mem::size_of::<GpuStats>() as u64,
        );
        ToneMapper {
            config: OperatorShader::config_of(&settings.operator),
            exposure: exposure_of(&settings.operator),
            settings,
            reduction,
            shader,
            stats,
            bound: Vec::new(),
            origin: uniform_buffer(&ctx, "tonegate.encode.target_origin", &[0; 16]),
            ring: uniforms::UniformRing::new(&ctx),
            adapted: adapted_buffer(&ctx),
            steps: steps_buffer(&ctx),
            bins: bins_buffer(&ctx),
            frame_seconds: DEFAULT_FRAME_SECONDS,
            cameras: cameras::Cameras::new(&ctx),
            stamps: None,
            history: taa::History::default(),
            ctx,
        }
    }

    /// What it maps with.
    pub fn settings(&self) -> &ToneMapperSettings {
        &self.settings
    }

    /// Compiles every pipeline the current settings need, so that the
    /// first [`ToneMapper::record`] does not (a frame's hitch otherwise):
    /// under [`OutputPath::Auto`], both paths' where the target format
    /// allows both. The pipelines do not depend on the frame's size: a
    /// one-pixel pair is wired and dropped, and the pipelines stay in the
    /// mapper's cache.
    pub fn prepare(&mut self) -> Result<(), ToneMapperError> {
        let texture = |format, usage| {
            self.ctx.create_texture(&wgpu::TextureDescriptor {
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
        let input = ImageView::whole(&texture(
            INPUT_FORMATS[0],
            wgpu::TextureUsages::TEXTURE_BINDING,
        ));
        let target = self.settings.target;
        let (compute, render) = self.paths();
        let output = texture(
            target,
            if compute {
                wgpu::TextureUsages::STORAGE_BINDING
            } else {
                wgpu::TextureUsages::RENDER_ATTACHMENT
            },
        );
        let view = output.create_view(&Default::default());
        let motion = self.has_taa().then(|| {
            texture(MOTION_FORMATS[0], wgpu::TextureUsages::TEXTURE_BINDING)
                .create_view(&Default::default())
        });
        let wired = self.wire(&input, motion.as_ref())?;
        if compute {
            drop(self.store_dispatch(&wired, &view));
        }
        if render {
            drop(self.draw(&wired.display));
        }
        Ok(())
    }

    /// The paths the settings allow: (compute, render pass).
    fn paths(&self) -> (bool, bool) {
        let storage = storable(self.settings.target, self.ctx.device.features());
        match self.settings.path {
            OutputPath::Auto => (storage, true),
            OutputPath::Compute => (true, false),
            OutputPath::RenderPass => (false, true),
        }
    }

    /// How many pipelines the mapper has compiled so far (each operator,
    /// operator constants, stage and target once), with the mappers it
    /// shares them with: what a caller counts to see that a settings change
    /// compiled nothing.
    pub fn compiled_pipelines(&self) -> usize {
        self.ctx.cached_pipelines()
    }

    /// What this mapper has created on the device since it was made:
    /// textures, buffers, bind groups and pipelines. A frame loop reads it
    /// twice to see what its frames created (docs/embedding.md#what-a-frame-creates):
    /// once warm, nothing but two bind groups for a storage target it has
    /// not seen among the last few, and nothing at all into a render
    /// attachment.
    pub fn created(&self) -> super::Created {
        self.ctx.created()
    }

    /// A second mapper on the same device and queue, with its own
    /// `settings`, adaptation state and TAA history, sharing this one's
    /// compiled pipelines: another camera compiles nothing this mapper
    /// has. (One mapper already gives each record its own settings and,
    /// by [`ToneMapper::set_camera`], each camera its own adaptation
    /// state; a second one is for a second TAA history.)
    pub fn sharing_pipelines(
        &self,
        settings: ToneMapperSettings,
    ) -> Result<ToneMapper, ToneMapperError> {
        check_settings(&settings, self.ctx.device.features())?;
        Ok(ToneMapper::on_context(
            self.ctx.sharing_pipelines(),
            settings,
        ))
    }

    /// Maps with `settings` from the next [`ToneMapper::record`] on; the
    /// records before keep the settings they were recorded with, even in
    /// the same submission. The same operator with other parameters held
    /// in its uniform (the exposure, a Reinhard key, …) compiles nothing
    /// and keeps the bindings: each record copies its own values into the
    /// uniform. A parameter that
    /// is one of the operator's shader constants, another operator,
    /// encoding, target or path is new pipelines, compiled once (on the
    /// next `prepare` or `record`) and kept, so switching back compiles
    /// nothing.
    pub fn set_settings(&mut self, settings: ToneMapperSettings) -> Result<(), ToneMapperError> {
        check_settings(&settings, self.ctx.device.features())?;
        if settings == self.settings {
            return Ok(());
        }
        let (op, was) = (&settings.operator, &self.settings.operator);
        let config = OperatorShader::config_of(op);
        let same_shader = op.definition().wgsl() == self.shader.module
            && OperatorShader::constants_of(op, None) == self.shader.constants
            && op.needs() == was.needs()
            && op.luminance() == was.luminance()
            && settings.encoding == self.settings.encoding
            && (settings.encoding != Encoding::Pq || op.display_levels() == was.display_levels())
            && settings.target == self.settings.target
            && settings.path == self.settings.path
            && settings.adaptation.map(|a| a.metering)
                == self.settings.adaptation.map(|a| a.metering)
            && settings.bloom == self.settings.bloom
            && settings.grade == self.settings.grade
            && settings.taa == self.settings.taa
            && (config.len() * 4) as u64 == self.shader.config.size();
        if !same_shader {
            self.shader = OperatorShader::new(&self.ctx, op, None);
            self.bound.clear();
            if settings.taa != self.settings.taa {
                self.history = taa::History::default();
            }
        }
        self.config = config;
        self.exposure = exposure_of(&settings.operator);
        self.settings = settings;
        Ok(())
    }

    /// Maps with `exposure` (a gain on the linear input: 2 is a stop
    /// brighter) from the next [`ToneMapper::record`] on, for an operator
    /// with an `exposure` parameter (every fixed curve, AgX, the ACES
    /// curves, BT.2390): the same frames as [`ToneMapper::set_settings`]
    /// with that parameter, bit for bit, but one word written in place,
    /// with nothing allocated, compared or compiled, so a game can call it
    /// every frame. It cannot fail: an exposure outside the parameter's
    /// range (1e-6 to 1e6) is held to it, and one that is not a number
    /// leaves the exposure as it was. False, with nothing changed, for an
    /// operator without an exposure (the Reinhard family keys on the
    /// frame's luminance instead: its `key` is a setting). `settings()`
    /// keeps the operator's values as last set; the exposure in effect is
    /// [`ToneMapper::exposure`].
    pub fn set_exposure(&mut self, exposure: f32) -> bool {
        let Some((word, (lo, hi))) = self.exposure else {
            return false;
        };
        if !exposure.is_nan() {
            self.config[word.index] = word.word(f64::from(exposure).clamp(lo, hi));
        }
        true
    }

    /// The exposure the next record maps with, for an operator with one.
    pub fn exposure(&self) -> Option<f64> {
        let (word, _) = self.exposure?;
        Some(f64::from(self.config[word.index]) * word.divisor)
    }

    /// The seconds between the frames recorded from now on, for the
    /// adaptation's step (a game's frame time; [`DEFAULT_FRAME_SECONDS`]
    /// until set). Refused unless finite and ≥ 0; 0 holds the adapted
    /// luminance where it is.
    pub fn set_frame_seconds(&mut self, seconds: f64) -> Result<(), ToneMapperError> {
        if !(seconds.is_finite() && seconds >= 0.0) {
            return Err(ToneMapperError::FrameSeconds { seconds });
        }
        self.frame_seconds = seconds;
        Ok(())
    }

    /// The current camera's next frame adapts at once to its own
    /// measurement (a cut, a teleport); each camera's first frame does
    /// anyway.
    pub fn reset_adaptation(&mut self) {
        self.cameras.reset[self.cameras.current] = true;
    }

    /// The camera the records from now on adapt (0 until set; at most
    /// [`MAX_CAMERAS`]): each keeps its own adapted state and reset, so
    /// one mapper serves several views, in one submission too, each
    /// adapting to its own frames. Settings, exposure and frame time stay
    /// the mapper's.
    pub fn set_camera(&mut self, camera: usize) -> Result<(), ToneMapperError> {
        if camera >= MAX_CAMERAS {
            return Err(ToneMapperError::Camera { camera });
        }
        self.cameras.current = camera;
        Ok(())
    }

    /// The camera the next records adapt.
    pub fn camera(&self) -> usize {
        self.cameras.current
    }

    /// The buffer the `adaptation` pass leaves the adapted values in, for
    /// a later pass of the caller's in the same submission to bind as
    /// storage (read-only): after a record, the natural logarithm of the
    /// luminance that record's camera is adapted to (f32 at offset 0; the
    /// weighted log average's at offset 4, where the operator reads one).
    /// A later record overwrites it.
    pub fn adaptation_buffer(&self) -> &wgpu::Buffer {
        &self.adapted
    }

    /// The luminance the current camera's last recorded frame was adapted
    /// to, in scene units (exp of the adapted log average), or `None`
    /// without adaptation or before that camera's first frame. It waits
    /// for the device: for tests and debugging overlays, not for every
    /// frame.
    pub fn read_adapted_luminance(&self) -> Result<Option<f64>, ToneMapperError> {
        if self.settings.adaptation.is_none() || self.cameras.reset[self.cameras.current] {
            return Ok(None);
        }
        let staging = self.ctx.create_buffer(&wgpu::BufferDescriptor {
            label: Some("tonegate.adaptation.read"),
            size: 16,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        self.cameras.copy_current(&mut encoder, &staging);
        self.ctx.queue.submit([encoder.finish()]);
        let bytes = self
            .ctx
            .read_buffer(&staging)
            .map_err(ToneMapperError::Readback)?;
        let ln: f32 = bytemuck::pod_read_unaligned(&bytes[..4]);
        Ok(Some(f64::from(ln).exp()))
    }

    /// Times the mapper's passes from the next frame on, with timestamp
    /// queries (a device opened with `Features::TIMESTAMP_QUERY`; refused
    /// otherwise); [`ToneMapper::read_timings`] reads the last frame's.
    pub fn enable_timestamps(&mut self) -> Result<(), ToneMapperError> {
        let feature = wgpu::Features::TIMESTAMP_QUERY;
        if !self.ctx.device.features().contains(feature) {
            return Err(ToneMapperError::MissingFeature { feature });
        }
        self.stamps = Some(timing::Stamps::new(&self.ctx.device, &self.ctx.queue));
        Ok(())
    }

    /// The GPU time of the last frame recorded (and submitted), or `None`
    /// before [`ToneMapper::enable_timestamps`]. It waits for the device:
    /// read it now and then, not every frame.
    pub fn read_timings(&self) -> Result<Option<MapperTimings>, ToneMapperError> {
        let Some(stamps) = &self.stamps else {
            return Ok(None);
        };
        let ticks = self
            .ctx
            .read_buffer(stamps.read_buffer())
            .map_err(ToneMapperError::Readback)?;
        Ok(Some(stamps.timings(&ticks)))
    }
}

/// Where `op`'s uniform holds its exposure, and the exposure parameter's
/// range.
fn exposure_of(
    op: &crate::operators::Operator,
) -> Option<(crate::operators::ExposureWord, (f64, f64))> {
    let word = op.definition().gpu_exposure_word()?;
    let param = op
        .definition()
        .params()
        .iter()
        .find(|p| p.name == "exposure")?;
    match param.kind {
        crate::operators::Kind::Number(r) | crate::operators::Kind::NumberOrAuto(r) => {
            Some((word, (r.min, r.max)))
        }
        _ => None,
    }
}
