//! `tonegate bench`: per-stage GPU time, FPS with and without readback, and
//! two floor passes every stage is expressed as a multiple of (a ratio
//! survives the machine's noise and its one-core/two-core switching better
//! than ms do). The floors run inside every measured frame's submission,
//! after its stages, each with its own timestamp pair, and a stage's multiple
//! is the median of its per-frame ratios: both sides of every ratio saw the
//! same machine at the same moment.

mod embedding;
mod floors;

pub use embedding::{embedding_stages, hdr_input, texture, EmbeddingBenchError, EmbeddingStage};

use super::timing::TIMING_SLOTS;
use super::{AdapterReport, GpuConfig, GpuContext, GpuError, GpuInput, GpuRenderer};
use crate::conventions::{rotation_matrix, Camera};
use crate::env::BuiltinEnv;
use crate::operators::Operator;
use crate::perf::{quantile, summarise, StageTiming};
use crate::plan::StagePlan;
use crate::reference::Pipeline;
use crate::scene::{Bloom, BrightPass, Encoding, Factor, NonNegative, Positive, Radius, TaaParams};
use floors::{median_ratio, Floors};
use serde::Serialize;

#[derive(Clone, Debug)]
pub struct BenchOptions {
    pub width: u32,
    pub height: u32,
    /// Measured frames (after `warmup`).
    pub frames: u32,
    pub warmup: u32,
    pub config: GpuConfig,
    /// The TAA stages after `sphere` (variant `TaaVariant::Off`: none),
    /// resolving against a history every measured frame.
    pub taa: TaaParams,
    /// The operator instead of the bench's own (`reinhard-auto-key` with
    /// the automatic key), to time one operator's `tonemap` stage against
    /// the floors.
    pub operator: Option<Operator>,
    /// Eye adaptation after the statistics (`histogram` and `adaptation`
    /// under histogram metering), stepped every frame at 60 a second.
    pub adaptation: Option<crate::scene::Adaptation>,
}

#[derive(Clone, Debug, Serialize)]
pub struct BenchStage {
    pub name: String,
    pub median_ms: f64,
    pub p95_ms: f64,
    /// The median over frames of this stage's time / the write-only floor's
    /// in the same frame.
    pub floor_multiple: f64,
    /// The same against the read-write floor.
    pub rw_floor_multiple: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct Percentiles {
    pub p50: f64,
    pub p95: f64,
    pub p99: f64,
}

impl Percentiles {
    fn of(v: &[f64]) -> Percentiles {
        Percentiles {
            p50: quantile(v, 0.5),
            p95: quantile(v, 0.95),
            p99: quantile(v, 0.99),
        }
    }
}

#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    pub adapter: AdapterReport,
    /// "WxH".
    pub size: String,
    /// Frames per second, no per-frame readback (frames submitted back to back).
    pub fps: f64,
    /// Frames per second with every frame read back to the host, frames in
    /// flight (`GpuRenderer::frames`): what `check` and `render` run.
    pub fps_with_readback: f64,
    /// Frames per second with every frame read back and waited for before
    /// the next is submitted (one frame in flight).
    pub fps_serial_readback: f64,
    /// Median GPU time of the write-only floor (one store per pixel), timed
    /// inside each measured frame.
    pub floor_ms: f64,
    /// Median GPU time of the read-write floor (one load and one store per
    /// pixel), timed inside each measured frame.
    pub floor_rw_ms: f64,
    /// The median over frames of (sum of the stages) / floor.
    pub frame_floor_multiple: f64,
    /// The same for the stages after the image exists (all but `sphere`,
    /// `taa_sobel` and `taa`): the statistics and display stages, whose sum
    /// the fused execution's target is stated in.
    pub display_floor_multiple: f64,
    pub stages: Vec<BenchStage>,
    /// GPU time per frame (sum of stages), no readback.
    pub frame_gpu_ms: Percentiles,
    /// Wall time per frame with readback, frames in flight: the interval
    /// between consecutive frames reaching the host.
    pub frame_wall_ms_with_readback: Percentiles,
    /// Wall time per frame with readback, one frame in flight: submit to
    /// results on the host.
    pub frame_wall_ms_serial: Percentiles,
    /// Of `frame_wall_ms_serial`, the mean per frame of the host's wait for
    /// the GPU (rendering, the copy into the mapped-readable buffer, the
    /// map) and of taking the frame off its mapping (unpacking it into
    /// RGB). The rest is recording and submitting.
    pub readback_serial: ReadbackSplit,
    pub frames: u32,
    pub warmup: u32,
    pub config: GpuConfig,
    pub plan: Vec<&'static str>,
    /// CPU threads the host has and LP_NUM_THREADS if set: llvmpipe's core use.
    pub host_threads: usize,
    pub lp_num_threads: Option<String>,
}

/// Where a read-back frame's host time goes (ms per frame).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct ReadbackSplit {
    pub wait_ms: f64,
    pub copy_ms: f64,
}

/// The full plan the speed targets are stated for: sphere + statistics
/// (`reinhard-auto-key`'s: weighted log-average, min, max) + tonemap + bloom
/// at ½ + encode.
pub fn bench_operator() -> (Operator, Bloom) {
    let op = Operator::named(crate::operators::REINHARD_AUTO_KEY, &[])
        .unwrap_or_else(|_| unreachable!());
    let bloom = Bloom {
        bright_pass: BrightPass::Scaled,
        threshold: NonNegative::try_from(50.0).unwrap_or_else(|_| unreachable!()),
        downsample: Factor::try_from(2).unwrap_or_else(|_| unreachable!()),
        radius: Radius::try_from(6).unwrap_or_else(|_| unreachable!()),
        sigma: Positive::try_from(3.0).unwrap_or_else(|_| unreachable!()),
        strength: NonNegative::try_from(0.5).unwrap_or_else(|_| unreachable!()),
    };
    (op, bloom)
}

/// A renderer of the bench's full plan at `width`×`height` over the built-in
/// sky (2048×1024), shared by `tonegate bench` and the criterion bench; with
/// TAA (a variant other than `TaaVariant::Off`), its stages after `sphere`.
pub fn full_plan_renderer<'a>(
    ctx: &'a GpuContext,
    width: u32,
    height: u32,
    config: GpuConfig,
    taa: TaaParams,
    operator: Option<&Operator>,
    adaptation: Option<crate::scene::Adaptation>,
) -> Result<GpuRenderer<'a>, GpuError> {
    let (default_op, bloom) = bench_operator();
    let op = operator.cloned().unwrap_or(default_op);
    let pipeline = Pipeline {
        operator: &op,
        bloom: Some(&bloom),
        grade: None,
        encoding: Encoding::Srgb,
    };
    let env = BuiltinEnv::Sky.generate(2048, 1024);
    let camera = Camera {
        width,
        height,
        fov_y_deg: 60.0,
    };
    let plan = StagePlan::build(
        crate::plan::Input::Sphere { spp: 1 },
        &op,
        Some(&bloom),
        None,
    )
    .with_taa(taa);
    let plan = match adaptation {
        Some(adaptation) => plan.with_adaptation(crate::plan::AdaptationStage {
            adaptation,
            frame_seconds: 1.0 / 60.0,
            operator_needs: op.needs(),
        }),
        None => plan,
    };
    GpuRenderer::new(
        ctx,
        plan,
        GpuInput::Sphere {
            env: &env,
            camera,
            spp: 1,
            light: 1.0,
        },
        &pipeline,
        config,
    )
}

/// Runs the bench on `ctx`.
pub fn run(ctx: &GpuContext, opts: &BenchOptions) -> Result<BenchReport, GpuError> {
    let r = full_plan_renderer(
        ctx,
        opts.width,
        opts.height,
        opts.config,
        opts.taa,
        opts.operator.as_ref(),
        opts.adaptation,
    )?;
    let plan = r.plan.clone();
    let angle = |n: u32| rotation_matrix([1.0, 0.0, 0.0], (n as f64 * 2.0).to_radians());
    // Every frame, TAA included, is the full cost: a history to resolve.
    let set = |n: u32| {
        let now = angle(n);
        r.set_frame(&now, crate::conventions::taa_jitter(n));
        r.set_adaptation(n == 0);
        r.set_taa_history(Some(&crate::conventions::reprojection(
            &angle(n.saturating_sub(1)),
            &now,
        )));
    };
    // Warm-up: pipelines compiled, caches filled; excluded from everything.
    for n in 0..opts.warmup {
        set(n);
        r.render(false)?;
    }
    // No readback: batches of frames submitted back to back, timestamps kept
    // per slot; each frame's floors in the same submission, after its stages.
    let floors = Floors::new(ctx, opts.width, opts.height, opts.config.hdr_format);
    let mut gpu_frames: Vec<Vec<StageTiming>> = Vec::new();
    let mut floor_frames: Vec<Vec<StageTiming>> = Vec::new();
    let mut done = 0;
    while done < opts.frames {
        let batch = (opts.frames - done).min(TIMING_SLOTS);
        for s in 0..batch {
            set(done + s);
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            r.encode(&mut encoder, s);
            if let Some(f) = &floors {
                f.encode(&mut encoder, s);
            }
            ctx.queue.submit([encoder.finish()]);
        }
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        r.encode_timing_copy(&mut encoder);
        if let Some(f) = &floors {
            f.queries.copy(&mut encoder);
        }
        ctx.queue.submit([encoder.finish()]);
        ctx.wait()?;
        gpu_frames.extend(r.read_timings(batch)?);
        if let Some(f) = &floors {
            floor_frames.extend(f.queries.read(ctx, &Floors::NAMES, batch)?);
        }
        done += batch;
    }
    // FPS without readback from frames without the floors: batches submitted
    // back to back, waited for at the end of each.
    let start = std::time::Instant::now();
    let mut done = 0;
    while done < opts.frames {
        let batch = (opts.frames - done).min(TIMING_SLOTS);
        for s in 0..batch {
            set(done + s);
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            r.encode(&mut encoder, s);
            ctx.queue.submit([encoder.finish()]);
        }
        ctx.wait()?;
        done += batch;
    }
    let fps = opts.frames as f64 / start.elapsed().as_secs_f64();
    // With readback, one frame in flight: every frame waited for and
    // copied to the host before the next is submitted.
    let mut serial = Vec::with_capacity(opts.frames as usize);
    let start = std::time::Instant::now();
    let before = crate::perf::clock::Snapshot::now();
    for n in 0..opts.frames {
        set(n);
        serial.push(r.render(true)?.wall_ms);
    }
    let fps_serial_readback = opts.frames as f64 / start.elapsed().as_secs_f64();
    let after = crate::perf::clock::Snapshot::now();
    let per_frame = |part| after.since(&before, part).as_secs_f64() * 1e3 / opts.frames as f64;
    let readback_serial = ReadbackSplit {
        wait_ms: per_frame(crate::perf::clock::Part::ReadbackWait),
        copy_ms: per_frame(crate::perf::clock::Part::ReadbackCopy),
    };
    // With readback, frames in flight: frame n copied out while n+1 renders.
    let mut wall = Vec::with_capacity(opts.frames as usize);
    let start = std::time::Instant::now();
    let mut last = start;
    r.frames::<GpuError>(
        0..opts.frames,
        &set,
        |_| true,
        |_, out| {
            std::hint::black_box(out.frame);
            let now = std::time::Instant::now();
            wall.push((now - last).as_secs_f64() * 1e3);
            last = now;
            Ok(())
        },
    )?;
    let fps_with_readback = opts.frames as f64 / start.elapsed().as_secs_f64();
    let floor_of = |i: usize| {
        let v: Vec<f64> = floor_frames
            .iter()
            .filter_map(|f| Some(f.get(i)?.ms))
            .collect();
        if v.is_empty() {
            f64::NAN
        } else {
            quantile(&v, 0.5)
        }
    };
    let (floor_ms, floor_rw_ms) = (floor_of(0), floor_of(1));
    let stages = summarise(&gpu_frames)
        .into_iter()
        .map(|s| BenchStage {
            floor_multiple: median_ratio(&gpu_frames, &floor_frames, &s.name, 0),
            rw_floor_multiple: median_ratio(&gpu_frames, &floor_frames, &s.name, 1),
            name: s.name,
            median_ms: s.median_ms,
            p95_ms: s.p95_ms,
        })
        .collect();
    let frame_gpu: Vec<f64> = gpu_frames
        .iter()
        .map(|f| f.iter().map(|t| t.ms).sum())
        .collect();
    // Per frame, the sum of the stages `keep` keeps, as a stage of its own.
    let summed = |keep: &dyn Fn(&str) -> bool| {
        let sums: Vec<Vec<StageTiming>> = gpu_frames
            .iter()
            .map(|f| {
                vec![StageTiming {
                    stage: "sum".into(),
                    ms: f.iter().filter(|t| keep(&t.stage)).map(|t| t.ms).sum(),
                }]
            })
            .collect();
        median_ratio(&sums, &floor_frames, "sum", 0)
    };
    let frame_floor_multiple = summed(&|_| true);
    let display_floor_multiple = summed(&|s| !["sphere", "taa_sobel", "taa"].contains(&s));
    Ok(BenchReport {
        adapter: ctx.adapter.clone(),
        size: format!("{}x{}", opts.width, opts.height),
        fps,
        fps_with_readback,
        fps_serial_readback,
        floor_ms,
        floor_rw_ms,
        frame_floor_multiple,
        display_floor_multiple,
        stages,
        frame_gpu_ms: Percentiles::of(&frame_gpu),
        frame_wall_ms_with_readback: Percentiles::of(&wall),
        frame_wall_ms_serial: Percentiles::of(&serial),
        readback_serial,
        frames: opts.frames,
        warmup: opts.warmup,
        config: r.config,
        plan: plan.names(),
        host_threads: std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1),
        lp_num_threads: std::env::var("LP_NUM_THREADS").ok(),
    })
}

impl std::fmt::Display for BenchReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "adapter: {} ({}, {}, {})",
            self.adapter.name, self.adapter.backend, self.adapter.driver, self.adapter.driver_info
        )?;
        writeln!(
            f,
            "size {}, {} frames after {} warm-up, intermediates {:?}, reduction {:?}, env filter {:?}, execution {:?}, host threads {}{}",
            self.size,
            self.frames,
            self.warmup,
            self.config.hdr_format,
            self.config.reduction,
            self.config.env_filter,
            self.config.execution,
            self.host_threads,
            self.lp_num_threads.as_ref().map(|t| format!(", LP_NUM_THREADS={t}")).unwrap_or_default()
        )?;
        // Fused kernels have long names ("tonemap+bloom_composite+encode").
        let w = self
            .stages
            .iter()
            .map(|s| s.name.len())
            .max()
            .unwrap_or(0)
            .max(18);
        writeln!(
            f,
            "{:<w$} {:>10} {:>10} {:>8} {:>8}",
            "stage", "median ms", "p95 ms", "x floor", "x rw"
        )?;
        for s in &self.stages {
            writeln!(
                f,
                "{:<w$} {:>10.3} {:>10.3} {:>8.2} {:>8.2}",
                s.name, s.median_ms, s.p95_ms, s.floor_multiple, s.rw_floor_multiple
            )?;
        }
        writeln!(
            f,
            "{:<w$} {:>10.3}   (write-only: one store per pixel)",
            "floor", self.floor_ms
        )?;
        writeln!(
            f,
            "{:<w$} {:>10.3}   (read-write: one load and one store per pixel)",
            "floor_rw", self.floor_rw_ms
        )?;
        writeln!(
            f,
            "multiples are medians of per-frame ratios, the floors timed inside each frame; the frame (sum of the stages) is {:.2}x the floor, the stages after sphere and TAA {:.2}x",
            self.frame_floor_multiple, self.display_floor_multiple
        )?;
        writeln!(
            f,
            "GPU frame ms p50/p95/p99: {:.2} / {:.2} / {:.2}",
            self.frame_gpu_ms.p50, self.frame_gpu_ms.p95, self.frame_gpu_ms.p99
        )?;
        writeln!(
            f,
            "wall frame ms with readback p50/p95/p99: {:.2} / {:.2} / {:.2} ({} in flight); one at a time: {:.2} / {:.2} / {:.2}",
            self.frame_wall_ms_with_readback.p50,
            self.frame_wall_ms_with_readback.p95,
            self.frame_wall_ms_with_readback.p99,
            super::FRAMES_IN_FLIGHT,
            self.frame_wall_ms_serial.p50,
            self.frame_wall_ms_serial.p95,
            self.frame_wall_ms_serial.p99
        )?;
        writeln!(
            f,
            "one at a time, per frame: {:.3} ms waiting for the GPU and the map, {:.3} ms taking the frame off its mapping",
            self.readback_serial.wait_ms, self.readback_serial.copy_ms
        )?;
        write!(
            f,
            "FPS: {:.1} without readback, {:.1} with readback ({:.1} one at a time)",
            self.fps, self.fps_with_readback, self.fps_serial_readback
        )
    }
}
