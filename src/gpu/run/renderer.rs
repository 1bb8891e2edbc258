//! The gate's front end on the executor: a stage plan's resources for
//! frames of one input, recorded by the executor (`exec::Executor`) with `encode`'s packed
//! frame as the sink, submitted and read back through the ring
//! (`readback`), frames in flight. Only the plan's stages are created,
//! dispatched and timed; what each stage reads and writes is wired in
//! `wiring` (and `fused`).

use super::readback::{GpuFrame, Ring, Sources, Ticket, FRAMES_IN_FLIGHT};
use super::timing::Queries;
use crate::conventions::{Camera, Mat3};
use crate::gpu::config::GpuConfig;
use crate::gpu::exec::Executor;
use crate::gpu::sphere::FrameUniforms;
use crate::gpu::stages::{extent_buffer, extent_of, storage_buffer, upload};
use crate::gpu::wiring::Wiring;
use crate::gpu::GpuInput;
use crate::gpu::{GpuContext, GpuError};
use crate::image::HdrImage;
use crate::perf::StageTiming;
use crate::plan::StagePlan;
use crate::reference::Pipeline;

/// A stage plan built on one context: its passes, textures and buffers,
/// rendered frame after frame (`readback`: submit, collect, frames in
/// flight; `inspect`: a stage's output read back).
pub struct GpuRenderer<'a> {
    pub(in crate::gpu) ctx: &'a GpuContext,
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
    pub(in crate::gpu) capacity: (u32, u32),
    /// The bloom's downsampling factor, which sizes its low-resolution level.
    pub(in crate::gpu) bloom_factor: Option<u32>,
    /// The `Extent` uniform the sized entry points read (stages::Extent).
    extent: wgpu::Buffer,
    camera: Option<Camera>,
    uniforms: Option<wgpu::Buffer>,
    /// The plan's stages, recorded into each frame's encoder.
    exec: Executor,
    /// The TAA history pair and uniforms, in a TAA plan.
    pub(in crate::gpu) taa: Option<crate::gpu::taa::TaaResources>,
    /// Whether the next frame is odd (reads the second history texture).
    pub(in crate::gpu) odd: std::sync::atomic::AtomicBool,
    /// The adapted luminance's state and step, in a plan with `adaptation`.
    adaptation: Option<crate::gpu::adaptation::AdaptationResources>,
    /// The scene's light for the next frames (`[[light]]`), as f32 bits:
    /// `sphere` scales its samples by it.
    light: std::sync::atomic::AtomicU32,
    /// Stage outputs that can be read back: (stage name, texture).
    pub(in crate::gpu) outputs: Vec<(&'static str, wgpu::Texture)>,
    stats: wgpu::Buffer,
    frame_buf: wgpu::Buffer,
    /// One set of host-readable copies per frame in flight.
    ring: Ring,
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
        if pipeline.encoding == crate::scene::Encoding::Pq
            && plan.contains("encode")
            && pipeline.operator.display_levels().is_none()
        {
            return Err(crate::plan::PlanError::NoParameters {
                stage: "encode",
                what: "the display levels a PQ frame needs (an operator that maps onto a display of known peak: bt2390)",
            }
            .into());
        }
        let requested = config;
        let (config, notes) = config.in_effect(input.max_component(), &plan, ctx.traits());
        let (width, height) = input.size();
        ctx.check_frame(width, height)?;
        let capacity = match input {
            GpuInput::Flat(_) => (width.max(capacity.0), height.max(capacity.1)),
            GpuInput::Sphere { .. } | GpuInput::View(_) => (width, height),
        };
        ctx.check_frame(capacity.0, capacity.1)?;
        let bloom_factor = plan.stages().iter().find_map(|s| match s {
            crate::plan::Stage::BloomDownsample { factor } => Some(*factor),
            _ => None,
        });
        let extent = extent_buffer(ctx, extent_of((width, height), bloom_factor));
        let taa = plan.taa().is_some();
        let mut wiring = Wiring::new(ctx, &input, pipeline, config, capacity, taa, extent)?;
        let input_texture = match input {
            GpuInput::Flat(_) => Some(wiring.hdr.clone()),
            GpuInput::Sphere { .. } | GpuInput::View(_) => None,
        };
        let camera = match input {
            GpuInput::Sphere { camera, .. } => Some(camera),
            GpuInput::Flat(_) | GpuInput::View(_) => None,
        };
        let exec = Executor::wire(&mut wiring, &plan, config.execution, None)?;
        // A plan without `encode` (an HDR or linear output) still names
        // its display image, which `encode` would otherwise have read.
        if !plan.contains("encode") {
            if let Some(display) = wiring.display.clone() {
                wiring.outputs.push(("display", display));
            }
        }
        let queries = Queries::new(ctx, exec.len());
        ctx.take_error()?;
        let frame_bytes = capacity.0 as u64
            * capacity.1 as u64
            * crate::gpu::encode::frame_bytes_per_pixel(pipeline.encoding);
        let Wiring {
            stats,
            frame,
            environment,
            outputs,
            taa,
            adaptation,
            extent,
            ..
        } = wiring;
        if let Some(a) = &adaptation {
            a.set_frame(ctx, true);
        }
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
            exec,
            taa,
            odd: std::sync::atomic::AtomicBool::new(false),
            adaptation,
            light: std::sync::atomic::AtomicU32::new(1f32.to_bits()),
            outputs,
            ring: Ring::new(
                ctx,
                capacity.0 as u64 * capacity.1 as u64,
                pipeline.encoding,
                queries.as_ref().map(|q| q.slot_bytes()),
            ),
            stats,
            // A plan without `encode` reads no frame back: a buffer stands in.
            frame_buf: frame.unwrap_or_else(|| storage_buffer(ctx, "tonegate.encode", frame_bytes)),
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
                .in_effect(img.max_component(), &self.plan, self.ctx.traits());
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

    pub(in crate::gpu) fn lock_size(&self) -> std::sync::MutexGuard<'_, (u32, u32)> {
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
        self.exec.stage_names()
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
            light: f32::from_bits(self.light.load(std::sync::atomic::Ordering::Relaxed)),
            _pad: 0.0,
        };
        self.ctx.queue.write_buffer(buf, 0, bytemuck::bytes_of(&u));
    }

    /// The scene's light (a `[[light]]` step's scale) for the frames after
    /// the next [`GpuRenderer::set_frame`] or `set_rotation`.
    pub fn set_light(&self, light: f64) {
        self.light.store(
            (light as f32).to_bits(),
            std::sync::atomic::Ordering::Relaxed,
        );
    }

    /// Whether the plan has `adaptation`, whose frames depend on the
    /// frames before.
    pub fn has_adaptation(&self) -> bool {
        self.adaptation.is_some()
    }

    /// The next frame's adaptation step: `reset` takes the frame's own
    /// measurement (the first frame of a sequence). Nothing without
    /// `adaptation` in the plan.
    pub fn set_adaptation(&self, reset: bool) {
        if let Some(a) = &self.adaptation {
            a.set_frame(self.ctx, reset);
        }
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
        let u = crate::gpu::taa::TaaUniforms::rotation(reprojection);
        self.ctx
            .queue
            .write_buffer(&taa.uniforms, 0, bytemuck::bytes_of(&u));
    }

    /// Records the plan's frame, timestamps (where the adapter has them)
    /// in `slot`.
    pub fn encode(&self, encoder: &mut wgpu::CommandEncoder, slot: u32) {
        let odd = self.odd.load(std::sync::atomic::Ordering::Relaxed);
        let stamps = self.queries.as_ref().map(|q| move |i| q.writes(slot, i));
        let stamps = stamps
            .as_ref()
            .map(|f| f as crate::gpu::exec::ComputeStamps);
        self.exec
            .record(encoder, odd, None, stamps, "tonegate.frame");
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
        let size = *self.lock_size();
        let sources = Sources {
            stats: &self.stats,
            frame: &self.frame_buf,
            queries: self.queries.as_ref(),
        };
        let ticket = self
            .ring
            .submit(self.ctx, sources, read_frame, size, |encoder, slot| {
                self.encode(encoder, slot)
            })?;
        if self.taa.is_some() {
            // The frame just submitted wrote the other history texture.
            self.odd
                .fetch_xor(true, std::sync::atomic::Ordering::Relaxed);
        }
        Ok(ticket)
    }

    /// Waits for a submitted frame and reads its results; its staging slot
    /// is free again afterwards whatever the outcome.
    pub fn collect(&self, ticket: Ticket) -> Result<GpuFrame, GpuError> {
        self.ring
            .collect(self.ctx, ticket, self.queries.as_ref(), &self.stage_names())
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
}
