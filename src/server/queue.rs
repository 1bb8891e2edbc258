//! The bounded work queues of `POST /tonemap`: one for the GPU, one for the
//! CPU reference, each with one worker thread. A request takes a permit
//! once its body is in (bodies being received are bounded apart, in
//! `uploads`, so a client that sends slowly holds no place), so at most
//! `waiting + 1` bodies per queue wait in memory; with no permit left the
//! answer is 503 with `Retry-After`, never an unbounded pile-up.

use super::error::ApiError;
use crate::gpu::GpuContext;
use crate::io::LoadOptions;
use crate::render::Renderer;
use crate::toning::{OutputKind, Resolved, TonedImage};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, RwLock};
use std::time::Instant;
use tokio::sync::{oneshot, OwnedSemaphorePermit, Semaphore};

/// What one job asks for.
pub struct JobParams {
    pub resolved: Resolved,
    pub load: LoadOptions,
    pub source_name: String,
}

/// A tone-mapped image and what was measured on the way.
pub struct ToneOutput {
    pub png: Vec<u8>,
    pub width: u32,
    pub height: u32,
    /// What the decoder found in the body.
    pub input: crate::io::LoadReport,
    /// The renderer, the path, the plan, the statistics and the tone
    /// parameters.
    pub report: crate::toning::ToneReport,
    /// The whole job: decode, tone-map and PNG.
    pub render_ms: f64,
    pub queue_ms: f64,
    /// Where `render_ms` went: decoding the body, the tone-map (upload,
    /// stages and readback on the GPU) and encoding the PNG.
    pub decode_ms: f64,
    pub tonemap_ms: f64,
    pub png_ms: f64,
}

struct Job {
    bytes: axum::body::Bytes,
    params: JobParams,
    queued_at: Instant,
    reply: oneshot::Sender<Result<ToneOutput, ApiError>>,
    _permit: OwnedSemaphorePermit,
}

/// Counters of one queue, for `/metrics` and `/healthz`.
#[derive(Default)]
pub struct QueueStats {
    pub accepted: AtomicU64,
    pub rejected: AtomicU64,
    pub succeeded: AtomicU64,
    pub failed: AtomicU64,
    /// Jobs whose client had gone (timed out or disconnected): stopped
    /// before they started or between stages, their memory freed.
    pub abandoned: AtomicU64,
    pub busy_us: AtomicU64,
}

pub struct Queue {
    pub name: &'static str,
    /// Jobs that may wait besides the one running.
    pub waiting: usize,
    permits: Arc<Semaphore>,
    /// `None` once the queue is shut down (see `Drop`).
    tx: Option<std::sync::mpsc::SyncSender<Job>>,
    worker: Option<std::thread::JoinHandle<()>>,
    pub stats: Arc<QueueStats>,
}

/// Shutting down: the worker finishes the jobs already queued (their
/// clients are answered, or counted abandoned when gone), then drops its
/// GPU context, and only then does the drop return. A process that exits
/// while a worker thread still holds a Vulkan device can crash in the
/// driver's exit handlers (`serve` on NVIDIA ended with SIGSEGV after GPU
/// requests); joining here releases the device first.
impl Drop for Queue {
    fn drop(&mut self) {
        drop(self.tx.take());
        if let Some(worker) = self.worker.take() {
            if worker.join().is_err() {
                tracing::error!(queue = self.name, "the tone-map worker panicked");
            } else {
                tracing::info!(queue = self.name, "tone-map worker stopped");
            }
        }
    }
}

impl Queue {
    /// Starts the worker thread. `hold` (tests only) is read-locked around
    /// every job, so a test can keep the worker busy while it fills the queue.
    pub fn start(
        name: &'static str,
        waiting: usize,
        engine: Renderer,
        hold: Option<Arc<RwLock<()>>>,
    ) -> std::io::Result<Queue> {
        let capacity = waiting + 1;
        let (tx, rx) = std::sync::mpsc::sync_channel::<Job>(capacity);
        let stats = Arc::new(QueueStats::default());
        let s = stats.clone();
        let worker = std::thread::Builder::new()
            .name(format!("tonemap-{name}"))
            .spawn(move || worker(rx, engine, s, hold))?;
        Ok(Queue {
            name,
            waiting,
            permits: Arc::new(Semaphore::new(capacity)),
            tx: Some(tx),
            worker: Some(worker),
            stats,
        })
    }

    /// Jobs in the queue, the running one included.
    pub fn depth(&self) -> usize {
        self.waiting + 1 - self.permits.available_permits()
    }

    pub fn capacity(&self) -> usize {
        self.waiting + 1
    }

    /// A place in the queue, or 503 with a `Retry-After` of about the time
    /// the jobs ahead take.
    pub fn reserve(&self) -> Result<OwnedSemaphorePermit, ApiError> {
        match self.permits.clone().try_acquire_owned() {
            Ok(p) => {
                self.stats.accepted.fetch_add(1, Ordering::Relaxed);
                Ok(p)
            }
            Err(_) => {
                self.stats.rejected.fetch_add(1, Ordering::Relaxed);
                let done = self.stats.succeeded.load(Ordering::Relaxed)
                    + self.stats.failed.load(Ordering::Relaxed);
                let mean_s = if done == 0 {
                    1.0
                } else {
                    self.stats.busy_us.load(Ordering::Relaxed) as f64 / done as f64 / 1e6
                };
                let wait = (mean_s * self.capacity() as f64).ceil() as u64;
                Err(ApiError::unavailable(
                    "busy",
                    format!(
                        "the {} tone-map queue is full ({} jobs); try again later",
                        self.name,
                        self.capacity()
                    ),
                    wait,
                ))
            }
        }
    }

    /// Hands a job to the worker; the answer comes on the returned channel.
    pub fn submit(
        &self,
        permit: OwnedSemaphorePermit,
        bytes: axum::body::Bytes,
        params: JobParams,
    ) -> Result<oneshot::Receiver<Result<ToneOutput, ApiError>>, ApiError> {
        let (reply, rx) = oneshot::channel();
        let job = Job {
            bytes,
            params,
            queued_at: Instant::now(),
            reply,
            _permit: permit,
        };
        // The channel holds as many jobs as there are permits, so with a
        // permit this never blocks; it fails only if the worker died.
        let stopped = || ApiError::internal(format!("the {} tone-map worker stopped", self.name));
        self.tx
            .as_ref()
            .ok_or_else(stopped)?
            .try_send(job)
            .map_err(|_| stopped())?;
        Ok(rx)
    }
}

fn worker(
    rx: std::sync::mpsc::Receiver<Job>,
    engine: Renderer,
    stats: Arc<QueueStats>,
    hold: Option<Arc<RwLock<()>>>,
) {
    let mut next = rx.recv().ok();
    // One pass per device: the GPU engine opens its context with the first
    // job and keeps it, with the renderers it made (reused by size and
    // settings), until a job leaves the device in doubt (a device error or
    // a panic); the next job then opens a fresh one.
    while let Some(first) = next.take() {
        let ctx = match &engine {
            Renderer::Cpu => None,
            Renderer::Gpu { adapter, .. } => {
                // A driver that panics while the device opens fails this
                // job, not the worker: the next job tries again.
                let opened = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                    GpuContext::new(adapter)
                }));
                let failed = match opened {
                    Ok(Ok(ctx)) => Ok(ctx),
                    Ok(Err(e)) => Err(ApiError::of_gpu(&e)),
                    Err(_) => Err(ApiError::internal(
                        "opening the GPU device panicked; the next job tries again",
                    )),
                };
                match failed {
                    Ok(ctx) => Some(ctx),
                    Err(e) => {
                        finish(first, &stats, Err(e));
                        next = rx.recv().ok();
                        continue;
                    }
                }
            }
        };
        let mut renderers = ctx.as_ref().map(crate::gpu::RendererPool::new);
        let mut job = first;
        // Whether jobs may still come: false once the queue is shut down.
        let open = loop {
            if serve_job(job, &engine, renderers.as_mut(), &stats, &hold) {
                // The device is in doubt: release it now, not when the next
                // job comes, which may be never.
                break true;
            }
            match rx.recv() {
                Ok(j) => job = j,
                Err(_) => break false,
            }
        };
        drop(renderers);
        if ctx.is_some() {
            drop(ctx);
            tracing::info!("GPU context released");
        }
        if open {
            next = rx.recv().ok();
        }
    }
}

/// Answers `job` (unless its client left) with `result`, counted.
fn finish(job: Job, stats: &QueueStats, result: Result<ToneOutput, ApiError>) {
    if job.reply.is_closed() {
        stats.abandoned.fetch_add(1, Ordering::Relaxed);
        return;
    }
    let counter = if result.is_ok() {
        &stats.succeeded
    } else {
        &stats.failed
    };
    counter.fetch_add(1, Ordering::Relaxed);
    // The place is free before the answer leaves: a client that sends its
    // next request the moment it has this answer finds it free (with the
    // permit dropped after the send, c = capacity got 503s).
    let Job {
        reply,
        _permit: permit,
        ..
    } = job;
    drop(permit);
    let _ = reply.send(result);
}

/// Runs one job and answers it; true when the device must be opened afresh
/// for the next (a device error or a panic may have left it in any state).
fn serve_job(
    job: Job,
    engine: &Renderer,
    renderers: Option<&mut crate::gpu::RendererPool>,
    stats: &QueueStats,
    hold: &Option<Arc<RwLock<()>>>,
) -> bool {
    let _held = hold.as_ref().map(|h| h.read());
    if job.reply.is_closed() {
        stats.abandoned.fetch_add(1, Ordering::Relaxed);
        return false;
    }
    let queue_ms = job.queued_at.elapsed().as_secs_f64() * 1e3;
    let start = Instant::now();
    let gone = || job.reply.is_closed();
    let mut fresh_device = false;
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        run_job(
            &job.bytes,
            &job.params,
            engine,
            renderers,
            &mut fresh_device,
            &gone,
        )
    }))
    .unwrap_or_else(|_| {
        fresh_device = true;
        Err(ApiError::internal("the tone mapper panicked on this input"))
    });
    let elapsed = start.elapsed();
    stats
        .busy_us
        .fetch_add(elapsed.as_micros() as u64, Ordering::Relaxed);
    match result {
        Ok(Some(mut out)) => {
            out.render_ms = elapsed.as_secs_f64() * 1e3;
            out.queue_ms = queue_ms;
            finish(job, stats, Ok(out));
        }
        Ok(None) => {
            stats.abandoned.fetch_add(1, Ordering::Relaxed);
        }
        Err(e) => finish(job, stats, Err(e)),
    }
    fresh_device
}

/// One job; `Ok(None)` when `gone` said its client left (checked after
/// decoding, between the stages, and before encoding the PNG).
fn run_job(
    bytes: &[u8],
    p: &JobParams,
    engine: &Renderer,
    renderers: Option<&mut crate::gpu::RendererPool>,
    fresh_device: &mut bool,
    gone: &dyn Fn() -> bool,
) -> Result<Option<ToneOutput>, ApiError> {
    let ms = |since: Instant| since.elapsed().as_secs_f64() * 1e3;
    let start = Instant::now();
    // On the GPU, an image the device cannot hold is refused from its
    // header, before seconds of decoding.
    let mut load = p.load;
    if let (Renderer::Gpu { .. }, Some(r)) = (engine, renderers.as_ref()) {
        load.device = Some(r.ctx().frame_fit());
    }
    let (img, load_report) =
        crate::io::decode_hdr(bytes, &p.source_name, &load).map_err(|e| ApiError::of_image(&e))?;
    let decode_ms = ms(start);
    if gone() {
        return Ok(None);
    }
    let start = Instant::now();
    let gpu = match (engine, renderers) {
        (Renderer::Gpu { config, .. }, Some(r)) => Some((r, *config)),
        _ => None,
    };
    let want = p
        .resolved
        .output_kind(OutputKind::Encoded)
        .map_err(|e| ApiError::of_crate(&e))?;
    let result = crate::toning::tone_map_until(&img, &p.resolved.pipeline(), gpu, want, gone);
    let tonemap_ms = ms(start);
    if let Err(crate::Error::Gpu(e)) = &result {
        if !matches!(
            e,
            crate::gpu::GpuError::TooLarge { .. } | crate::gpu::GpuError::FrameTooLarge { .. }
        ) {
            // A lost device is not coming back: the next job opens a new one.
            *fresh_device = true;
        }
    }
    let Some(out) = result.map_err(|e| ApiError::of_crate(&e))? else {
        return Ok(None);
    };
    let crate::toning::Toned { report, image } = out;
    // The 8-bit frame, or the 16-bit image with its chunks: both own their
    // pixels, so the input can go.
    let image = match image {
        TonedImage::Encoded(frame) => Ok(frame),
        TonedImage::Hdr(hdr, info) => Err((hdr, info)),
        _ => return Err(ApiError::internal("the tone-map made no PNG image")),
    };
    // The input is not needed past here: a server holds little per job.
    drop(img);
    if gone() {
        return Ok(None);
    }
    let start = Instant::now();
    let (png, width, height) = match &image {
        Ok(frame) => (crate::io::encode_png8(frame), frame.width, frame.height),
        Err((hdr, info)) => (crate::io::encode_hdr_png(hdr, info), hdr.width, hdr.height),
    };
    let png = png.map_err(|e| ApiError::internal(e.to_string()))?;
    let png_ms = ms(start);
    Ok(Some(ToneOutput {
        png,
        width,
        height,
        input: load_report,
        report,
        render_ms: 0.0,
        queue_ms: 0.0,
        decode_ms,
        tonemap_ms,
        png_ms,
    }))
}
