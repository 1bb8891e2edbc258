//! Wiring a plan's stages into passes, in plan order: which texture or
//! buffer each stage reads, which it writes, and which outputs can be read
//! back. Fused execution (`super::fused`) takes over the stages it merges and
//! leaves the rest to [`Wiring::staged`].

use crate::gpu::luminance_stats::GpuStats;
use crate::gpu::sphere::{Environment, FrameUniforms};
use crate::gpu::stages::{hdr_texture, shared_buffer, storage_buffer, upload, Dispatch, ImageView};
use crate::gpu::tonemap::OperatorShader;
use crate::gpu::{GpuConfig, GpuContext, GpuError, GpuInput, HdrFormat};
use crate::plan::{BloomSource, PlanError, Stage};
use crate::reference::bloom_downsample::downsampled_size;
use crate::reference::Pipeline;
use crate::scene::Bloom;

/// One compute pass: a stage (or merged stages) and its dispatches.
pub struct Pass {
    pub name: &'static str,
    pub dispatches: Vec<Dispatch>,
    /// The dispatches of odd frames, for a stage whose bindings alternate
    /// (the TAA history's ping-pong pair); None: `dispatches` every frame.
    pub odd: Option<Vec<Dispatch>>,
}

impl Pass {
    /// A stage that runs inside another stage's pass.
    pub fn merged(name: &'static str) -> Pass {
        Pass::every_frame(name, Vec::new())
    }

    /// A pass with the same dispatches every frame.
    pub fn every_frame(name: &'static str, dispatches: Vec<Dispatch>) -> Pass {
        Pass {
            name,
            dispatches,
            odd: None,
        }
    }
}

/// The frame's resources while its stages are wired.
pub struct Wiring<'a, 'p> {
    pub ctx: &'a GpuContext,
    pub format: HdrFormat,
    pub width: u32,
    pub height: u32,
    pub pipeline: &'p Pipeline<'p>,
    pub reduction: crate::gpu::ReductionMethod,
    /// Fault injection: a gain on the tone-mapped colour (`check --fault-gain`).
    pub fault_gain: Option<f32>,
    /// Fault injection: a broken TAA (`check --taa-fault`).
    pub taa_fault: Option<crate::gpu::TaaFault>,
    /// How the stages that resample a texture filter it.
    pub filter: crate::gpu::EnvFilter,
    /// The operator's luminance weights and δ.
    pub weights: [f64; 3],
    pub delta: f64,
    /// The HDR frame the operator reads: `sphere`'s output (`taa`'s in a TAA
    /// plan), or the uploaded flat image, or a caller's texture (whose
    /// view `hdr_view` is).
    pub hdr: wgpu::Texture,
    /// The view of `hdr` the stages read.
    pub hdr_view: ImageView,
    /// In a TAA plan, `sphere`'s jittered frame, which `taa` resolves into `hdr`.
    pub current: Option<wgpu::Texture>,
    /// `taa_sobel`'s aliasing amount.
    pub amount: Option<wgpu::Texture>,
    /// `taa`'s history pair and uniforms; set before wiring, the caller's
    /// (a `ToneMapper` keeps its history across pairs of views), reused by
    /// the stage when of the frame's size.
    pub taa: Option<crate::gpu::taa::TaaResources>,
    /// The caller's motion vectors, which `taa` finds the history by where
    /// there is no camera (a `ToneMapper`'s input).
    pub motion: Option<wgpu::TextureView>,
    /// `adaptation`'s state and per-frame step, with its parameters; set
    /// before wiring, it is the caller's (a `ToneMapper` keeps its state
    /// across pairs of views), and the stage reuses it.
    pub adaptation: Option<crate::gpu::adaptation::AdaptationResources>,
    /// The operator's shader, when the caller keeps it (a `ToneMapper`
    /// writes its uniform per frame); else `tonemap` makes its own.
    pub shader: Option<OperatorShader>,
    /// `luminance_stats`'s output and the resolved operator parameters.
    pub stats: wgpu::Buffer,
    /// `encode`'s packed 8-bit frame, made when `encode` is wired.
    pub frame: Option<wgpu::Buffer>,
    /// The part of the textures the frame covers (`stages::Extent`): the
    /// textures are `width`×`height`, which a size class may make larger.
    pub extent: wgpu::Buffer,
    /// The environment and the frame uniforms `sphere` reads.
    pub environment: Option<(Environment, wgpu::Buffer)>,
    /// Stage outputs that can be read back: (stage name, texture).
    pub outputs: Vec<(&'static str, wgpu::Texture)>,
    /// The texture the next display-referred stage reads.
    pub display: Option<wgpu::Texture>,
    pub toned: Option<wgpu::Texture>,
    pub bright: Option<wgpu::Texture>,
    pub low: Option<wgpu::Texture>,
    pub blurred: Option<wgpu::Texture>,
    pub grade_mean: Option<wgpu::Buffer>,
    /// Fused execution: the operator's parameters for the merged kernels,
    /// whether their resolve step still has to run, and the bright pass's source.
    pub tone: Option<OperatorShader>,
    pub pending_resolve: bool,
    pub bright_source: Option<BloomSource>,
    /// The bloom (blurred texture, strength) the fused tail adds.
    pub composite: Option<(wgpu::Texture, f64)>,
}

impl<'a, 'p> Wiring<'a, 'p> {
    /// The frame's fixed resources (textures of `width`×`height`, the
    /// capacity) and its input uploaded: what the plan's stages are then
    /// wired between.
    pub(in crate::gpu) fn new(
        ctx: &'a GpuContext,
        input: &GpuInput,
        pipeline: &'p Pipeline<'p>,
        config: GpuConfig,
        (width, height): (u32, u32),
        taa: bool,
        extent: wgpu::Buffer,
    ) -> Result<Wiring<'a, 'p>, GpuError> {
        let format = config.hdr_format;
        let lum = pipeline.operator.luminance();
        let (weights, delta) = (lum.weights, lum.delta);
        let (hdr, environment) = match input {
            GpuInput::Sphere { env, .. } => {
                let environment = Environment::upload(ctx, env, config.env_filter)?;
                let uniforms = crate::gpu::stages::uniform_buffer(
                    ctx,
                    "tonegate.sphere.frame",
                    &[0u8; std::mem::size_of::<FrameUniforms>()],
                );
                let hdr = hdr_texture(ctx, "tonegate.sphere", width, height, format);
                (hdr, Some((environment, uniforms)))
            }
            GpuInput::Flat(img) => {
                let hdr = hdr_texture(ctx, "tonegate.input", width, height, format);
                upload(ctx, &hdr, img, format);
                (hdr, None)
            }
            GpuInput::View(v) => (v.view.texture().clone(), None),
        };
        // A TAA plan's sphere writes the jittered frame, and `taa` the frame the
        // operator reads.
        let (hdr, current) = match taa {
            true => (
                hdr_texture(ctx, "tonegate.taa", width, height, format),
                Some(hdr),
            ),
            false => (hdr, None),
        };
        let hdr_view = match input {
            GpuInput::View(v) if current.is_none() => (*v).clone(),
            _ => ImageView::whole(&hdr),
        };
        Ok(Wiring {
            ctx,
            format,
            width,
            height,
            pipeline,
            reduction: config.reduction,
            fault_gain: config.fault_gain,
            taa_fault: config.taa_fault,
            filter: config.env_filter,
            current,
            amount: None,
            taa: None,
            motion: None,
            adaptation: None,
            weights,
            delta,
            hdr,
            hdr_view,
            shader: None,
            stats: shared_buffer(
                ctx,
                "tonegate.luminance_stats",
                std::mem::size_of::<GpuStats>() as u64,
            ),
            frame: None,
            extent,
            environment,
            outputs: Vec::new(),
            display: None,
            toned: None,
            bright: None,
            low: None,
            blurred: None,
            grade_mean: None,
            tone: None,
            pending_resolve: false,
            bright_source: None,
            composite: None,
        })
    }
}

impl<'p> Wiring<'_, 'p> {
    /// The operator's shader for `tonemap` or the fused kernels (the
    /// caller's, when it keeps one), its input scaled by adaptation's
    /// auto-exposure where the plan says so.
    pub fn operator_shader(&self) -> OperatorShader {
        let mut shader = match &self.shader {
            Some(p) => p.clone(),
            None => OperatorShader::new(self.ctx, self.pipeline.operator, self.fault_gain),
        };
        shader.exposed = self.adaptation.as_ref().is_some_and(|a| a.exposes());
        shader
    }

    /// `encode`'s packed frame buffer, made on first use.
    pub fn frame_buffer(&mut self) -> wgpu::Buffer {
        let bytes = self.width as u64
            * self.height as u64
            * crate::gpu::encode::frame_bytes_per_pixel(self.pipeline.encoding);
        let ctx = self.ctx;
        self.frame
            .get_or_insert_with(|| storage_buffer(ctx, "tonegate.encode", bytes))
            .clone()
    }

    /// The bloom's parameters, which every bloom stage needs.
    pub fn bloom(&self, stage: &'static str) -> Result<&'p Bloom, PlanError> {
        self.pipeline.bloom.ok_or(PlanError::NoParameters {
            stage,
            what: "bloom",
        })
    }

    fn texture(&self, stage: &'static str, width: u32, height: u32) -> wgpu::Texture {
        hdr_texture(
            self.ctx,
            &format!("tonegate.{stage}"),
            width,
            height,
            self.format,
        )
    }

    /// Wires `stage` as its own pass (the staged execution).
    pub fn staged(&mut self, stage: &Stage) -> Result<Pass, GpuError> {
        let name = stage.name();
        let (ctx, format) = (self.ctx, self.format);
        let order = |needs| PlanError::order(name, needs);
        let dispatches = match stage {
            Stage::Sphere { spp } => {
                let (env, uniforms) = self.environment.as_ref().ok_or(PlanError::NoParameters {
                    stage: name,
                    what: "environment",
                })?;
                let target = self.current.as_ref().unwrap_or(&self.hdr);
                self.outputs.push((name, target.clone()));
                vec![crate::gpu::sphere::sphere(
                    ctx, format, *spp, uniforms, env, target,
                )]
            }
            Stage::TaaSobel => {
                let current = self.current.clone().ok_or(order("sphere"))?;
                let amount =
                    crate::gpu::taa_sobel::amount_texture(ctx, current.width(), current.height());
                let d = crate::gpu::taa_sobel::taa_sobel(ctx, format, &current, &amount);
                self.outputs.push((name, amount.clone()));
                self.amount = Some(amount);
                vec![d]
            }
            Stage::Taa(params) => {
                let current = self.current.clone().ok_or(order("sphere"))?;
                // The camera's uniforms, or for motion vectors the film's
                // size alone.
                let frame = match (&self.motion, &self.environment) {
                    (Some(_), _) => sized_frame_uniforms(ctx, self.width, self.height),
                    (None, Some((_, uniforms))) => uniforms.clone(),
                    (None, None) => {
                        return Err(PlanError::NoParameters {
                            stage: name,
                            what: "camera or motion vectors",
                        }
                        .into())
                    }
                };
                let io = crate::gpu::taa::TaaTextures {
                    frame: &frame,
                    current: &current,
                    amount: self.amount.as_ref(),
                    motion: self.motion.as_ref(),
                    out: &self.hdr,
                };
                let made = crate::gpu::taa::taa(
                    ctx,
                    format,
                    params,
                    (self.taa_fault, self.filter),
                    &io,
                    self.taa.take(),
                )?;
                self.outputs.push((name, self.hdr.clone()));
                self.taa = Some(made.resources);
                return Ok(Pass {
                    name,
                    dispatches: made.even,
                    odd: Some(made.odd),
                });
            }
            Stage::LuminanceStats(needs) => crate::gpu::luminance_stats::luminance_stats(
                ctx,
                format,
                self.reduction,
                *needs,
                self.weights,
                self.delta,
                &self.hdr_view,
                &self.stats,
                &self.extent,
            ),
            Stage::Histogram(stage) => {
                let made = self.adaptation.take().unwrap_or_else(|| {
                    crate::gpu::adaptation::AdaptationResources::new(ctx, *stage)
                });
                let d = crate::gpu::histogram::histogram(
                    ctx,
                    format,
                    self.reduction,
                    self.weights,
                    &self.hdr_view.view,
                    (self.hdr_view.width, self.hdr_view.height),
                    &made.bins,
                    &made.steps,
                    &self.extent,
                );
                self.adaptation = Some(made);
                vec![d]
            }
            Stage::Adaptation(stage) => {
                let made = self.adaptation.take().unwrap_or_else(|| {
                    crate::gpu::adaptation::AdaptationResources::new(ctx, *stage)
                });
                let d = made.dispatch(ctx, format, &self.stats);
                self.adaptation = Some(made);
                vec![d]
            }
            Stage::Tonemap { .. } => {
                let out = self.texture(name, self.width, self.height);
                let shader = self.operator_shader();
                let d = crate::gpu::tonemap::tonemap(
                    ctx,
                    format,
                    &shader,
                    &self.stats,
                    &self.hdr_view,
                    &out,
                    &self.extent,
                );
                self.outputs.push((name, out.clone()));
                self.toned = Some(out.clone());
                self.display = Some(out);
                d
            }
            Stage::BloomBright { source } => {
                let b = self.bloom(name)?;
                let src = match source {
                    BloomSource::Hdr => self.hdr_view.clone(),
                    BloomSource::Toned => {
                        ImageView::whole(self.toned.as_ref().ok_or(order("tonemap"))?)
                    }
                };
                let out = self.texture(name, self.width, self.height);
                let d = crate::gpu::bloom_bright::bloom_bright(
                    ctx,
                    format,
                    b,
                    self.weights,
                    &self.stats,
                    &src,
                    &out,
                    &self.extent,
                );
                self.bright = Some(out);
                vec![d]
            }
            Stage::BloomDownsample { factor } => {
                let (lw, lh) = downsampled_size(self.width, self.height, *factor);
                let out = self.texture(name, lw, lh);
                let src = self.bright.take().ok_or(order("bloom_bright"))?;
                let d = crate::gpu::bloom_downsample::bloom_downsample(
                    ctx,
                    format,
                    *factor,
                    &src,
                    &out,
                    &self.extent,
                );
                self.low = Some(out);
                vec![d]
            }
            Stage::BloomBlur { radius } => {
                let sigma = self.bloom(name)?.sigma.get();
                let src = self.low.take().ok_or(order("bloom_downsample"))?;
                let (w, h) = (src.width(), src.height());
                let tmp = hdr_texture(ctx, "tonegate.bloom_blur.horizontal", w, h, format);
                let out = self.texture(name, w, h);
                let d = crate::gpu::bloom_blur::bloom_blur(
                    ctx,
                    format,
                    *radius,
                    sigma,
                    &src,
                    &tmp,
                    &out,
                    &self.extent,
                );
                self.outputs.push((name, out.clone()));
                self.blurred = Some(out);
                d
            }
            Stage::BloomComposite => {
                let strength = self.bloom(name)?.strength.get();
                let base = self.display.take().ok_or(order("tonemap"))?;
                let blurred = self.blurred.clone().ok_or(order("bloom_blur"))?;
                let out = self.texture(name, self.width, self.height);
                let d = crate::gpu::bloom_composite::bloom_composite(
                    ctx,
                    format,
                    strength,
                    &base,
                    &blurred,
                    &out,
                    &self.extent,
                );
                self.outputs.push((name, out.clone()));
                self.display = Some(out);
                vec![d]
            }
            Stage::GradeStats => {
                let base = self.display.clone().ok_or(order("tonemap"))?;
                let mean = shared_buffer(ctx, "tonegate.grade_stats", 4);
                let d = crate::gpu::grade_stats::grade_stats(
                    ctx,
                    format,
                    self.reduction,
                    &base,
                    &mean,
                    &self.extent,
                );
                self.grade_mean = Some(mean);
                d
            }
            Stage::Grade => {
                let g = self.pipeline.grade.ok_or(PlanError::NoParameters {
                    stage: name,
                    what: "grade",
                })?;
                let base = self.display.take().ok_or(order("tonemap"))?;
                // Without contrast the mean is unused: a zero buffer stands in.
                let mean = self
                    .grade_mean
                    .clone()
                    .unwrap_or_else(|| shared_buffer(ctx, "tonegate.grade.unused_mean", 4));
                let out = self.texture(name, self.width, self.height);
                let d = crate::gpu::grade::grade(ctx, format, g, &mean, &base, &out, &self.extent);
                self.outputs.push((name, out.clone()));
                self.display = Some(out);
                vec![d]
            }
            Stage::Encode => {
                let base = self.display.clone().ok_or(order("tonemap"))?;
                self.outputs.push(("display", base.clone()));
                let frame = self.frame_buffer();
                vec![crate::gpu::encode::encode(
                    ctx,
                    format,
                    self.pipeline.encoding,
                    self.pipeline.operator.display_levels(),
                    &base,
                    &frame,
                    &self.extent,
                )]
            }
        };
        Ok(Pass::every_frame(name, dispatches))
    }
}

/// Frame uniforms that hold only the film's size: what the `taa` stage
/// reads of them when motion vectors take the camera's place.
fn sized_frame_uniforms(ctx: &GpuContext, width: u32, height: u32) -> wgpu::Buffer {
    let u = FrameUniforms {
        size: [width, height],
        ..bytemuck::Zeroable::zeroed()
    };
    crate::gpu::stages::uniform_buffer(ctx, "tonegate.taa.frame", bytemuck::bytes_of(&u))
}
