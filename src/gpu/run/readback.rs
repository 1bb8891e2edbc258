//! The readback ring: up to [`FRAMES_IN_FLIGHT`] frames submitted and not
//! yet read, each with its own host-readable copies of the statistics, the
//! encoded frame and the timestamps, mapped asynchronously. `submit` takes a
//! slot, `collect` waits for its frame, reads it and frees the slot whatever
//! the outcome; `frames` keeps the ring full over a sequence.

use super::timing::Queries;
use crate::gpu::luminance_stats::GpuStats;
use crate::gpu::stages::read_buffer;
use crate::gpu::{GpuContext, GpuError};
use crate::image::{Frame, Image};
use crate::perf::StageTiming;

/// One rendered frame.
#[derive(Clone, Debug)]
pub struct GpuFrame {
    /// The encoded frame, when read back.
    pub frame: Option<Frame>,
    pub stats: GpuStats,
    /// GPU time of each stage of the plan (empty without timestamp support).
    pub timings: Vec<StageTiming>,
    /// Wall-clock time from submit to results on the host.
    pub wall_ms: f64,
}

/// Frames a renderer keeps in flight ([`crate::gpu::GpuRenderer::frames`]): each has its
/// own host-readable copies, so frame n is mapped and copied out while frame
/// n+1 renders. Three cover a frame being rendered, one being copied and one
/// being read on the host.
pub const FRAMES_IN_FLIGHT: usize = 3;

/// How long `collect` waits, once a frame's submission is done, for its
/// maps' callbacks to run in another thread's poll.
const MAP_PATIENCE: std::time::Duration = std::time::Duration::from_secs(10);

/// The host-readable copies of one frame in flight.
struct Staging {
    stats: wgpu::Buffer,
    frame: wgpu::Buffer,
    /// The frame's resolved timestamps, when the adapter has them.
    timing: Option<wgpu::Buffer>,
}

/// A submitted frame: [`crate::gpu::GpuRenderer::collect`] waits for it and reads it.
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

/// The staging slots and which of them a frame not yet collected holds.
pub(in crate::gpu) struct Ring {
    staging: Vec<Staging>,
    /// Bytes a pixel of the packed frame: 8 for 16-bit PQ (two words), 4
    /// for RGBA8.
    bytes_per_pixel: u64,
    busy: std::sync::Mutex<[bool; FRAMES_IN_FLIGHT]>,
    submitted: std::sync::atomic::AtomicUsize,
}

impl Ring {
    /// Slots for frames of up to `pixels` in `encoding`, with
    /// `timing_bytes` of resolved timestamps each when the adapter has
    /// timestamp queries.
    pub(in crate::gpu) fn new(
        ctx: &GpuContext,
        pixels: u64,
        encoding: crate::scene::Encoding,
        timing_bytes: Option<u64>,
    ) -> Ring {
        let bytes_per_pixel = crate::gpu::encode::frame_bytes_per_pixel(encoding);
        let frame_bytes = pixels * bytes_per_pixel;
        Ring {
            bytes_per_pixel,
            staging: (0..FRAMES_IN_FLIGHT)
                .map(|_| Staging {
                    stats: read_buffer(
                        ctx,
                        "tonegate.luminance_stats.read",
                        std::mem::size_of::<GpuStats>() as u64,
                    ),
                    frame: read_buffer(ctx, "tonegate.encode.read", frame_bytes.max(16)),
                    timing: timing_bytes
                        .map(|bytes| read_buffer(ctx, "tonegate.timestamps.read", bytes)),
                })
                .collect(),
            busy: Default::default(),
            submitted: Default::default(),
        }
    }

    /// The next slot in turn, refused while the frame in it is not collected.
    fn take(&self) -> Result<usize, GpuError> {
        let n = self
            .submitted
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let slot = n % FRAMES_IN_FLIGHT;
        let mut busy = self.lock_busy();
        if busy[slot] {
            return Err(GpuError::Readback(format!(
                "more than {FRAMES_IN_FLIGHT} frames submitted and not collected"
            )));
        }
        busy[slot] = true;
        Ok(slot)
    }

    fn release(&self, slot: usize) {
        self.lock_busy()[slot] = false;
    }

    fn lock_busy(&self) -> std::sync::MutexGuard<'_, [bool; FRAMES_IN_FLIGHT]> {
        self.busy
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// The staging buffers a frame in `slot` maps, tagged as in
    /// [`Ticket::mapped`].
    fn buffers(
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

    /// Records a frame with `encode` (given its slot for timestamps), copies
    /// its results from `sources` into a free slot's staging buffers,
    /// submits it, and starts mapping them without waiting. At most
    /// [`FRAMES_IN_FLIGHT`] frames may be submitted and not yet collected.
    pub(in crate::gpu) fn submit(
        &self,
        ctx: &GpuContext,
        sources: Sources,
        read_frame: bool,
        size: (u32, u32),
        encode: impl FnOnce(&mut wgpu::CommandEncoder, u32),
    ) -> Result<Ticket, GpuError> {
        let start = std::time::Instant::now();
        let slot = self.take()?;
        let staging = &self.staging[slot];
        let mut encoder = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("tonegate.frame"),
            });
        encode(&mut encoder, slot as u32);
        if let (Some(q), Some(dst)) = (sources.queries, &staging.timing) {
            q.copy_slot(&mut encoder, slot as u32, dst);
        }
        encoder.copy_buffer_to_buffer(
            sources.stats,
            0,
            &staging.stats,
            0,
            std::mem::size_of::<GpuStats>() as u64,
        );
        if read_frame {
            encoder.copy_buffer_to_buffer(
                sources.frame,
                0,
                &staging.frame,
                0,
                size.0 as u64 * size.1 as u64 * self.bytes_per_pixel,
            );
        }
        let submission = ctx.queue.submit([encoder.finish()]);
        let (tx, mapped) = std::sync::mpsc::channel();
        for (i, buffer) in self.buffers(slot, read_frame) {
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

    /// Waits for a submitted frame and reads its results. Its staging slot
    /// is free again afterwards whatever the outcome: every buffer whose map
    /// succeeded or is still pending is unmapped (which cancels a pending
    /// one), so a failed frame leaves nothing mapped for the next frame's
    /// copies to trip over.
    pub(in crate::gpu) fn collect(
        &self,
        ctx: &GpuContext,
        ticket: Ticket,
        queries: Option<&Queries>,
        stage_names: &[&'static str],
    ) -> Result<GpuFrame, GpuError> {
        use crate::perf::clock::{timed, Part};
        let waited = timed(Part::ReadbackWait, || wait(ctx, &ticket));
        let mut outcome: [Option<Result<(), wgpu::BufferAsyncError>>; 3] = Default::default();
        if waited.is_ok() {
            self.gather(ctx, &ticket, &mut outcome);
        }
        while let Ok((i, r)) = ticket.mapped.try_recv() {
            outcome[i] = Some(r);
        }
        let result = waited.and_then(|()| {
            for (i, _) in self.buffers(ticket.slot, ticket.read_frame) {
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
            timed(Part::ReadbackCopy, || {
                self.read(ctx, &ticket, queries, stage_names)
            })
        });
        for (i, buffer) in self.buffers(ticket.slot, ticket.read_frame) {
            // A failed map left its buffer unmapped already; unmapping it
            // again would be a validation error on the device.
            if !matches!(outcome[i], Some(Err(_))) {
                buffer.unmap();
            }
        }
        self.release(ticket.slot);
        result
    }

    /// Receives the outcome of each of the ticket's maps. The wait returns
    /// once the submission is done, but a map's callback runs in whichever
    /// thread polls the device next: when several threads render on one
    /// device (the stress suite's rows), another thread's poll may still be
    /// running it. So this polls until every outcome is in, for at most
    /// [`MAP_PATIENCE`]; what is still missing then is reported by
    /// `collect`.
    fn gather(
        &self,
        ctx: &GpuContext,
        ticket: &Ticket,
        outcome: &mut [Option<Result<(), wgpu::BufferAsyncError>>; 3],
    ) {
        let started = std::time::Instant::now();
        loop {
            while let Ok((i, r)) = ticket.mapped.try_recv() {
                outcome[i] = Some(r);
            }
            let missing = self
                .buffers(ticket.slot, ticket.read_frame)
                .any(|(i, _)| outcome[i].is_none());
            if !missing || started.elapsed() > MAP_PATIENCE {
                return;
            }
            let _ = ctx.device.poll(wgpu::PollType::Poll);
            if let Ok((i, r)) = ticket
                .mapped
                .recv_timeout(std::time::Duration::from_micros(200))
            {
                outcome[i] = Some(r);
            }
        }
    }

    fn read(
        &self,
        ctx: &GpuContext,
        ticket: &Ticket,
        queries: Option<&Queries>,
        stage_names: &[&'static str],
    ) -> Result<GpuFrame, GpuError> {
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
            let (width, height) = ticket.size;
            let n = width as usize * height as usize;
            Some(if self.bytes_per_pixel == 8 {
                Frame::Pq16(Image {
                    width,
                    height,
                    pixels: unpack_pq16(&view, n),
                })
            } else {
                Frame::Rgb8(Image {
                    width,
                    height,
                    pixels: unpack_rgba8(&view, n),
                })
            })
        } else {
            None
        };
        let timings = match (queries, &staging.timing) {
            (Some(q), Some(b)) => q.parse(&mapped(b)?, stage_names, ctx),
            _ => Vec::new(),
        };
        Ok(GpuFrame {
            frame,
            stats,
            timings,
            wall_ms: ticket.start.elapsed().as_secs_f64() * 1e3,
        })
    }
}

/// The first `n` pixels of an encoded RGBA8 frame as RGB: the one copy a
/// frame takes off its mapping. At 1080p on llvmpipe's host, 2026-11-27
/// (criterion, `gpu_pipeline`'s `readback_1080p` group, medians of one
/// run): 0.87 ms, against 0.59 ms for a plain memcpy of the mapped bytes,
/// 0.71 ms for the copy into the buffer with its wait, and under 1 µs for
/// the map and unmap. Byte chunks measured faster than whole `[u8; 4]`
/// pixels (0.94 ms), and a reused vector saved 0.06 ms (the allocation).
pub fn unpack_rgba8(bytes: &[u8], n: usize) -> Vec<[u8; 3]> {
    bytes
        .chunks_exact(4)
        .take(n)
        .map(|c| [c[0], c[1], c[2]])
        .collect()
}

/// The first `n` pixels of an encoded 16-bit PQ frame (four little-endian
/// words a pixel) as RGB words.
pub fn unpack_pq16(bytes: &[u8], n: usize) -> Vec<[u16; 3]> {
    let pixels: &[[[u8; 2]; 4]] = bytemuck::cast_slice(&bytes[..n * 8]);
    pixels
        .iter()
        .map(|&[r, g, b, _]| {
            [
                u16::from_le_bytes(r),
                u16::from_le_bytes(g),
                u16::from_le_bytes(b),
            ]
        })
        .collect()
}

/// The buffers a frame's results are copied from.
pub(in crate::gpu) struct Sources<'a> {
    pub stats: &'a wgpu::Buffer,
    pub frame: &'a wgpu::Buffer,
    pub queries: Option<&'a Queries>,
}

/// Waits until the ticket's submission is done, then reports the first
/// error the device raised, whether or not the wait succeeded (a
/// submission that failed validation is never done, and its validation
/// error says why better than the wait), and forgets the rest: one fault
/// raises several (at `finish` and at `submit`), which would otherwise
/// fail the frames after it.
fn wait(ctx: &GpuContext, ticket: &Ticket) -> Result<(), GpuError> {
    let waited = ctx.device.poll(wgpu::PollType::Wait {
        submission_index: Some(ticket.submission.clone()),
        timeout: None,
    });
    ctx.take_first_error()?;
    waited
        .map(|_| ())
        .map_err(|e| GpuError::DeviceLost(e.to_string()))
}
