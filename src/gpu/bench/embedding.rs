//! The embedding's stages against the renderer's: a flat image tone-mapped
//! by tonegate's own renderer and by a `ToneMapper` on the same device,
//! frame about, each stage's GPU time as a multiple of the floor pass timed
//! in the same submission (`bench`'s floors), so that the two are compared
//! within one sitting and the adapter's speed from one frame to the next
//! cancels out.

use super::Floors;
use crate::gpu::{
    GpuConfig, GpuContext, GpuError, GpuInput, GpuRenderer, ToneMapper, ToneMapperError,
    ToneMapperSettings,
};
use crate::image::HdrImage;
use crate::operators::Operator;
use crate::perf::{quantile, StageTiming};
use crate::plan::{Input, StagePlan};
use crate::reference::Pipeline;
use crate::scene::Encoding;
use serde::Serialize;

/// One stage: the median over frames of its time / the write-only floor's
/// in the same submission, through the renderer and through the embedding
/// (NaN where that side has no such stage).
#[derive(Clone, Debug, Serialize)]
pub struct EmbeddingStage {
    pub stage: String,
    pub renderer: f64,
    pub embedding: f64,
}

/// Why the comparison could not run.
#[derive(Debug, thiserror::Error)]
pub enum EmbeddingBenchError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Mapper(#[from] ToneMapperError),
}

/// `operator` on `img` with the sRGB encoding, `frames` frames each way,
/// the embedding writing an `Rgba8Unorm` storage target (its write is the
/// stage `target`, the renderer's is `encode`). None where the device has
/// no timestamp queries.
pub fn embedding_stages(
    ctx: &GpuContext,
    img: &HdrImage,
    operator: &Operator,
    frames: u32,
) -> Result<Option<Vec<EmbeddingStage>>, EmbeddingBenchError> {
    let Some(floors) = Floors::new(ctx, img.width, img.height, GpuConfig::default().hdr_format)
    else {
        return Ok(None);
    };
    let pipeline = Pipeline {
        operator,
        bloom: None,
        grade: None,
        encoding: Encoding::Srgb,
    };
    let plan = StagePlan::build(Input::Flat, operator, None, None);
    let renderer = GpuRenderer::new(
        ctx,
        plan,
        GpuInput::Flat(img),
        &pipeline,
        GpuConfig::default(),
    )?;
    let settings = ToneMapperSettings {
        operator: operator.clone(),
        target: wgpu::TextureFormat::Rgba8Unorm,
        ..ToneMapperSettings::default()
    };
    let mut mapper = ToneMapper::new(&ctx.device, &ctx.queue, settings)?;
    mapper.enable_timestamps()?;
    let input = hdr_input(ctx, img).create_view(&Default::default());
    let output = texture(
        ctx,
        (img.width, img.height),
        wgpu::TextureFormat::Rgba8Unorm,
        wgpu::TextureUsages::STORAGE_BINDING,
    )
    .create_view(&Default::default());
    let mut ours: Vec<(Vec<StageTiming>, f64)> = Vec::new();
    let mut theirs: Vec<(Vec<StageTiming>, f64)> = Vec::new();
    // Frame 0 of each compiles nothing (the renderer's pipelines are made
    // with it, the mapper's by `prepare`) but fills caches: left out.
    mapper.prepare()?;
    for n in 0..=frames {
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        renderer.encode(&mut encoder, 0);
        floors.encode(&mut encoder, 0);
        renderer.encode_timing_copy(&mut encoder);
        floors.queries.copy(&mut encoder);
        ctx.queue.submit([encoder.finish()]);
        ctx.wait()?;
        let stages = renderer.read_timings(1)?.pop().unwrap_or_default();
        let floor = floor_ms(ctx, &floors)?;

        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        mapper.record(&mut encoder, &input, &output)?;
        floors.encode(&mut encoder, 0);
        floors.queries.copy(&mut encoder);
        ctx.queue.submit([encoder.finish()]);
        ctx.wait()?;
        let timed = mapper.read_timings()?;
        let mapper_floor = floor_ms(ctx, &floors)?;
        if n > 0 {
            theirs.push((stages, floor));
            ours.push((timed.map(|t| t.stages).unwrap_or_default(), mapper_floor));
        }
    }
    let median = |runs: &[(Vec<StageTiming>, f64)], stage: &str| {
        let ratios: Vec<f64> = runs
            .iter()
            .filter_map(|(s, floor)| {
                let ms = s.iter().find(|t| t.stage == stage)?.ms;
                (*floor > 0.0).then_some(ms / floor)
            })
            .collect();
        quantile(&ratios, 0.5)
    };
    let names: Vec<String> = theirs
        .first()
        .into_iter()
        .chain(ours.first())
        .flat_map(|(s, _)| s.iter().map(|t| t.stage.clone()))
        .fold(Vec::new(), |mut v, n| {
            if !v.contains(&n) {
                v.push(n);
            }
            v
        });
    Ok(Some(
        names
            .into_iter()
            .map(|stage| EmbeddingStage {
                renderer: median(&theirs, &stage),
                embedding: median(&ours, &stage),
                stage,
            })
            .collect(),
    ))
}

/// The write-only floor's time in the submission just waited for.
fn floor_ms(ctx: &GpuContext, floors: &Floors) -> Result<f64, GpuError> {
    let read = floors.queries.read(ctx, &Floors::NAMES, 1)?;
    Ok(read
        .first()
        .and_then(|f| f.first())
        .map_or(f64::NAN, |t| t.ms))
}

/// A one-level 2-D texture of `size`, as an application makes one.
pub fn texture(
    ctx: &GpuContext,
    (width, height): (u32, u32),
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("tonegate.bench.application"),
        size: wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

/// `img` in an `Rgba32Float` texture: an application's HDR frame.
pub fn hdr_input(ctx: &GpuContext, img: &HdrImage) -> wgpu::Texture {
    let input = texture(
        ctx,
        (img.width, img.height),
        wgpu::TextureFormat::Rgba32Float,
        wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
    );
    let texels: Vec<f32> = img
        .pixels
        .iter()
        .flat_map(|p| [p[0], p[1], p[2], 1.0])
        .collect();
    ctx.queue.write_texture(
        input.as_image_copy(),
        bytemuck::cast_slice(&texels),
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(img.width * 16),
            rows_per_image: None,
        },
        input.size(),
    );
    input
}
