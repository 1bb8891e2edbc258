//! Executes a stage plan on the GPU: only the plan's stages are created,
//! dispatched and timed. `new` is the sequence of steps below; what each
//! stage reads and writes is wired in `wiring` (and `fused`).

use super::config::{Execution, GpuConfig};
use super::sphere::Environment;
use super::stages::{
    extent_buffer, hdr_texture, read_buffer, shared_buffer, storage_buffer, upload, Extent,
};
use super::timing::Queries;
use super::wiring::Wiring;
use super::{GpuContext, GpuError, HdrFormat};
use crate::conventions::{Camera, Mat3};
use crate::image::{HdrImage, LinearImage, Rgb8Image};
use crate::perf::StageTiming;
use crate::plan::StagePlan;
use crate::reference::bloom_downsample::downsampled_size;
use crate::reference::tonemap::operator_constants;
use crate::reference::Pipeline;
use serde::Serialize;

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

/// Frames a renderer keeps in flight ([`GpuRenderer::frames`]): each has its
/// own host-readable copies, so frame n is mapped and copied out while frame
/// n+1 renders. Three cover a frame being rendered, one being copied and one
/// being read on the host.
pub const FRAMES_IN_FLIGHT: usize = 3;

/// The most bytes per frame pixel any one buffer of a renderer takes: the
/// ping-pong reduction's first level, a 32-byte partial per 2×2 block (the
/// packed frame takes 4). What `GpuContext::check_frame` holds a frame to.
pub(crate) const MAX_BUFFER_BYTES_PER_PIXEL: u64 = super::luminance_stats::PARTIAL_BYTES / 4;

/// The host-readable copies of one frame in flight.
struct Staging {
    stats: wgpu::Buffer,
    frame: wgpu::Buffer,
    /// The frame's resolved timestamps, when the adapter has them.
    timing: Option<wgpu::Buffer>,
}

/// A submitted frame: [`GpuRenderer::collect`] waits for it and reads it.
#[must_use = "a submitted frame holds its staging slot until it is collected"]
pub struct Ticket {
    slot: usize,
    read_frame: bool,
    /// The frame's size (a kept renderer's image may change between frames).
    size: (u32, u32),
    start: std::time::Instant,
    submission: wgpu::SubmissionIndex,
    /// Each map's outcome, tagged with its buffer: 0 statistics, 1 frame,
    /// 2 timestamps.
    mapped: std::sync::mpsc::Receiver<(usize, Result<(), wgpu::BufferAsyncError>)>,
}

/// Mirrors `FrameUniforms` in shaders/shared/frame.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct FrameUniforms {
    rot: [[f32; 4]; 3],
    size: [u32; 2],
    tan_half: f32,
    aspect: f32,
    jitter: [f32; 2],
    /// WGSL rounds the struct up to 16 bytes.
    _pad: [f32; 2],
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

impl GpuInput<'_> {
    /// The output frame's size.
    fn size(&self) -> (u32, u32) {
        match self {
            GpuInput::Sphere { camera, .. } => (camera.width, camera.height),
            GpuInput::Flat(img) => (img.width, img.height),
        }
    }

    /// The largest component of the input (NaN ignored): no intermediate
    /// before `tonemap` exceeds it.
    fn max_component(&self) -> f32 {
        let img = match self {
            GpuInput::Sphere { env, .. } => env,
            GpuInput::Flat(img) => img,
        };
        max_component(&img.pixels)
    }
}

/// The largest component of `pixels`, at least 0, NaN ignored. Eight
/// independent lanes (a comparison, not `f32::max`) let the compiler use
/// vector maxima: the serial NaN-aware fold took 2.5 ms of a 1024×512
/// request.
fn max_component(pixels: &[[f32; 3]]) -> f32 {
    let flat: &[f32] = bytemuck::cast_slice(pixels);
    let mut lanes = [0.0f32; 8];
    let chunks = flat.chunks_exact(8);
    let rest = chunks.remainder();
    for chunk in chunks {
        for (m, &v) in lanes.iter_mut().zip(chunk) {
            // A NaN compares false and is skipped, as f32::max skips it.
            *m = if v > *m { v } else { *m };
        }
    }
    rest.iter()
        .chain(&lanes)
        .fold(0.0f32, |m, &v| if v > m { v } else { m })
}

pub struct GpuRenderer<'a> {
    ctx: &'a GpuContext,
    pub plan: StagePlan,
    /// The configuration in effect (after any f16 → f32 promotion).
    pub config: GpuConfig,
    /// What the renderer changed on its own and why (e.g. f16 promoted to f32).
    pub notes: Vec<String>,
    /// The configuration asked for, before `in_effect`.
    requested: GpuConfig,
    /// A flat input's texture, which [`GpuRenderer::reload`] refills.
    input: Option<wgpu::Texture>,
    /// The size of the frames rendered now ([`GpuRenderer::reload`] may
    /// change it within the capacity), and the size of the textures.
    size: std::sync::Mutex<(u32, u32)>,
    capacity: (u32, u32),
    /// The bloom's downsampling factor, which sizes its low-resolution level.
    bloom_factor: Option<u32>,
    /// The `Extent` uniform the sized entry points read (stages::Extent).
    extent: wgpu::Buffer,
    camera: Option<Camera>,
    uniforms: Option<wgpu::Buffer>,
    /// Per plan stage, its dispatches (one compute pass each), and those of
    /// odd frames where they alternate (the TAA history).
    passes: Vec<super::wiring::Pass>,
    /// The TAA history pair and uniforms, in a TAA plan.
    taa: Option<super::taa::TaaResources>,
    /// Whether the next frame is odd (reads the second history texture).
    odd: std::sync::atomic::AtomicBool,
    /// Stage outputs that can be read back: (stage name, texture).
    outputs: Vec<(&'static str, wgpu::Texture)>,
    stats: wgpu::Buffer,
    frame_buf: wgpu::Buffer,
    /// One set of host-readable copies per frame in flight, and which are
    /// taken by a frame not yet collected.
    staging: Vec<Staging>,
    busy: std::sync::Mutex<[bool; FRAMES_IN_FLIGHT]>,
    submitted: std::sync::atomic::AtomicUsize,
    queries: Option<Queries>,
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
        Self::with_capacity(ctx, plan, input, pipeline, config, (0, 0))
    }

    /// [`GpuRenderer::new`] with textures and buffers of at least
    /// `capacity`: a flat renderer that [`GpuRenderer::reload`] can then
    /// refill with any image up to that size (a server's size class). A
    /// sphere renderer's frames are the camera's size.
    pub fn with_capacity(
        ctx: &'a GpuContext,
        plan: StagePlan,
        input: GpuInput,
        pipeline: &Pipeline,
        config: GpuConfig,
        capacity: (u32, u32),
    ) -> Result<GpuRenderer<'a>, GpuError> {
        let requested = config;
        let (config, notes) = config.in_effect(input.max_component(), &plan, ctx.traits());
        let (width, height) = input.size();
        ctx.check_frame(width, height)?;
        let capacity = match input {
            GpuInput::Flat(_) => (width.max(capacity.0), height.max(capacity.1)),
            GpuInput::Sphere { .. } => (width, height),
        };
        ctx.check_frame(capacity.0, capacity.1)?;
        let bloom_factor = plan.stages().iter().find_map(|s| match s {
            crate::plan::Stage::BloomDownsample { factor } => Some(*factor),
            _ => None,
        });
        let extent = extent_buffer(ctx, extent_of((width, height), bloom_factor));
        let taa = plan.taa().is_some();
        let mut wiring = frame_resources(ctx, &input, pipeline, config, capacity, taa, extent)?;
        let input_texture = match input {
            GpuInput::Flat(_) => Some(wiring.hdr.clone()),
            GpuInput::Sphere { .. } => None,
        };
        let camera = match input {
            GpuInput::Sphere { camera, .. } => Some(camera),
            GpuInput::Flat(_) => None,
        };
        let mut passes = Vec::new();
        for stage in plan.stages() {
            let fused = match config.execution {
                Execution::Fused => super::fused::wire(&mut wiring, stage)?,
                Execution::Staged => None,
            };
            let pass = match fused {
                Some(pass) => pass,
                None => wiring.staged(stage)?,
            };
            if !pass.dispatches.is_empty() {
                passes.push(pass);
            }
        }
        let queries = Queries::new(ctx, passes.len());
        ctx.take_error()?;
        let Wiring {
            stats,
            frame,
            environment,
            outputs,
            taa,
            extent,
            ..
        } = wiring;
        let frame_bytes = capacity.0 as u64 * capacity.1 as u64 * 4;
        Ok(GpuRenderer {
            ctx,
            plan,
            config,
            notes,
            requested,
            input: input_texture,
            size: std::sync::Mutex::new((width, height)),
            capacity,
            bloom_factor,
            extent,
            camera,
            uniforms: environment.map(|(_, uniforms)| uniforms),
            passes,
            taa,
            odd: std::sync::atomic::AtomicBool::new(false),
            outputs,
            staging: (0..FRAMES_IN_FLIGHT)
                .map(|_| Staging {
                    stats: read_buffer(
                        ctx,
                        "tonegate.luminance_stats.read",
                        std::mem::size_of::<GpuStats>() as u64,
                    ),
                    frame: read_buffer(ctx, "tonegate.encode.read", frame_bytes.max(16)),
                    timing: queries
                        .as_ref()
                        .map(|q| read_buffer(ctx, "tonegate.timestamps.read", q.slot_bytes())),
                })
                .collect(),
            busy: Default::default(),
            submitted: Default::default(),
            stats,
            frame_buf: frame,
            queries,
        })
    }

    /// Replaces a flat input with `img` for the next frames, keeping every
    /// texture, buffer and bind group: what a server rendering many images
    /// of one set of settings reuses. An image smaller than the capacity is
    /// rendered in its top-left corner: the sized entry points read its
    /// size from the `Extent` uniform, rewritten here, and nothing outside
    /// it. False (nothing changed) when the renderer cannot take it: a
    /// sphere renderer, an image larger than the capacity, or an input that
    /// would change the configuration in effect (f16 intermediates promoted
    /// to f32, or no longer).
    pub fn reload(&self, img: &HdrImage) -> bool {
        let Some(texture) = &self.input else {
            return false;
        };
        if img.width > self.capacity.0 || img.height > self.capacity.1 {
            return false;
        }
        let (config, _) =
            self.requested
                .in_effect(max_component(&img.pixels), &self.plan, self.ctx.traits());
        if config != self.config {
            return false;
        }
        upload(self.ctx, texture, img, self.config.hdr_format);
        let mut size = self.lock_size();
        if *size != (img.width, img.height) {
            *size = (img.width, img.height);
            let extent = extent_of(*size, self.bloom_factor);
            self.ctx
                .queue
                .write_buffer(&self.extent, 0, bytemuck::bytes_of(&extent));
        }
        true
    }

    fn lock_size(&self) -> std::sync::MutexGuard<'_, (u32, u32)> {
        self.size
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// The width of the frames rendered now.
    pub fn width(&self) -> u32 {
        self.lock_size().0
    }

    /// The height of the frames rendered now.
    pub fn height(&self) -> u32 {
        self.lock_size().1
    }

    /// The size of the renderer's textures and buffers: the largest image
    /// [`GpuRenderer::reload`] takes.
    pub fn capacity(&self) -> (u32, u32) {
        self.capacity
    }

    /// The adapter the passes run on.
    pub fn adapter_name(&self) -> &str {
        &self.ctx.adapter.name
    }

    pub fn stage_names(&self) -> Vec<&'static str> {
        self.passes.iter().map(|p| p.name).collect()
    }

    /// Sets the sphere rotation for the next frames (no-op for flat input).
    pub fn set_rotation(&self, rotation: &Mat3) {
        self.set_frame(rotation, (0.0, 0.0));
    }

    /// Sets the sphere rotation and the frame's sub-pixel jitter (a TAA
    /// frame's `conventions::taa_jitter`) for the next frames.
    pub fn set_frame(&self, rotation: &Mat3, jitter: (f64, f64)) {
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
            jitter: [jitter.0 as f32, jitter.1 as f32],
            _pad: [0.0; 2],
        };
        self.ctx.queue.write_buffer(buf, 0, bytemuck::bytes_of(&u));
    }

    /// Whether the plan has a TAA stage.
    pub fn has_taa(&self) -> bool {
        self.taa.is_some()
    }

    /// The TAA history of the next frame: `reprojection` from the previous
    /// frame's rotation (`conventions::reprojection`), or None for a reset.
    /// No-op without a TAA stage.
    pub fn set_taa_history(&self, reprojection: Option<&Mat3>) {
        let Some(taa) = &self.taa else {
            return;
        };
        let row = |m: &Mat3, i: usize| [m[i][0] as f32, m[i][1] as f32, m[i][2] as f32, 0.0];
        let u = super::taa::TaaUniforms {
            rows: match reprojection {
                Some(m) => [row(m, 0), row(m, 1), row(m, 2)],
                None => [[0.0; 4]; 3],
            },
            has_history: reprojection.is_some() as u32,
            _pad: [0; 3],
        };
        self.ctx
            .queue
            .write_buffer(&taa.uniforms, 0, bytemuck::bytes_of(&u));
    }

    /// Records every pass of the plan, timestamps in `slot`.
    pub fn encode(&self, encoder: &mut wgpu::CommandEncoder, slot: u32) {
        let odd = self.odd.load(std::sync::atomic::Ordering::Relaxed);
        for (i, p) in self.passes.iter().enumerate() {
            let name = p.name;
            let dispatches = match &p.odd {
                Some(d) if odd => d,
                _ => &p.dispatches,
            };
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(&format!("tonegate.{name}")),
                timestamp_writes: self.queries.as_ref().map(|q| q.writes(slot, i)),
            });
            for d in dispatches {
                d.record(&mut pass);
            }
        }
        if let Some(q) = &self.queries {
            q.resolve(encoder, slot);
        }
    }

    /// Copies the resolved timestamps of all slots for `read_timings`.
    pub fn encode_timing_copy(&self, encoder: &mut wgpu::CommandEncoder) {
        if let Some(q) = &self.queries {
            q.copy(encoder);
        }
    }

    /// Stage times of the first `slots` slots (after `encode_timing_copy` ran).
    pub fn read_timings(&self, slots: u32) -> Result<Vec<Vec<StageTiming>>, GpuError> {
        match &self.queries {
            Some(q) => q.read(self.ctx, &self.stage_names(), slots),
            None => Ok(Vec::new()),
        }
    }

    /// Renders one frame (rotation already set) and reads back the frame,
    /// the statistics and the stage times.
    pub fn render(&self, read_frame: bool) -> Result<GpuFrame, GpuError> {
        let ticket = self.submit(read_frame)?;
        self.collect(ticket)
    }

    /// Submits one frame (rotation, jitter and history already set) and
    /// starts mapping its results without waiting for them. At most
    /// [`FRAMES_IN_FLIGHT`] frames may be submitted and not yet collected.
    pub fn submit(&self, read_frame: bool) -> Result<Ticket, GpuError> {
        let start = std::time::Instant::now();
        let size = *self.lock_size();
        let n = self
            .submitted
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let slot = n % FRAMES_IN_FLIGHT;
        {
            let mut busy = self.lock_busy();
            if busy[slot] {
                return Err(GpuError::Readback(format!(
                    "more than {FRAMES_IN_FLIGHT} frames submitted and not collected"
                )));
            }
            busy[slot] = true;
        }
        let staging = &self.staging[slot];
        let mut encoder = self
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("tonegate.frame"),
            });
        self.encode(&mut encoder, slot as u32);
        if let (Some(q), Some(dst)) = (&self.queries, &staging.timing) {
            q.copy_slot(&mut encoder, slot as u32, dst);
        }
        encoder.copy_buffer_to_buffer(
            &self.stats,
            0,
            &staging.stats,
            0,
            std::mem::size_of::<GpuStats>() as u64,
        );
        if read_frame {
            encoder.copy_buffer_to_buffer(
                &self.frame_buf,
                0,
                &staging.frame,
                0,
                size.0 as u64 * size.1 as u64 * 4,
            );
        }
        let submission = self.ctx.queue.submit([encoder.finish()]);
        if self.taa.is_some() {
            // The frame just submitted wrote the other history texture.
            self.odd
                .fetch_xor(true, std::sync::atomic::Ordering::Relaxed);
        }
        let (tx, mapped) = std::sync::mpsc::channel();
        for (i, buffer) in self.ticket_buffers(slot, read_frame) {
            let tx = tx.clone();
            buffer.slice(..).map_async(wgpu::MapMode::Read, move |r| {
                let _ = tx.send((i, r));
            });
        }
        Ok(Ticket {
            slot,
            read_frame,
            size,
            start,
            submission,
            mapped,
        })
    }

    /// The staging buffers a frame in `slot` maps, tagged as in
    /// [`Ticket::mapped`].
    fn ticket_buffers(
        &self,
        slot: usize,
        read_frame: bool,
    ) -> impl Iterator<Item = (usize, &wgpu::Buffer)> {
        let staging = &self.staging[slot];
        [
            Some(&staging.stats),
            read_frame.then_some(&staging.frame),
            staging.timing.as_ref(),
        ]
        .into_iter()
        .enumerate()
        .filter_map(|(i, b)| b.map(|b| (i, b)))
    }

    /// Waits for a submitted frame and reads its results. Its staging slot
    /// is free again afterwards whatever the outcome: every buffer whose map
    /// succeeded or is still pending is unmapped (which cancels a pending
    /// one), so a failed frame leaves nothing mapped for the next frame's
    /// copies to trip over.
    pub fn collect(&self, ticket: Ticket) -> Result<GpuFrame, GpuError> {
        let waited = self.wait_ticket(&ticket);
        let mut outcome: [Option<Result<(), wgpu::BufferAsyncError>>; 3] = Default::default();
        while let Ok((i, r)) = ticket.mapped.try_recv() {
            outcome[i] = Some(r);
        }
        let result = waited.and_then(|()| {
            // The wait returns after the submission's map callbacks have run.
            for (i, _) in self.ticket_buffers(ticket.slot, ticket.read_frame) {
                match &outcome[i] {
                    Some(Ok(())) => {}
                    Some(Err(e)) => return Err(GpuError::Readback(e.to_string())),
                    None => {
                        return Err(GpuError::Readback(
                            "a frame's results were not mapped after its submission finished"
                                .into(),
                        ))
                    }
                }
            }
            self.read_ticket(&ticket)
        });
        for (i, buffer) in self.ticket_buffers(ticket.slot, ticket.read_frame) {
            // A failed map left its buffer unmapped already; unmapping it
            // again would be a validation error on the device.
            if !matches!(outcome[i], Some(Err(_))) {
                buffer.unmap();
            }
        }
        self.lock_busy()[ticket.slot] = false;
        result
    }

    fn lock_busy(&self) -> std::sync::MutexGuard<'_, [bool; FRAMES_IN_FLIGHT]> {
        self.busy
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// Waits until the ticket's submission is done, then reports the first
    /// error the device raised, whether or not the wait succeeded (a
    /// submission that failed validation is never done, and its validation
    /// error says why better than the wait), and forgets the rest: one fault
    /// raises several (at `finish` and at `submit`), which would otherwise
    /// fail the frames after it.
    fn wait_ticket(&self, ticket: &Ticket) -> Result<(), GpuError> {
        let waited = self.ctx.device.poll(wgpu::PollType::Wait {
            submission_index: Some(ticket.submission.clone()),
            timeout: None,
        });
        self.ctx.take_first_error()?;
        waited
            .map(|_| ())
            .map_err(|e| GpuError::DeviceLost(e.to_string()))
    }

    fn read_ticket(&self, ticket: &Ticket) -> Result<GpuFrame, GpuError> {
        let staging = &self.staging[ticket.slot];
        let mapped = |b: &wgpu::Buffer| -> Result<Vec<u8>, GpuError> {
            Ok(b.slice(..)
                .get_mapped_range()
                .map_err(|e| GpuError::Readback(e.to_string()))?
                .to_vec())
        };
        let stats_bytes = mapped(&staging.stats)?;
        let stats: GpuStats =
            bytemuck::pod_read_unaligned(&stats_bytes[..std::mem::size_of::<GpuStats>()]);
        let frame = if ticket.read_frame {
            let view = staging
                .frame
                .slice(..)
                .get_mapped_range()
                .map_err(|e| GpuError::Readback(e.to_string()))?;
            // Buffers are at least 16 bytes: a frame under 4 pixels has padding.
            let pixels = view
                .chunks_exact(4)
                .take(ticket.size.0 as usize * ticket.size.1 as usize)
                .map(|c| [c[0], c[1], c[2]])
                .collect();
            Some(Rgb8Image {
                width: ticket.size.0,
                height: ticket.size.1,
                pixels,
            })
        } else {
            None
        };
        let timings = match (&self.queries, &staging.timing) {
            (Some(q), Some(b)) => q.parse(&mapped(b)?, &self.stage_names(), self.ctx),
            _ => Vec::new(),
        };
        Ok(GpuFrame {
            frame,
            stats,
            timings,
            wall_ms: ticket.start.elapsed().as_secs_f64() * 1e3,
        })
    }

    /// Renders `frames` in order with up to [`FRAMES_IN_FLIGHT`] in flight:
    /// `set(n)` prepares frame n (rotation, jitter, history) just before it
    /// is submitted, and `sink(n, frame)` receives the frames in order, the
    /// image read back where `read(n)`. Frame n+1 is rendering while frame n
    /// is copied out and handed over. On an error (the device's or the
    /// sink's) the frames still in flight are collected and dropped.
    pub fn frames<E: From<GpuError>>(
        &self,
        frames: impl IntoIterator<Item = u32>,
        mut set: impl FnMut(u32),
        read: impl Fn(u32) -> bool,
        mut sink: impl FnMut(u32, GpuFrame) -> Result<(), E>,
    ) -> Result<(), E> {
        let mut flight: std::collections::VecDeque<(u32, Ticket)> = Default::default();
        let run = || -> Result<(), E> {
            for n in frames {
                if flight.len() == FRAMES_IN_FLIGHT {
                    if let Some((k, t)) = flight.pop_front() {
                        sink(k, self.collect(t)?)?;
                    }
                }
                set(n);
                flight.push_back((n, self.submit(read(n))?));
            }
            while let Some((k, t)) = flight.pop_front() {
                sink(k, self.collect(t)?)?;
            }
            Ok(())
        };
        let result = run();
        for (_, t) in flight {
            let _ = self.collect(t);
        }
        result
    }

    /// Reads back the output texture of `stage` ("sphere", "taa_sobel",
    /// "taa", "tonemap", "bloom_blur", "bloom_composite", "grade", "display"
    /// for the frame entering `encode`, or "taa_history" for the unsharpened
    /// TAA blend of the last frame) as f64, or None when the plan has no such
    /// stage.
    pub fn read_output(&self, stage: &str) -> Result<Option<LinearImage>, GpuError> {
        // The TAA history the last frame wrote: the texture the next frame reads.
        let history = self.taa.as_ref().map(|t| {
            let odd = self.odd.load(std::sync::atomic::Ordering::Relaxed);
            ("taa_history", &t.history[usize::from(odd)])
        });
        let found = self
            .outputs
            .iter()
            .map(|(n, t)| (*n, t))
            .chain(history)
            .find(|(n, _)| *n == stage);
        let Some((_, texture)) = found else {
            return Ok(None);
        };
        // The part the frame covers: a texture of the capacity holds the
        // frame, one of the bloom's level at the capacity holds its level.
        let extent = extent_of(*self.lock_size(), self.bloom_factor);
        let texture_size = (texture.width(), texture.height());
        let (w, h) = if texture_size == self.capacity {
            (extent.frame[0], extent.frame[1])
        } else if Some(texture_size)
            == self
                .bloom_factor
                .map(|f| downsampled_size(self.capacity.0, self.capacity.1, f))
        {
            (extent.low[0], extent.low[1])
        } else {
            texture_size
        };
        let single = texture.format() == wgpu::TextureFormat::R32Float;
        let bpp = if single {
            4
        } else {
            self.config.hdr_format.bytes_per_pixel()
        };
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
            wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
        );
        self.ctx.queue.submit([encoder.finish()]);
        let bytes = self.ctx.read_buffer(&buf)?;
        let mut pixels = Vec::with_capacity(w as usize * h as usize);
        for y in 0..h as usize {
            let line = &bytes[y * row as usize..y * row as usize + (w * bpp) as usize];
            for px in line.chunks_exact(bpp as usize) {
                if single {
                    let v = f32::from_le_bytes([px[0], px[1], px[2], px[3]]) as f64;
                    pixels.push([v, v, v]);
                    continue;
                }
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

/// The extent of a frame of `size` with the bloom's `factor`.
fn extent_of(size: (u32, u32), bloom_factor: Option<u32>) -> Extent {
    let low = bloom_factor.map_or(size, |f| downsampled_size(size.0, size.1, f));
    Extent {
        frame: [size.0, size.1],
        low: [low.0, low.1],
    }
}

/// The frame's fixed resources (textures of `width`×`height`, the capacity)
/// and its input uploaded: what the plan's stages are then wired between.
fn frame_resources<'a, 'p>(
    ctx: &'a GpuContext,
    input: &GpuInput,
    pipeline: &'p Pipeline<'p>,
    config: GpuConfig,
    (width, height): (u32, u32),
    taa: bool,
    extent: wgpu::Buffer,
) -> Result<Wiring<'a, 'p>, GpuError> {
    let format = config.hdr_format;
    let (weights, delta) = operator_constants(pipeline.operator);
    let (hdr, environment) = match input {
        GpuInput::Sphere { env, .. } => {
            let environment = Environment::upload(ctx, env, config.env_filter)?;
            let uniforms = super::stages::uniform_buffer(
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
    Ok(Wiring {
        ctx,
        format,
        width,
        height,
        pipeline,
        reduction: config.reduction,
        fault_gain: config.fault_gain,
        taa_fault: config.taa_fault,
        current,
        amount: None,
        taa: None,
        weights,
        delta,
        hdr,
        stats: shared_buffer(
            ctx,
            "tonegate.luminance_stats",
            std::mem::size_of::<GpuStats>() as u64,
        ),
        frame: storage_buffer(ctx, "tonegate.encode", width as u64 * height as u64 * 4),
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

#[cfg(test)]
mod tests {
    use super::max_component;

    #[test]
    fn max_component_is_the_serial_fold_at_any_length_with_nan_and_negatives() {
        let serial = |p: &[[f32; 3]]| {
            p.iter()
                .flat_map(|p| p.iter().copied())
                .fold(0.0f32, f32::max)
        };
        let mut seed = 7u32;
        let mut next = move || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1 << 24) as f32
        };
        for n in [0usize, 1, 2, 3, 5, 8, 11, 64, 1001] {
            let mut p: Vec<[f32; 3]> = (0..n)
                .map(|_| [next() * 10.0 - 5.0, next(), -next()])
                .collect();
            assert_eq!(max_component(&p), serial(&p), "{n}");
            if n > 2 {
                // The largest value in every possible lane position, and a
                // NaN in front of it, are still found.
                for at in 0..(3 * n).min(17) {
                    let mut q = p.clone();
                    q[at / 3][at % 3] = 1e30;
                    if at > 0 {
                        q[(at - 1) / 3][(at - 1) % 3] = f32::NAN;
                    }
                    assert_eq!(max_component(&q), 1e30, "{n} at {at}");
                }
                p[0][0] = f32::INFINITY;
                assert_eq!(max_component(&p), f32::INFINITY);
            }
        }
        assert_eq!(max_component(&[[-1.0, f32::NAN, -3.0]]), 0.0);
    }
}
