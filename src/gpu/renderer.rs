//! Executes a stage plan on the GPU: only the plan's stages are created,
//! dispatched and timed.

use super::stages::{hdr_texture, shared_buffer, storage_buffer, Dispatch};
use super::timing::{durations, StageTiming};
use super::{GpuContext, GpuError, HdrFormat};
use crate::conventions::{Camera, Mat3};
use crate::image::{HdrImage, LinearImage, Rgb8Image};
use crate::plan::{BloomSource, Stage, StagePlan};
use crate::reference::bloom_downsample::downsampled_size;
use crate::reference::tonemap::operator_constants;
use crate::reference::Pipeline;
use serde::Serialize;

/// How `luminance_stats` reduces the frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ReductionMethod {
    /// Seed 001: one pass of barrier-free 16×16 block partials, one combine.
    #[default]
    BlockPartials,
    /// Seed 000: log₂ passes of 2×2 downsampling.
    PingPong,
}

impl std::str::FromStr for ReductionMethod {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "block" | "block_partials" => Ok(ReductionMethod::BlockPartials),
            "pingpong" | "ping_pong" => Ok(ReductionMethod::PingPong),
            _ => Err(format!("unknown reduction {s:?}: use block or pingpong")),
        }
    }
}

/// How the plan's stages map onto kernels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Execution {
    /// One kernel per stage: every stage timed and readable on its own.
    #[default]
    Staged,
    /// The display-referred stages merged (shaders/fused.wgsl): tonemap,
    /// bloom_composite and encode in one kernel; bloom_bright and
    /// bloom_downsample in another. Same per-pixel functions in the same
    /// order, fewer full-frame stores and loads. Timed per kernel; the
    /// merged stages' outputs cannot be read back. Plans with a grade run
    /// staged (the grade needs the whole frame's mean first); `notes` says so.
    Fused,
}

impl std::str::FromStr for Execution {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "staged" => Ok(Execution::Staged),
            "fused" => Ok(Execution::Fused),
            _ => Err(format!("unknown execution {s:?}: use staged or fused")),
        }
    }
}

/// The knobs of the GPU path that trade accuracy for speed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct GpuConfig {
    pub hdr_format: HdrFormat,
    pub reduction: ReductionMethod,
    pub env_filter: super::EnvFilter,
    pub execution: Execution,
    /// Fault injection: multiply the tone-mapped colour by this gain, a
    /// deliberately wrong tone mapper that proves the gate catches one
    /// (`check --fault-gain 1.02`). None in every real run.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fault_gain: Option<f32>,
}

/// The statistics and resolved parameters the GPU used (mirrors `Stats` in
/// shaders/shared/stats.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuStats {
    pub log_average: f32,
    pub weighted_log_average: f32,
    pub min: f32,
    pub max: f32,
    pub weight_sum: f32,
    pub key: f32,
    pub adaptation: f32,
    pub scale: f32,
    /// Lwhite (white² is the reference's `white_sq`); <= 0 or +Inf: never burn.
    pub white: f32,
}

impl GpuStats {
    /// The statistics in the reference's shape, for comparing and reporting.
    pub fn luminance_stats(&self) -> crate::reference::luminance_stats::LuminanceStats {
        crate::reference::luminance_stats::LuminanceStats {
            log_average: Some(self.log_average as f64),
            weighted_log_average: Some(self.weighted_log_average as f64),
            min: Some(self.min as f64),
            max: Some(self.max as f64),
            weight_sum: Some(self.weight_sum as f64),
        }
    }
}

/// One rendered frame.
#[derive(Clone, Debug)]
pub struct GpuFrame {
    /// The encoded frame, when read back.
    pub frame: Option<Rgb8Image>,
    pub stats: GpuStats,
    /// GPU time of each stage of the plan (empty without timestamp support).
    pub timings: Vec<StageTiming>,
    /// Wall-clock time from submit to results on the host.
    pub wall_ms: f64,
}

/// Mirrors `FrameUniforms` in shaders/shared/frame.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct FrameUniforms {
    rot: [[f32; 4]; 3],
    size: [u32; 2],
    tan_half: f32,
    aspect: f32,
}

/// Timestamp queries: one (begin, end) pair per stage per slot.
struct Queries {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    read: wgpu::Buffer,
    /// Byte stride of one slot in the resolve buffer (256-aligned).
    stride: u64,
}

/// The environment as the filter reads it: a storage buffer (manual
/// bilinear) or a texture and its sampler (hardware).
type EnvResources = (Option<wgpu::Buffer>, Option<(wgpu::Texture, wgpu::Sampler)>);

/// Frames in flight whose timestamps can be kept before they are read.
pub const TIMING_SLOTS: u32 = 32;

/// The largest finite value f16 (rgba16float) can hold.
pub const F16_MAX: f32 = 65504.0;

/// The largest component of `img` (NaN ignored).
fn max_component(img: &HdrImage) -> f32 {
    img.pixels
        .iter()
        .flat_map(|p| p.iter().copied())
        .fold(0.0f32, f32::max)
}

pub struct GpuRenderer<'a> {
    ctx: &'a GpuContext,
    pub plan: StagePlan,
    /// The configuration in effect (after any f16 → f32 promotion).
    pub config: GpuConfig,
    /// What the renderer changed on its own and why (e.g. f16 promoted to f32).
    pub notes: Vec<String>,
    width: u32,
    height: u32,
    camera: Option<Camera>,
    uniforms: Option<wgpu::Buffer>,
    /// Per plan stage, its dispatches (one compute pass each).
    passes: Vec<(&'static str, Vec<Dispatch>)>,
    /// Stage outputs that can be read back: (stage name, texture).
    outputs: Vec<(&'static str, wgpu::Texture)>,
    stats: wgpu::Buffer,
    stats_read: wgpu::Buffer,
    frame_buf: wgpu::Buffer,
    frame_read: wgpu::Buffer,
    queries: Option<Queries>,
}

fn read_buffer(ctx: &GpuContext, label: &str, size: u64) -> wgpu::Buffer {
    ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// Where the frame comes from.
pub enum GpuInput<'i> {
    /// A sphere view of this environment with this camera at `spp`.
    Sphere {
        env: &'i HdrImage,
        camera: Camera,
        spp: u32,
    },
    /// A flat HDR image.
    Flat(&'i HdrImage),
}

/// Uploads `img` (RGB f32) into an RGBA texture of `format`.
fn upload(ctx: &GpuContext, texture: &wgpu::Texture, img: &HdrImage, format: HdrFormat) {
    let bytes: Vec<u8> = match format {
        HdrFormat::Rgba32Float => {
            let v: Vec<f32> = img
                .pixels
                .iter()
                .flat_map(|p| [p[0], p[1], p[2], 1.0])
                .collect();
            bytemuck::cast_slice(&v).to_vec()
        }
        HdrFormat::Rgba16Float => {
            let v: Vec<u16> = img
                .pixels
                .iter()
                .flat_map(|p| [p[0], p[1], p[2], 1.0].map(|c| half::f16::from_f32(c).to_bits()))
                .collect();
            bytemuck::cast_slice(&v).to_vec()
        }
    };
    ctx.queue.write_texture(
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        &bytes,
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(img.width * format.bytes_per_pixel()),
            rows_per_image: Some(img.height),
        },
        texture.size(),
    );
}

impl<'a> GpuRenderer<'a> {
    /// Builds the passes of `plan` for frames of `input`, with the parameters
    /// of `pipeline`. Nothing outside the plan is created.
    pub fn new(
        ctx: &'a GpuContext,
        plan: StagePlan,
        input: GpuInput,
        pipeline: &Pipeline,
        config: GpuConfig,
    ) -> Result<GpuRenderer<'a>, GpuError> {
        // f16 overflow: every HDR intermediate before `tonemap` is a filtered
        // or averaged copy of the input, so none exceeds the input's largest
        // component. Past f16's 65504 the f16 path would store +Inf, so it is
        // promoted to f32 here and the promotion reported (`notes`).
        let mut config = config;
        let mut notes = Vec::new();
        let input_max = match &input {
            GpuInput::Sphere { env, .. } => max_component(env),
            GpuInput::Flat(img) => max_component(img),
        };
        if config.hdr_format == HdrFormat::Rgba16Float && input_max > F16_MAX {
            notes.push(format!(
                "rgba16float intermediates promoted to rgba32float: the input reaches {input_max:.4e}, beyond f16's largest value {F16_MAX}"
            ));
            config.hdr_format = HdrFormat::Rgba32Float;
        }
        let format = config.hdr_format;
        let (width, height) = match &input {
            GpuInput::Sphere { camera, .. } => (camera.width, camera.height),
            GpuInput::Flat(img) => (img.width, img.height),
        };
        ctx.check_size(width, height)?;
        let (weights, delta) = operator_constants(pipeline.operator);
        let hdr = hdr_texture(ctx, "tonegate.hdr", width, height, format);
        let stats = shared_buffer(
            ctx,
            "tonegate.stats",
            std::mem::size_of::<GpuStats>() as u64,
        );
        let frame_bytes = width as u64 * height as u64 * 4;
        let frame_buf = storage_buffer(ctx, "tonegate.frame", frame_bytes);
        let mut passes: Vec<(&'static str, Vec<Dispatch>)> = Vec::new();
        let mut outputs: Vec<(&'static str, wgpu::Texture)> = Vec::new();
        let mut camera = None;
        let mut uniforms = None;
        let mut env_source: Option<EnvResources> = None;
        let mut env_size = (0, 0);
        match input {
            GpuInput::Sphere {
                env, camera: cam, ..
            } => {
                env_source = Some(match config.env_filter {
                    // The map as a storage buffer of RGBA f32 texels: on
                    // llvmpipe plain loads cost less than textureLoad.
                    super::EnvFilter::Manual => {
                        let bytes = env.pixel_count() as u64 * 16;
                        let limit = ctx.limits.max_storage_buffer_binding_size;
                        if bytes > limit {
                            return Err(GpuError::EnvironmentTooLarge {
                                width: env.width,
                                height: env.height,
                                bytes,
                                limit,
                            });
                        }
                        let texels: Vec<f32> = env
                            .pixels
                            .iter()
                            .flat_map(|p| [p[0], p[1], p[2], 1.0])
                            .collect();
                        let buf = storage_buffer(ctx, "tonegate.env", bytes);
                        ctx.queue
                            .write_buffer(&buf, 0, bytemuck::cast_slice(&texels));
                        (Some(buf), None)
                    }
                    super::EnvFilter::Hardware => {
                        if !ctx.float32_filterable {
                            return Err(GpuError::MissingFeature {
                                adapter: ctx.adapter.name.clone(),
                                feature: "FLOAT32_FILTERABLE",
                                what: "--env-filter hardware",
                            });
                        }
                        ctx.check_size(env.width, env.height)?;
                        let t = ctx.device.create_texture(&wgpu::TextureDescriptor {
                            label: Some("tonegate.env"),
                            size: wgpu::Extent3d {
                                width: env.width,
                                height: env.height,
                                depth_or_array_layers: 1,
                            },
                            mip_level_count: 1,
                            sample_count: 1,
                            dimension: wgpu::TextureDimension::D2,
                            format: wgpu::TextureFormat::Rgba32Float,
                            usage: wgpu::TextureUsages::TEXTURE_BINDING
                                | wgpu::TextureUsages::COPY_DST,
                            view_formats: &[],
                        });
                        upload(ctx, &t, env, HdrFormat::Rgba32Float);
                        let sampler = ctx.device.create_sampler(&wgpu::SamplerDescriptor {
                            label: Some("tonegate.env_sampler"),
                            address_mode_u: wgpu::AddressMode::Repeat,
                            address_mode_v: wgpu::AddressMode::ClampToEdge,
                            mag_filter: wgpu::FilterMode::Linear,
                            min_filter: wgpu::FilterMode::Linear,
                            ..Default::default()
                        });
                        (None, Some((t, sampler)))
                    }
                });
                env_size = (env.width, env.height);
                camera = Some(cam);
                uniforms = Some(super::stages::uniform_buffer(
                    ctx,
                    "tonegate.frame_uniforms",
                    &[0u8; std::mem::size_of::<FrameUniforms>()],
                ));
            }
            GpuInput::Flat(img) => upload(ctx, &hdr, img, format),
        }
        // The texture the next display-referred stage reads.
        let mut display: Option<wgpu::Texture> = None;
        let mut toned: Option<wgpu::Texture> = None;
        let mut bright: Option<wgpu::Texture> = None;
        let mut low: Option<wgpu::Texture> = None;
        let mut blurred: Option<wgpu::Texture> = None;
        let mut grade_mean: Option<wgpu::Buffer> = None;
        // Fused execution: what the merged kernels still need.
        if config.execution == Execution::Fused
            && plan
                .stages
                .iter()
                .any(|s| matches!(s, Stage::Grade | Stage::GradeStats))
        {
            notes.push(
                "executed staged: fused execution covers plans without a grade (the grade needs the whole frame's mean first)".into(),
            );
            config.execution = Execution::Staged;
        }
        let fused = config.execution == Execution::Fused;
        let mut tone: Option<super::tonemap::ToneParams> = None;
        // The curve's resolve step, until a fused kernel runs it first.
        let mut pending_resolve = false;
        let mut bright_source: Option<BloomSource> = None;
        for stage in &plan.stages {
            let mut name = stage.name();
            let dispatches = match stage {
                Stage::Sphere { spp } => {
                    let (Some(env), Some(u)) = (&env_source, &uniforms) else {
                        return Err(GpuError::Validation(
                            "sphere stage without an environment".into(),
                        ));
                    };
                    outputs.push((name, hdr.clone()));
                    let source = match env {
                        (Some(buf), _) => super::sphere::EnvSource::Buffer(buf),
                        (None, Some((t, s))) => super::sphere::EnvSource::Texture(t, s),
                        (None, None) => {
                            return Err(GpuError::Validation("no environment source".into()))
                        }
                    };
                    vec![super::sphere::sphere(
                        ctx, format, *spp, u, source, env_size, &hdr,
                    )]
                }
                Stage::LuminanceStats(needs) => super::luminance_stats::luminance_stats(
                    ctx,
                    format,
                    config.reduction,
                    *needs,
                    weights,
                    delta,
                    &hdr,
                    &stats,
                ),
                Stage::Tonemap { .. } if fused => {
                    tone = Some(super::tonemap::ToneParams::new(
                        ctx,
                        pipeline.operator,
                        config.fault_gain,
                    ));
                    pending_resolve = true;
                    Vec::new()
                }
                Stage::BloomBright { source } if fused => {
                    bright_source = Some(*source);
                    Vec::new()
                }
                Stage::BloomDownsample { factor } if fused => {
                    let b = pipeline
                        .bloom
                        .ok_or_else(|| GpuError::Validation("bloom stage without bloom".into()))?;
                    let (Some(source), Some(t)) = (bright_source, &tone) else {
                        return Err(GpuError::Validation(
                            "downsample before bright pass or tonemap".into(),
                        ));
                    };
                    let (lw, lh) = downsampled_size(width, height, *factor);
                    let out = hdr_texture(ctx, "tonegate.bloom_low", lw, lh, format);
                    let from_toned = source == BloomSource::Toned;
                    let mut d = Vec::new();
                    if from_toned {
                        name = "tonemap+bloom_bright+bloom_downsample";
                        d.push(super::tonemap::resolve(ctx, format, t, &stats));
                        pending_resolve = false;
                    } else {
                        name = "bloom_bright+bloom_downsample";
                    }
                    d.push(super::fused::bright_low(
                        ctx, format, t, b, from_toned, weights, &stats, &hdr, &out,
                    ));
                    low = Some(out);
                    d
                }
                Stage::BloomComposite if fused => Vec::new(),
                Stage::Encode if fused => {
                    let Some(t) = &tone else {
                        return Err(GpuError::Validation("encode before tonemap".into()));
                    };
                    let bloom = match (pipeline.bloom, &blurred) {
                        (Some(b), Some(bl)) => Some((bl, b.strength.get())),
                        _ => None,
                    };
                    name = if bloom.is_some() {
                        "tonemap+bloom_composite+encode"
                    } else {
                        "tonemap+encode"
                    };
                    let mut d = Vec::new();
                    if pending_resolve {
                        d.push(super::tonemap::resolve(ctx, format, t, &stats));
                        pending_resolve = false;
                    }
                    d.push(super::fused::tail(
                        ctx,
                        format,
                        t,
                        bloom,
                        pipeline.encoding,
                        &stats,
                        &hdr,
                        &frame_buf,
                    ));
                    d
                }
                Stage::Tonemap { .. } => {
                    let out = hdr_texture(ctx, "tonegate.toned", width, height, format);
                    let params =
                        super::tonemap::ToneParams::new(ctx, pipeline.operator, config.fault_gain);
                    let d = super::tonemap::tonemap(ctx, format, &params, &stats, &hdr, &out);
                    outputs.push((name, out.clone()));
                    toned = Some(out.clone());
                    display = Some(out);
                    d
                }
                Stage::BloomBright { source } => {
                    let b = pipeline
                        .bloom
                        .ok_or_else(|| GpuError::Validation("bloom stage without bloom".into()))?;
                    let src = match source {
                        BloomSource::Hdr => hdr.clone(),
                        BloomSource::Toned => toned
                            .clone()
                            .ok_or_else(|| GpuError::Validation("bloom before tonemap".into()))?,
                    };
                    let out = hdr_texture(ctx, "tonegate.bloom_bright", width, height, format);
                    let d = super::bloom_bright::bloom_bright(
                        ctx, format, b, weights, &stats, &src, &out,
                    );
                    bright = Some(out);
                    vec![d]
                }
                Stage::BloomDownsample { factor } => {
                    let (lw, lh) = downsampled_size(width, height, *factor);
                    let out = hdr_texture(ctx, "tonegate.bloom_low", lw, lh, format);
                    let src = bright.take().ok_or_else(|| {
                        GpuError::Validation("downsample before bright pass".into())
                    })?;
                    let d =
                        super::bloom_downsample::bloom_downsample(ctx, format, *factor, &src, &out);
                    low = Some(out);
                    vec![d]
                }
                Stage::BloomBlur { radius } => {
                    let b = pipeline
                        .bloom
                        .ok_or_else(|| GpuError::Validation("bloom stage without bloom".into()))?;
                    let src = low
                        .take()
                        .ok_or_else(|| GpuError::Validation("blur before downsample".into()))?;
                    let tmp =
                        hdr_texture(ctx, "tonegate.bloom_tmp", src.width(), src.height(), format);
                    let out = hdr_texture(
                        ctx,
                        "tonegate.bloom_blur",
                        src.width(),
                        src.height(),
                        format,
                    );
                    let d = super::bloom_blur::bloom_blur(
                        ctx,
                        format,
                        *radius,
                        b.sigma.get(),
                        &src,
                        &tmp,
                        &out,
                    );
                    outputs.push((name, out.clone()));
                    blurred = Some(out);
                    d
                }
                Stage::BloomComposite => {
                    let b = pipeline
                        .bloom
                        .ok_or_else(|| GpuError::Validation("bloom stage without bloom".into()))?;
                    let base = display
                        .take()
                        .ok_or_else(|| GpuError::Validation("composite before tonemap".into()))?;
                    let bl = blurred
                        .clone()
                        .ok_or_else(|| GpuError::Validation("composite before blur".into()))?;
                    let out = hdr_texture(ctx, "tonegate.composite", width, height, format);
                    let d = super::bloom_composite::bloom_composite(
                        ctx,
                        format,
                        b.strength.get(),
                        &base,
                        &bl,
                        &out,
                    );
                    outputs.push((name, out.clone()));
                    display = Some(out);
                    vec![d]
                }
                Stage::GradeStats => {
                    let base = display
                        .clone()
                        .ok_or_else(|| GpuError::Validation("grade before tonemap".into()))?;
                    let mean = shared_buffer(ctx, "tonegate.grade_mean", 4);
                    let d = super::grade_stats::grade_stats(ctx, format, &base, &mean);
                    grade_mean = Some(mean);
                    d
                }
                Stage::Grade => {
                    let g = pipeline
                        .grade
                        .ok_or_else(|| GpuError::Validation("grade stage without grade".into()))?;
                    let base = display
                        .take()
                        .ok_or_else(|| GpuError::Validation("grade before tonemap".into()))?;
                    // Without contrast the mean is unused: a zero buffer stands in.
                    let mean = grade_mean
                        .clone()
                        .unwrap_or_else(|| shared_buffer(ctx, "tonegate.grade_mean", 4));
                    let out = hdr_texture(ctx, "tonegate.graded", width, height, format);
                    let d = super::grade::grade(ctx, format, g, &mean, &base, &out);
                    outputs.push((name, out.clone()));
                    display = Some(out);
                    vec![d]
                }
                Stage::Encode => {
                    let base = display
                        .clone()
                        .ok_or_else(|| GpuError::Validation("encode before tonemap".into()))?;
                    outputs.push(("display", base.clone()));
                    vec![super::encode::encode(
                        ctx,
                        format,
                        pipeline.encoding,
                        &base,
                        &frame_buf,
                    )]
                }
            };
            if !dispatches.is_empty() {
                passes.push((name, dispatches));
            }
        }
        let queries = ctx.adapter.timestamps.then(|| {
            let n = 2 * passes.len() as u32;
            let stride = (n as u64 * 8).div_ceil(256) * 256;
            Queries {
                set: ctx.device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some("tonegate.timestamps"),
                    ty: wgpu::QueryType::Timestamp,
                    count: n * TIMING_SLOTS,
                }),
                resolve: ctx.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("tonegate.timestamps.resolve"),
                    size: stride * TIMING_SLOTS as u64,
                    usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                }),
                read: read_buffer(
                    ctx,
                    "tonegate.timestamps.read",
                    stride * TIMING_SLOTS as u64,
                ),
                stride,
            }
        });
        ctx.take_error()?;
        Ok(GpuRenderer {
            ctx,
            plan,
            config,
            notes,
            width,
            height,
            camera,
            uniforms,
            passes,
            outputs,
            stats_read: read_buffer(
                ctx,
                "tonegate.stats.read",
                std::mem::size_of::<GpuStats>() as u64,
            ),
            stats,
            frame_read: read_buffer(ctx, "tonegate.frame.read", frame_bytes.max(16)),
            frame_buf,
            queries,
        })
    }

    pub fn stage_names(&self) -> Vec<&'static str> {
        self.passes.iter().map(|(n, _)| *n).collect()
    }

    /// Sets the sphere rotation for the next frames (no-op for flat input).
    pub fn set_rotation(&self, rotation: &Mat3) {
        let (Some(cam), Some(buf)) = (&self.camera, &self.uniforms) else {
            return;
        };
        let r = |i: usize| {
            [
                rotation[i][0] as f32,
                rotation[i][1] as f32,
                rotation[i][2] as f32,
                0.0,
            ]
        };
        let u = FrameUniforms {
            rot: [r(0), r(1), r(2)],
            size: [cam.width, cam.height],
            tan_half: libm::tan(0.5 * cam.fov_y_deg.to_radians()) as f32,
            aspect: (cam.width as f64 / cam.height as f64) as f32,
        };
        self.ctx.queue.write_buffer(buf, 0, bytemuck::bytes_of(&u));
    }

    /// Records every pass of the plan, timestamps in `slot`.
    pub fn encode(&self, encoder: &mut wgpu::CommandEncoder, slot: u32) {
        let base = slot % TIMING_SLOTS * 2 * self.passes.len() as u32;
        for (i, (name, dispatches)) in self.passes.iter().enumerate() {
            let timestamp_writes =
                self.queries
                    .as_ref()
                    .map(|q| wgpu::ComputePassTimestampWrites {
                        query_set: &q.set,
                        beginning_of_pass_write_index: Some(base + 2 * i as u32),
                        end_of_pass_write_index: Some(base + 2 * i as u32 + 1),
                    });
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(&format!("tonegate.{name}")),
                timestamp_writes,
            });
            for d in dispatches {
                d.record(&mut pass);
            }
        }
        if let Some(q) = &self.queries {
            let n = 2 * self.passes.len() as u32;
            let s = slot % TIMING_SLOTS;
            encoder.resolve_query_set(&q.set, s * n..(s + 1) * n, &q.resolve, s as u64 * q.stride);
        }
    }

    /// Copies the resolved timestamps of all slots for `read_timings`.
    pub fn encode_timing_copy(&self, encoder: &mut wgpu::CommandEncoder) {
        if let Some(q) = &self.queries {
            encoder.copy_buffer_to_buffer(
                &q.resolve,
                0,
                &q.read,
                0,
                q.stride * TIMING_SLOTS as u64,
            );
        }
    }

    /// Stage times of the first `slots` slots (after `encode_timing_copy` ran).
    pub fn read_timings(&self, slots: u32) -> Result<Vec<Vec<StageTiming>>, GpuError> {
        let Some(q) = &self.queries else {
            return Ok(Vec::new());
        };
        let bytes = self.ctx.read_buffer(&q.read)?;
        let names = self.stage_names();
        let n = 2 * names.len();
        Ok((0..slots.min(TIMING_SLOTS) as usize)
            .map(|s| {
                let at = s * q.stride as usize;
                let ticks: Vec<u64> = bytes[at..at + n * 8]
                    .chunks_exact(8)
                    .map(|c| u64::from_le_bytes(c.try_into().unwrap_or([0; 8])))
                    .collect();
                durations(&names, &ticks, self.ctx.timestamp_period)
            })
            .collect())
    }

    /// Renders one frame (rotation already set) and reads back the frame,
    /// the statistics and the stage times.
    pub fn render(&self, read_frame: bool) -> Result<GpuFrame, GpuError> {
        let start = std::time::Instant::now();
        let mut encoder = self
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("tonegate.frame"),
            });
        self.encode(&mut encoder, 0);
        self.encode_timing_copy(&mut encoder);
        encoder.copy_buffer_to_buffer(
            &self.stats,
            0,
            &self.stats_read,
            0,
            std::mem::size_of::<GpuStats>() as u64,
        );
        if read_frame {
            encoder.copy_buffer_to_buffer(
                &self.frame_buf,
                0,
                &self.frame_read,
                0,
                self.width as u64 * self.height as u64 * 4,
            );
        }
        self.ctx.queue.submit([encoder.finish()]);
        self.ctx.wait()?;
        let stats_bytes = self.ctx.read_buffer(&self.stats_read)?;
        let stats: GpuStats =
            bytemuck::pod_read_unaligned(&stats_bytes[..std::mem::size_of::<GpuStats>()]);
        let frame = if read_frame {
            let bytes = self.ctx.read_buffer(&self.frame_read)?;
            // Buffers are at least 16 bytes: a frame under 4 pixels has padding.
            let pixels = bytes
                .chunks_exact(4)
                .take(self.width as usize * self.height as usize)
                .map(|c| [c[0], c[1], c[2]])
                .collect();
            Some(Rgb8Image {
                width: self.width,
                height: self.height,
                pixels,
            })
        } else {
            None
        };
        let timings = self.read_timings(1)?.pop().unwrap_or_default();
        Ok(GpuFrame {
            frame,
            stats,
            timings,
            wall_ms: start.elapsed().as_secs_f64() * 1e3,
        })
    }

    /// Reads back the output texture of `stage` ("sphere", "tonemap",
    /// "bloom_blur", "bloom_composite", "grade", or "display" for the frame
    /// entering `encode`) as f64, or None when the plan has no such stage.
    pub fn read_output(&self, stage: &str) -> Result<Option<LinearImage>, GpuError> {
        let Some((_, texture)) = self.outputs.iter().find(|(n, _)| *n == stage) else {
            return Ok(None);
        };
        let (w, h) = (texture.width(), texture.height());
        let bpp = self.config.hdr_format.bytes_per_pixel();
        let row = (w * bpp).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT)
            * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let buf = read_buffer(self.ctx, "tonegate.readback", row as u64 * h as u64);
        let mut encoder = self
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("tonegate.readback"),
            });
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &buf,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(row),
                    rows_per_image: Some(h),
                },
            },
            texture.size(),
        );
        self.ctx.queue.submit([encoder.finish()]);
        let bytes = self.ctx.read_buffer(&buf)?;
        let mut pixels = Vec::with_capacity(w as usize * h as usize);
        for y in 0..h as usize {
            let line = &bytes[y * row as usize..y * row as usize + (w * bpp) as usize];
            for px in line.chunks_exact(bpp as usize) {
                let c = |i: usize| -> f64 {
                    match self.config.hdr_format {
                        HdrFormat::Rgba32Float => f32::from_le_bytes([
                            px[4 * i],
                            px[4 * i + 1],
                            px[4 * i + 2],
                            px[4 * i + 3],
                        ]) as f64,
                        HdrFormat::Rgba16Float => {
                            half::f16::from_le_bytes([px[2 * i], px[2 * i + 1]]).to_f64()
                        }
                    }
                };
                pixels.push([c(0), c(1), c(2)]);
            }
        }
        Ok(Some(LinearImage {
            width: w,
            height: h,
            pixels,
        }))
    }
}
