//! FLIP on the GPU: the LDR pipeline of FLIP 1.2 (NVIDIA's C++, which
//! `metrics::flip` runs through nv-flip) as three compute passes
//! (`shaders/flip.wgsl`), giving the same per-pixel map in f32 and so the
//! same pooled figures (mean, weighted percentiles) computed on the host.
//! The filter weights and the colour difference's maximum are computed here
//! as FLIP's C++ computes them, in f32.
//!
//! Locked to nv-flip (`tests/it/gpu_metrics.rs`): the mean of the map
//! within 1e-4. Each pixel goes through a few hundred f32 operations in a
//! different order (the shader's exp, pow and sqrt are the adapter's), so
//! the maps differ in their last bits, not in their figures.

use crate::gpu::stages::{pipeline, read_buffer};
use crate::gpu::{GpuContext, GpuError, HdrFormat};
use crate::image::Image;
use crate::metrics::flip::Flip;
use crate::metrics::{MetricsError, Raster};

/// FLIP's constants (its sharedflip.h): the colour difference's exponent
/// and the remap's knee, and the feature filter's width in degrees.
const QC: f32 = 0.7;
const PC: f32 = 0.4;
const W: f32 = 0.082;
/// The spatial filters' Gaussians (FLIP's `GaussianConstants`): for Y and
/// Cx one each (a1, b1), for Cz the sum of two (a1, b1) + (a2, b2).
const A1: [f32; 3] = [1.0, 1.0, 34.1];
const B1: [f32; 3] = [0.0047, 0.0053, 0.04];
const A2_CZ: f32 = 13.5;
const B2: [f32; 3] = [1.0e-5, 1.0e-5, 0.025];
/// FLIP's π (3.14159265358979 in its C++), which is f32's π once rounded.
const PI: f32 = std::f32::consts::PI;

/// The three passes' pipelines, compiled once per device.
pub struct GpuFlip<'c> {
    ctx: &'c GpuContext,
    ycxcz: wgpu::ComputePipeline,
    horizontal: wgpu::ComputePipeline,
    vertical: wgpu::ComputePipeline,
}

impl<'c> GpuFlip<'c> {
    pub fn new(ctx: &'c GpuContext) -> GpuFlip<'c> {
        let p = |entry| pipeline(ctx, "flip", entry, HdrFormat::Rgba32Float, &[]);
        GpuFlip {
            ctx,
            ycxcz: p("ycxcz"),
            horizontal: p("horizontal"),
            vertical: p("vertical"),
        }
    }

    /// The FLIP map of `test` against `reference` at `ppd` pixels per
    /// degree: what `metrics::flip::flip` gives, computed on the device.
    pub fn flip(&self, test: Raster, reference: Raster, ppd: f64) -> Result<Flip, MetricsError> {
        crate::metrics::raster::check_pair(&test, &reference)?;
        if !(ppd.is_finite() && ppd > 0.0) {
            return Err(MetricsError::BadParameter {
                name: "ppd",
                detail: format!("pixels per degree must be a finite number > 0, got {ppd}"),
            });
        }
        self.map(test, reference, ppd as f32)
            .map_err(|e| MetricsError::Device {
                metric: "FLIP",
                detail: e.to_string(),
            })
    }

    fn map(&self, test: Raster, reference: Raster, ppd: f32) -> Result<Flip, GpuError> {
        let (width, height) = (test.width, test.height);
        self.ctx.check_frame(width, height)?;
        let input_test = upload(self.ctx, &test, "tonegate.flip.test");
        let input_ref = upload(self.ctx, &reference, "tonegate.flip.reference");
        let mut encoder = self
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("tonegate.flip"),
            });
        let read = self.record(&mut encoder, &input_test, &input_ref, (width, height), ppd);
        self.ctx.queue.submit([encoder.finish()]);
        read_map(self.ctx, &read, (width, height), ppd)
    }

    /// Records the three passes over two uploaded images ([`upload`]) of
    /// `size`, and the map's copy into the mapped-readable buffer returned.
    pub(in crate::gpu) fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        input_test: &wgpu::Buffer,
        input_ref: &wgpu::Buffer,
        size: (u32, u32),
        ppd: f32,
    ) -> wgpu::Buffer {
        let (width, height) = size;
        let ctx = self.ctx;
        let n = width as u64 * height as u64;
        let filters = Filters::new(ppd);
        let (cmax, pccmax) = colour_maximum();
        let mut params = Vec::with_capacity(32);
        for v in [
            width,
            height,
            filters.spatial_radius,
            filters.feature_radius,
        ] {
            params.extend_from_slice(&v.to_le_bytes());
        }
        for v in [cmax, pccmax, 0.0, 0.0] {
            params.extend_from_slice(&v.to_le_bytes());
        }
        let init = |label: &str, contents: &[u8], usage: wgpu::BufferUsages| {
            crate::gpu::stages::buffer_with(ctx, label, contents, usage)
        };
        let storage = wgpu::BufferUsages::STORAGE;
        let params = init("tonegate.flip.params", &params, wgpu::BufferUsages::UNIFORM);
        let weights = init(
            "tonegate.flip.weights",
            bytemuck::cast_slice(&filters.weights),
            storage,
        );
        let scratch = |label: &str, bytes_per_pixel: u64, extra: wgpu::BufferUsages| {
            ctx.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: (n * bytes_per_pixel).max(16),
                usage: storage | extra,
                mapped_at_creation: false,
            })
        };
        let none = wgpu::BufferUsages::empty();
        let ycxcz_ref = scratch("tonegate.flip.ycxcz_ref", 16, none);
        let ycxcz_test = scratch("tonegate.flip.ycxcz_test", 16, none);
        let colour_ref = scratch("tonegate.flip.colour_ref", 16, none);
        let colour_test = scratch("tonegate.flip.colour_test", 16, none);
        let feature_ref = scratch("tonegate.flip.feature_ref", 16, none);
        let feature_test = scratch("tonegate.flip.feature_test", 16, none);
        let map = scratch("tonegate.flip.map", 4, wgpu::BufferUsages::COPY_SRC);
        let read = read_buffer(ctx, "tonegate.flip.map.read", (n * 4).max(16));
        let bind = |pipeline: &wgpu::ComputePipeline, entries: &[(u32, &wgpu::Buffer)]| {
            crate::gpu::stages::bind_buffers(ctx, "tonegate.flip", pipeline, entries)
        };
        let passes = [
            (
                &self.ycxcz,
                bind(
                    &self.ycxcz,
                    &[
                        (0, &params),
                        (1, input_ref),
                        (2, input_test),
                        (3, &ycxcz_ref),
                        (4, &ycxcz_test),
                    ],
                ),
            ),
            (
                &self.horizontal,
                bind(
                    &self.horizontal,
                    &[
                        (0, &params),
                        (3, &ycxcz_ref),
                        (4, &ycxcz_test),
                        (5, &weights),
                        (6, &colour_ref),
                        (7, &colour_test),
                        (8, &feature_ref),
                        (9, &feature_test),
                    ],
                ),
            ),
            (
                &self.vertical,
                bind(
                    &self.vertical,
                    &[
                        (0, &params),
                        (5, &weights),
                        (6, &colour_ref),
                        (7, &colour_test),
                        (8, &feature_ref),
                        (9, &feature_test),
                        (10, &map),
                    ],
                ),
            ),
        ];
        for (pipeline, group) in &passes {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("tonegate.flip"),
                timestamp_writes: None,
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, group, &[]);
            pass.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), 1);
        }
        encoder.copy_buffer_to_buffer(&map, 0, &read, 0, n * 4);
        read
    }
}

/// The map [`GpuFlip::record`] copied into `read`, once its submission is
/// done.
pub(in crate::gpu) fn read_map(
    ctx: &GpuContext,
    read: &wgpu::Buffer,
    size: (u32, u32),
    ppd: f32,
) -> Result<Flip, GpuError> {
    let (width, height) = size;
    let n = width as usize * height as usize;
    let pixels: Vec<f32> = ctx.with_mapped(read, |bytes| {
        bytes[..n * 4]
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect()
    })?;
    Ok(Flip {
        map: Image {
            width,
            height,
            pixels,
        },
        ppd: f64::from(ppd),
    })
}

/// An image's pixels in a storage buffer, packed as the shaders read them.
pub(in crate::gpu) fn upload(ctx: &GpuContext, image: &Raster, label: &str) -> wgpu::Buffer {
    crate::gpu::stages::buffer_with(ctx, label, &packed(image), wgpu::BufferUsages::STORAGE)
}

/// The pixels packed as r | g << 8 | b << 16 (grey replicated, alpha
/// dropped).
fn packed(r: &Raster) -> Vec<u8> {
    let pack = |p: &[u8]| match p.len() {
        1 => u32::from(p[0]) * 0x0001_0101,
        _ => u32::from(p[0]) | u32::from(p[1]) << 8 | u32::from(p[2]) << 16,
    };
    r.samples
        .chunks_exact(r.channels)
        .flat_map(|p| pack(p).to_le_bytes())
        .collect()
}

/// FLIP's separated filters at `ppd`: the spatial filters' taps
/// (Y, Cx, and the square roots of Cz's two Gaussians, the latter two
/// normalised together), then the feature filter's (Gaussian, 1st and 2nd
/// derivative, each normalised as FLIP's `setFeatureFilter` does).
struct Filters {
    spatial_radius: u32,
    feature_radius: u32,
    weights: Vec<[f32; 4]>,
}

impl Filters {
    fn new(ppd: f32) -> Filters {
        let pi_sq = PI * PI;
        let delta = 1.0 / ppd;
        let max_b = B1.into_iter().chain(B2).fold(0.0f32, f32::max);
        let spatial_radius = (3.0 * (max_b / (2.0 * pi_sq)).sqrt() * ppd).ceil() as i32;
        let gaussian = |x2: f32, a: f32, b: f32| a * (PI / b).sqrt() * (-pi_sq * x2 / b).exp();
        let gaussian_sqrt =
            |x2: f32, a: f32, b: f32| (a * (PI / b).sqrt()).sqrt() * (-pi_sq * x2 / b).exp();
        let mut spatial: Vec<[f32; 4]> = (-spatial_radius..=spatial_radius)
            .map(|x| {
                let ix = x as f32 * delta;
                let ix2 = ix * ix;
                [
                    gaussian(ix2, A1[0], B1[0]),
                    gaussian(ix2, A1[1], B1[1]),
                    gaussian_sqrt(ix2, A1[2], B1[2]),
                    gaussian_sqrt(ix2, A2_CZ, B2[2]),
                ]
            })
            .collect();
        let sum = |i: usize| spatial.iter().fold(0.0f32, |s, w| s + w[i]);
        let (sy, scx, scz1, scz2) = (sum(0), sum(1), sum(2), sum(3));
        let norm_cz = 1.0 / (scz1 * scz1 + scz2 * scz2).sqrt();
        for w in &mut spatial {
            *w = [
                w[0] * (1.0 / sy),
                w[1] * (1.0 / scx),
                w[2] * norm_cz,
                w[3] * norm_cz,
            ];
        }
        let sd = 0.5 * W * ppd;
        let feature_radius = (3.0 * sd).ceil() as i32;
        let mut feature: Vec<[f32; 4]> = (-feature_radius..=feature_radius)
            .map(|x| {
                let x = x as f32;
                let g = (-(x * x) / (2.0 * sd * sd)).exp();
                [g, -x * g, (x * x / (sd * sd) - 1.0) * g, 0.0]
            })
            .collect();
        let g_sum = feature.iter().fold(0.0f32, |s, w| s + w[0]);
        let signed = |i: usize, positive: bool| {
            feature
                .iter()
                .fold(0.0f32, |s, w| match (w[i] > 0.0, positive) {
                    (true, true) => s + w[i],
                    (false, false) => s - w[i],
                    _ => s,
                })
        };
        let (dg_pos, dg_neg) = (signed(1, true), signed(1, false));
        let (ddg_pos, ddg_neg) = (signed(2, true), signed(2, false));
        for w in &mut feature {
            *w = [
                w[0] / g_sum,
                w[1] / if w[1] > 0.0 { dg_pos } else { dg_neg },
                w[2] / if w[2] > 0.0 { ddg_pos } else { ddg_neg },
                0.0,
            ];
        }
        Filters {
            spatial_radius: spatial_radius as u32,
            feature_radius: feature_radius as u32,
            weights: spatial.into_iter().chain(feature).collect(),
        }
    }
}

/// FLIP's largest colour difference, green against blue after the Hunt
/// adjustment, compressed by its exponent, and the remap's knee (its
/// `computeMaxDistance`, times 0.4).
fn colour_maximum() -> (f32, f32) {
    let lab = |rgb: [f32; 3]| {
        let m = [
            [
                10135552.0 / 24577794.0,
                8788810.0 / 24577794.0,
                4435075.0 / 24577794.0,
            ],
            [
                2613072.0 / 12288897.0,
                8788810.0 / 12288897.0,
                887015.0 / 12288897.0,
            ],
            [
                1425312.0 / 73733382.0,
                8788810.0 / 73733382.0,
                70074185.0 / 73733382.0,
            ],
        ];
        let inv = [1.052_156_9_f32, 1.0, 0.918_357_7];
        let xyz: [f32; 3] = std::array::from_fn(|i| {
            (m[i][0] * rgb[0] + m[i][1] * rgb[1] + m[i][2] * rgb[2]) * inv[i]
        });
        let delta = 6.0f32 / 29.0;
        let f = |t: f32| {
            if t > delta * delta * delta {
                t.powf(1.0 / 3.0)
            } else {
                t * (1.0 / (3.0 * delta * delta)) + 4.0 / 29.0
            }
        };
        let (fx, fy, fz) = (f(xyz[0]), f(xyz[1]), f(xyz[2]));
        let l = 116.0 * fy - 16.0;
        [
            l,
            0.01 * l * (500.0 * (fx - fy)),
            0.01 * l * (200.0 * (fy - fz)),
        ]
    };
    let (g, b) = (lab([0.0, 1.0, 0.0]), lab([0.0, 0.0, 1.0]));
    let hyab = (g[0] - b[0]).abs() + ((g[1] - b[1]).powi(2) + (g[2] - b[2]).powi(2)).sqrt();
    let cmax = hyab.powf(QC);
    (cmax, PC * cmax)
}
