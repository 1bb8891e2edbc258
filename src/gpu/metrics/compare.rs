//! Every figure of an 8-bit pair on the GPU (`check --metrics gpu`): both
//! images uploaded once, then in one submission the error sums and the
//! fraction over one code (`shaders/compare.wgsl`, integers: exact), SSIM
//! (the same file: f32, about the window's own mean) and FLIP
//! ([`super::flip`]). Only the workgroups' partial sums and the FLIP map
//! come back; the host adds the sums in f64 (integers in u64) and applies
//! the CPU's formulas (`metrics::metrics_from`), so MSE, RMSE, PSNR, SNR,
//! the differences and the fraction over one code are the CPU's exactly.
//!
//! Locked by `tests/it/gpu_metrics.rs`: SSIM's mean within 1e-6 of the
//! CPU's, FLIP's within 1e-4 of nv-flip's, the rest equal.

use super::flip::{read_map, upload, GpuFlip};
use crate::gpu::stages::{pipeline, read_buffer};
use crate::gpu::{GpuContext, GpuError, HdrFormat};
use crate::image::Image;
use crate::metrics::basic::ErrorSums;
use crate::metrics::flip::{Flip, DEFAULT_PPD};
use crate::metrics::{Metrics, MetricsError, Raster, Ssim, SSIM_WINDOW};

pub struct GpuCompare<'c> {
    ctx: &'c GpuContext,
    flip: GpuFlip<'c>,
    errors: wgpu::ComputePipeline,
    ssim: wgpu::ComputePipeline,
    ssim_map: wgpu::ComputePipeline,
}

/// What one comparison on the device gives: the figures, FLIP with its
/// map, and (when asked for) SSIM's map.
struct Compared {
    metrics: Metrics,
    flip: Flip,
    ssim_map: Option<Image<f64>>,
}

impl<'c> GpuCompare<'c> {
    pub fn new(ctx: &'c GpuContext) -> GpuCompare<'c> {
        let p = |entry| pipeline(ctx, "compare", entry, HdrFormat::Rgba32Float, &[]);
        GpuCompare {
            ctx,
            flip: GpuFlip::new(ctx),
            errors: p("errors"),
            ssim: p("ssim"),
            ssim_map: p("ssim_map"),
        }
    }

    /// What `metrics::compare_with_flip` gives for `test` against
    /// `reference`, computed on the device. RGB images only: grey and RGBA
    /// ones (whose alpha the CPU's error sums count) are compared on the CPU.
    pub fn compare(
        &self,
        test: Raster,
        reference: Raster,
    ) -> Result<(Metrics, Flip), MetricsError> {
        crate::metrics::raster::check_pair(&test, &reference)?;
        if test.channels != 3 {
            return crate::metrics::compare_with_flip(test, reference);
        }
        if test.width < SSIM_WINDOW || test.height < SSIM_WINDOW {
            return Err(MetricsError::TooSmallForSsim {
                width: test.width,
                height: test.height,
            });
        }
        let c = self.device(test, reference, false)?;
        Ok((c.metrics, c.flip))
    }

    /// The maps of a frame whose artifacts are kept, from the same passes
    /// as its figures: SSIM at every pixel (uncropped, mirrored at the
    /// edges, as `metrics::ssim`'s map) and FLIP's. RGB images at least
    /// [`SSIM_WINDOW`] wide and tall.
    pub fn maps(&self, test: Raster, reference: Raster) -> Result<(Ssim, Flip), MetricsError> {
        crate::metrics::raster::check_pair(&test, &reference)?;
        if test.channels != 3 || test.width < SSIM_WINDOW || test.height < SSIM_WINDOW {
            return Err(MetricsError::Device {
                metric: "the SSIM and FLIP maps",
                detail: format!(
                    "{}x{} with {} channels: the device's maps take RGB images of at least {SSIM_WINDOW}x{SSIM_WINDOW}",
                    test.width, test.height, test.channels
                ),
            });
        }
        let c = self.device(test, reference, true)?;
        let map = c.ssim_map.ok_or_else(|| MetricsError::Device {
            metric: "the SSIM map",
            detail: "not read back".into(),
        })?;
        Ok((
            Ssim {
                mean: c.metrics.ssim,
                map,
            },
            c.flip,
        ))
    }

    fn device(&self, test: Raster, reference: Raster, map: bool) -> Result<Compared, MetricsError> {
        self.run(test, reference, map)
            .map_err(|e| MetricsError::Device {
                metric: "the metrics",
                detail: e.to_string(),
            })
    }

    fn run(&self, test: Raster, reference: Raster, with_map: bool) -> Result<Compared, GpuError> {
        let ctx = self.ctx;
        let (width, height) = (test.width, test.height);
        ctx.check_frame(width, height)?;
        let input_test = upload(ctx, &test, "tonegate.compare.test");
        let input_ref = upload(ctx, &reference, "tonegate.compare.reference");
        let error_groups = (width.div_ceil(8), height.div_ceil(8));
        let ssim_groups = ((width - 10).div_ceil(8), (height - 10).div_ceil(8));
        let words = [width, height, error_groups.0, ssim_groups.0];
        let init = |label: &str, contents: &[u8], usage: wgpu::BufferUsages| {
            crate::gpu::stages::buffer_with(ctx, label, contents, usage)
        };
        let storage = wgpu::BufferUsages::STORAGE;
        let copy = wgpu::BufferUsages::COPY_SRC;
        let params = init(
            "tonegate.compare.params",
            bytemuck::cast_slice(&words),
            wgpu::BufferUsages::UNIFORM,
        );
        let weights = crate::metrics::ssim::gaussian_taps().map(|w| w as f32);
        let gauss = init(
            "tonegate.compare.gauss",
            bytemuck::cast_slice(&weights),
            storage,
        );
        let n_errors = error_groups.0 as u64 * error_groups.1 as u64;
        let n_ssim = ssim_groups.0 as u64 * ssim_groups.1 as u64;
        let error_sums = init(
            "tonegate.compare.error_sums",
            &vec![0u8; (n_errors * 16) as usize],
            storage | copy,
        );
        let max_diff = init("tonegate.compare.max_diff", &[0u8; 4], storage | copy);
        let ssim_sums = init(
            "tonegate.compare.ssim_sums",
            &vec![0u8; (n_ssim * 4) as usize],
            storage | copy,
        );
        let bind = |pipeline: &wgpu::ComputePipeline, entries: &[(u32, &wgpu::Buffer)]| {
            crate::gpu::stages::bind_buffers(ctx, "tonegate.compare", pipeline, entries)
        };
        let errors_group = bind(
            &self.errors,
            &[
                (0, &params),
                (1, &input_ref),
                (2, &input_test),
                (3, &error_sums),
                (4, &max_diff),
            ],
        );
        let ssim_group = bind(
            &self.ssim,
            &[
                (0, &params),
                (1, &input_ref),
                (2, &input_test),
                (5, &gauss),
                (6, &ssim_sums),
            ],
        );
        let pixels = width as u64 * height as u64;
        let map_out = with_map.then(|| {
            init(
                "tonegate.compare.ssim_map",
                &vec![0u8; (pixels * 4) as usize],
                storage | copy,
            )
        });
        let map_group = map_out.as_ref().map(|out| {
            bind(
                &self.ssim_map,
                &[
                    (0, &params),
                    (1, &input_ref),
                    (2, &input_test),
                    (5, &gauss),
                    (7, out),
                ],
            )
        });
        let mut encoder = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("tonegate.compare"),
            });
        let map_pass = map_group
            .as_ref()
            .map(|g| (&self.ssim_map, g, (width.div_ceil(8), height.div_ceil(8))));
        for (pipeline, group, groups) in [
            (&self.errors, &errors_group, error_groups),
            (&self.ssim, &ssim_group, ssim_groups),
        ]
        .into_iter()
        .chain(map_pass)
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("tonegate.compare"),
                timestamp_writes: None,
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, group, &[]);
            pass.dispatch_workgroups(groups.0, groups.1, 1);
        }
        let reads: Vec<(wgpu::Buffer, u64)> = [
            (&error_sums, n_errors * 16),
            (&max_diff, 4),
            (&ssim_sums, n_ssim * 4),
        ]
        .into_iter()
        .chain(map_out.as_ref().map(|b| (b, pixels * 4)))
        .map(|(source, bytes)| {
            let read = read_buffer(ctx, "tonegate.compare.read", bytes.max(16));
            encoder.copy_buffer_to_buffer(source, 0, &read, 0, bytes);
            (read, bytes)
        })
        .collect();
        let ppd = DEFAULT_PPD as f32;
        let flip_read =
            self.flip
                .record(&mut encoder, &input_test, &input_ref, (width, height), ppd);
        ctx.queue.submit([encoder.finish()]);
        // Each buffer's words, read where they are mapped.
        let words = |i: usize| -> Result<Vec<u32>, GpuError> {
            let (read, n) = &reads[i];
            ctx.with_mapped(read, |b| {
                b[..*n as usize]
                    .chunks_exact(4)
                    .map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
                    .collect()
            })
        };
        let partials = words(0)?;
        let mut sums = ErrorSums {
            samples: width as u64 * height as u64 * 3,
            ..ErrorSums::default()
        };
        let mut over = 0u64;
        for p in partials.chunks_exact(4) {
            sums.squared_error += u64::from(p[0]);
            sums.reference_energy += u64::from(p[1]);
            sums.abs_error += u64::from(p[2]);
            over += u64::from(p[3]);
        }
        let max = words(1)?[0];
        sums.max_abs_diff = u8::try_from(max).map_err(|_| {
            GpuError::Readback(format!("a difference of {max} codes between 8-bit images"))
        })?;
        let ssim_sum: f64 = words(2)?
            .into_iter()
            .map(|w| f64::from(f32::from_bits(w)))
            .sum();
        let cropped = (width as u64 - 10) * (height as u64 - 10);
        let ssim = ssim_sum / cropped as f64;
        let flip = read_map(ctx, &flip_read, (width, height), ppd)?;
        let fraction = over as f64 / pixels as f64;
        let ssim_map = match with_map {
            true => Some(Image {
                width,
                height,
                pixels: words(3)?
                    .into_iter()
                    .map(|w| f64::from(f32::from_bits(w)))
                    .collect(),
            }),
            false => None,
        };
        Ok(Compared {
            metrics: crate::metrics::metrics_from(&sums, ssim, fraction, flip.mean()),
            flip,
            ssim_map,
        })
    }
}

/// An RGB frame of shared structure (gradients) and per-seed noise: two
/// seeds differ everywhere by a few codes.
fn synthetic(width: u32, height: u32, seed: u32) -> Vec<u8> {
    (0..width * height * 3)
        .map(|i| {
            let (x, y, c) = ((i / 3) % width, (i / 3) / width, i % 3);
            let noise = (i.wrapping_mul(2_654_435_761) ^ seed.wrapping_mul(0x9E37_79B9)) >> 28;
            ((x / 3 + y / 2 + c * 70 + noise) % 256) as u8
        })
        .collect()
}

impl GpuCompare<'_> {
    /// The locks, checked on this adapter before a gate trusts it: one
    /// synthetic pair (67×53, and the same against a copy shifted by 40
    /// codes) compared on the device and on the CPU, held to
    /// [`agrees`]. A check whose adapter fails it judges on the CPU and says
    /// why (`check --metrics auto|gpu`).
    pub fn self_check(&self) -> Result<(), String> {
        let (w, h) = (67, 53);
        let a = synthetic(w, h, 1);
        let b = synthetic(w, h, 2);
        let shifted: Vec<u8> = a.iter().map(|&v| v.saturating_add(40)).collect();
        for other in [&b, &shifted] {
            let (t, r) = (
                Raster::new(w, h, 3, &a).map_err(|e| e.to_string())?,
                Raster::new(w, h, 3, other).map_err(|e| e.to_string())?,
            );
            let (gpu, _) = self.compare(t, r).map_err(|e| e.to_string())?;
            let (cpu, _) = crate::metrics::compare_with_flip(t, r).map_err(|e| e.to_string())?;
            agrees(&gpu, &cpu)?;
        }
        Ok(())
    }
}

/// Whether the GPU's figures are the CPU's within the locks: the ones from
/// integer sums equal, SSIM's mean within 1e-6, FLIP's within 1e-4; the
/// first that is not, named.
pub fn agrees(gpu: &Metrics, cpu: &Metrics) -> Result<(), String> {
    let exact = [
        ("MSE", gpu.mse, cpu.mse),
        ("PSNR", gpu.psnr, cpu.psnr),
        ("SNR", gpu.snr, cpu.snr),
        ("mean |diff|", gpu.mean_abs_diff, cpu.mean_abs_diff),
        (
            "fraction over 1 code",
            gpu.fraction_over_1lsb,
            cpu.fraction_over_1lsb,
        ),
        (
            "max |diff|",
            f64::from(gpu.max_abs_diff),
            f64::from(cpu.max_abs_diff),
        ),
    ];
    for (name, g, c) in exact {
        if g.to_bits() != c.to_bits() {
            return Err(format!("{name} {g} on the GPU against {c} on the CPU"));
        }
    }
    for (name, g, c, bound) in [
        ("SSIM", gpu.ssim, cpu.ssim, 1e-6),
        ("FLIP", gpu.flip_mean, cpu.flip_mean, 1e-4),
    ] {
        // A NaN on either side is off too.
        let within = (g - c).abs() <= bound;
        if !within {
            return Err(format!(
                "{name} {g} on the GPU against {c} on the CPU (bound {bound:e})"
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The self-check can fail: each figure moved past its bound is named.
    #[test]
    fn agrees_names_the_first_figure_off_its_lock() {
        let (a, b) = (synthetic(20, 16, 1), synthetic(20, 16, 2));
        let (t, r) = (
            Raster::new(20, 16, 3, &a).unwrap(),
            Raster::new(20, 16, 3, &b).unwrap(),
        );
        let (cpu, _) = crate::metrics::compare_with_flip(t, r).unwrap();
        assert_eq!(agrees(&cpu, &cpu), Ok(()));
        let mut off = cpu.clone();
        off.mse = f64::from_bits(cpu.mse.to_bits() + 1);
        assert!(agrees(&off, &cpu).unwrap_err().starts_with("MSE"));
        let mut off = cpu.clone();
        off.ssim += 2e-6;
        assert!(agrees(&off, &cpu).unwrap_err().starts_with("SSIM"));
        let mut off = cpu.clone();
        off.ssim += 5e-7;
        off.flip_mean += 2e-4;
        assert!(agrees(&off, &cpu).unwrap_err().starts_with("FLIP"));
        let mut off = cpu.clone();
        off.flip_mean = f64::NAN;
        assert!(agrees(&off, &cpu).is_err());
    }
}

/// FLIP's time at one size on both sides (`tonegate bench --flip`): the
/// GPU's median over `runs` (after one warm-up: upload, passes, readback
/// of the map), nv-flip's over three, with both means, on two synthetic
/// frames of shared structure that differ everywhere; and every figure of
/// the pair on the GPU in one submission (`gpu_all_ms`, what `check
/// --metrics gpu` runs per frame) against the CPU's (`cpu_all_ms`).
#[derive(Clone, Debug, serde::Serialize)]
pub struct FlipTiming {
    pub size: String,
    pub gpu_ms: f64,
    pub cpu_ms: f64,
    pub gpu_mean: f64,
    pub cpu_mean: f64,
    pub gpu_all_ms: f64,
    pub cpu_all_ms: f64,
    pub runs: u32,
}

pub fn time_flip(
    ctx: &GpuContext,
    width: u32,
    height: u32,
    runs: u32,
) -> Result<FlipTiming, MetricsError> {
    let (a, b) = (synthetic(width, height, 1), synthetic(width, height, 2));
    let (ta, tb) = (
        Raster::new(width, height, 3, &a)?,
        Raster::new(width, height, 3, &b)?,
    );
    let runs = runs.max(1);
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    // Milliseconds of each of `n` calls of `f`, after one untimed call.
    let time = |n: u32, f: &dyn Fn() -> Result<f64, MetricsError>| {
        f()?;
        (0..n)
            .map(|_| {
                let t = std::time::Instant::now();
                f().map(|_| t.elapsed().as_secs_f64() * 1e3)
            })
            .collect::<Result<Vec<f64>, MetricsError>>()
            .map(median)
    };
    let flip = GpuFlip::new(ctx);
    let all = GpuCompare::new(ctx);
    let gpu_mean = flip.flip(ta, tb, DEFAULT_PPD)?.mean();
    let cpu_mean = crate::metrics::flip::flip(ta, tb, DEFAULT_PPD)?.mean();
    Ok(FlipTiming {
        size: format!("{width}x{height}"),
        gpu_ms: time(runs, &|| flip.flip(ta, tb, DEFAULT_PPD).map(|_| 0.0))?,
        cpu_ms: time(3, &|| {
            crate::metrics::flip::flip(ta, tb, DEFAULT_PPD).map(|_| 0.0)
        })?,
        gpu_mean,
        cpu_mean,
        gpu_all_ms: time(runs, &|| all.compare(ta, tb).map(|_| 0.0))?,
        cpu_all_ms: time(3, &|| {
            crate::metrics::compare_with_flip(ta, tb).map(|_| 0.0)
        })?,
        runs,
    })
}
