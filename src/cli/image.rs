//! The commands on single images and scenes: `tonemap`, `compare`, `plan`,
//! `render` and `env` (`bench` is in `bench.rs`).

use super::progress::Bar;
use super::{invalid, write_json, GpuArgs};
use clap::Args;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use tonegate::error::{Error, Result};
use tonegate::golden::frame_file;
use tonegate::gpu::GpuContext;
use tonegate::metrics::hdr_flip::ToneMapper;
use tonegate::progress::Progress;
use tonegate::render::{scene_environment, FrameDetail, SceneRenderer};
use tonegate::scene::{Scene, Size, MAX_SPP};
use tonegate::toning::{OutputKind, ToneSettings};

#[derive(Args)]
pub struct TonemapArgs {
    /// Input HDR image.
    pub input: PathBuf,
    /// Output: .png (8-bit encoded), .exr / .pfm / .hdr (linear, before encoding).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Tone-map on the GPU instead of the CPU reference.
    #[arg(long)]
    pub gpu: bool,
    #[command(flatten)]
    pub gpu_options: GpuArgs,
    #[command(flatten)]
    pub settings: ToneSettings,
    /// Set NaN and ±Inf input values to 0 (and count them) instead of refusing the file.
    #[arg(long)]
    pub sanitize: bool,
    /// Largest accepted input, in pixels.
    #[arg(long, default_value_t = tonegate::io::LoadOptions::default().max_pixels)]
    pub max_pixels: u64,
    /// Print a JSON report (load report, plan, statistics, parameters) on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Two images of one kind: two 8-bit PNGs (LDR metrics) or two linear HDR
/// files, .exr / .hdr / .pfm (HDR metrics). Name them as FLIP's tool does,
/// `-r REFERENCE -t TEST`, or by position, test first: `compare TEST REFERENCE`.
#[derive(Args)]
pub struct CompareArgs {
    /// The image under test (positional form: the first image).
    #[arg(value_name = "TEST")]
    pub test_at: Option<PathBuf>,
    /// The reference (positional form: the second image).
    #[arg(value_name = "REFERENCE")]
    pub reference_at: Option<PathBuf>,
    /// The reference image (FLIP's -r): HDR-FLIP's exposures come from it.
    #[arg(short = 'r', long)]
    pub reference: Option<PathBuf>,
    /// The image under test (FLIP's -t).
    #[arg(short = 't', long)]
    pub test: Option<PathBuf>,
    /// Write the per-pixel SSIM map as a greyscale PNG (PU21-SSIM's for HDR inputs).
    #[arg(long)]
    pub ssim_map: Option<PathBuf>,
    /// Write a heat map of the absolute differences (8-bit inputs).
    #[arg(long)]
    pub diff: Option<PathBuf>,
    /// Write the FLIP error map (HDR-FLIP's for HDR inputs), magma-coloured.
    #[arg(long)]
    pub flip_map: Option<PathBuf>,
    /// FLIP's pixels per degree (default: a 0.7 m wide 4K display at 0.7 m, 67.02).
    #[arg(long)]
    pub ppd: Option<f64>,
    /// HDR inputs: the display peak in cd/m² that 1.0 maps to (PU21, delta E ITP).
    #[arg(long, default_value_t = tonegate::metrics::pu21::DEFAULT_PEAK)]
    pub peak: f64,
    /// HDR-FLIP's tone mapper: aces, hable or reinhard.
    #[arg(long, default_value = "aces", value_parser = super::by_name::<ToneMapper>)]
    pub tone_mapper: ToneMapper,
    /// HDR-FLIP's first exposure in stops (default: from the reference's maximum).
    #[arg(long, allow_hyphen_values = true)]
    pub start_exposure: Option<f64>,
    /// HDR-FLIP's last exposure in stops (default: from the reference's median).
    #[arg(long, allow_hyphen_values = true)]
    pub stop_exposure: Option<f64>,
    /// HDR-FLIP's number of exposures (default: one a stop, at least 2).
    #[arg(long)]
    pub exposures: Option<u32>,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct PlanArgs {
    pub scene: PathBuf,
    /// Samples per pixel of the sphere stage.
    #[arg(long, default_value_t = 1)]
    pub spp: u32,
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct RenderArgs {
    pub scene: PathBuf,
    /// Output directory for NNN.png frames and frames.json.
    #[arg(long)]
    pub out: PathBuf,
    /// Samples per pixel (GPU default 1; CPU default the scene's reference_spp).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Render with the CPU reference instead of the GPU.
    #[arg(long)]
    pub cpu: bool,
    #[command(flatten)]
    pub gpu: GpuArgs,
}

#[derive(Args)]
pub struct EnvArgs {
    /// sky, interior, night, grid or colours.
    pub name: Option<String>,
    #[arg(long, default_value = "1024x512")]
    pub size: Size,
    /// Output file (.exr, .pfm, .hdr).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// List the built-in environments.
    #[arg(long)]
    pub list: bool,
}

pub fn tonemap(a: TonemapArgs) -> Result<ExitCode> {
    let resolved = a.settings.resolve()?;
    let opts = tonegate::io::LoadOptions {
        sanitize: a.sanitize,
        max_pixels: a.max_pixels,
        device: None,
    };
    let (img, load_report) = tonegate::io::load_hdr(&a.input, &opts)?;
    let ctx = if a.gpu {
        Some(GpuContext::new(&a.gpu_options.adapter())?)
    } else {
        None
    };
    let want = resolved.output_kind(OutputKind::of_path(&a.output)?)?;
    let toned = tonegate::toning::tone_map(
        &img,
        &resolved.pipeline(),
        ctx.as_ref().map(|c| (c, a.gpu_options.config())),
        want,
    )?;
    toned.image.write(&a.output)?;
    let report = toned.report;
    if a.json {
        #[derive(serde::Serialize)]
        struct Written<'r> {
            output: &'r Path,
            #[serde(flatten)]
            report: tonegate::toning::FileReport<'r>,
        }
        let written = Written {
            output: &a.output,
            report: tonegate::toning::FileReport {
                input: &load_report,
                toned: &report,
            },
        };
        write_json(Path::new("-"), "the tone-map report", &written)?;
    } else {
        eprintln!(
            "{}: {}x{}, Y {:.4e} .. {:.4e} ({:.1} stops), {}{} -> {}",
            a.input.display(),
            load_report.width,
            load_report.height,
            load_report.min_luminance,
            load_report.max_luminance,
            load_report.dynamic_range_stops,
            report.tone.operator,
            report
                .tone
                .values
                .iter()
                .map(|(n, v)| format!(", {n} {v:.4e}"))
                .collect::<String>(),
            a.output.display()
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// What `compare --json` prints for two 8-bit images: the metrics, and
/// FLIP's pooled statistics at the chosen viewing distance.
#[derive(serde::Serialize)]
struct LdrComparison<'p> {
    /// Which file was which, as the command understood its arguments.
    test: &'p Path,
    reference: &'p Path,
    #[serde(flatten)]
    metrics: tonegate::metrics::Metrics,
    flip: tonegate::metrics::flip::FlipStats,
    flip_definition: String,
}

fn is_png(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("png"))
}

impl CompareArgs {
    /// (test, reference), from the flags or the positions: a reference
    /// given by flag with one image by position makes that image the test.
    fn pair(&self) -> Result<(PathBuf, PathBuf)> {
        let mut positional = [&self.test_at, &self.reference_at]
            .into_iter()
            .flatten()
            .cloned();
        let test = self.test.clone().or_else(|| positional.next());
        let reference = self.reference.clone().or_else(|| positional.next());
        let extra = positional.next();
        match (test, reference, extra) {
            (Some(t), Some(r), None) => Ok((t, r)),
            (_, _, Some(extra)) => Err(invalid(format!(
                "{} is one image too many: give the test and the reference once each",
                extra.display()
            ))),
            _ => Err(invalid(
                "compare needs two images: -t TEST -r REFERENCE, or TEST REFERENCE by position",
            )),
        }
    }
}

pub fn compare(a: CompareArgs) -> Result<ExitCode> {
    let (test, reference) = a.pair()?;
    match (is_png(&test), is_png(&reference)) {
        (true, true) => compare_ldr(&a, &test, &reference),
        (false, false) => compare_hdr(&a, &test, &reference),
        _ => Err(invalid(format!(
            "{} and {} are not of one kind: compare two frame PNGs (8-bit, or 16-bit PQ) or two linear HDR files (.exr, .hdr, .pfm)",
            test.display(),
            reference.display()
        ))),
    }
}

fn compare_ldr(a: &CompareArgs, test: &Path, reference: &Path) -> Result<ExitCode> {
    use tonegate::image::Frame;
    use tonegate::metrics::{compare_frames, frame_diff_heatmap, frame_ssim};
    // 8-bit frames, or 16-bit PQ ones (a PQ scene's goldens and artifacts).
    let frame_a = tonegate::io::read_frame_png(test)?;
    let frame_b = tonegate::io::read_frame_png(reference)?;
    let (mut m, default_flip) = compare_frames(&frame_a, &frame_b)?;
    let mut flip_definition = tonegate::metrics::FLIP_DEFINITION.to_owned();
    let flip = match (a.ppd, &frame_a, &frame_b) {
        (None, ..) => default_flip,
        (Some(ppd), Frame::Rgb8(x), Frame::Rgb8(y)) => {
            // Every figure that says FLIP is at the asked distance: the
            // metrics' flip_mean and the definition too, not only the map.
            let flip = tonegate::metrics::flip::flip(x.raster(), y.raster(), ppd)?;
            m.flip_mean = flip.mean();
            flip_definition = flip_definition.replace(
                "at 67.02 pixels per degree (a 0.7 m wide 4K display seen from 0.7 m)",
                &format!("at {ppd} pixels per degree (compare --ppd)"),
            );
            flip
        }
        (Some(_), ..) => {
            return Err(invalid(
                "--ppd sets LDR FLIP's viewing distance; 16-bit PQ frames are compared with HDR-FLIP at its default",
            ))
        }
    };
    if let Some(path) = &a.ssim_map {
        let s = frame_ssim(&frame_a, &frame_b)?;
        tonegate::io::write_png8(path, &tonegate::metrics::ssim_map_image(&s))?;
    }
    if let Some(path) = &a.diff {
        tonegate::io::write_png8(path, &frame_diff_heatmap(&frame_a, &frame_b)?)?;
    }
    if let Some(path) = &a.flip_map {
        tonegate::io::write_png8(path, &flip.magma_image())?;
    }
    let stats = flip.stats();
    if a.json {
        let report = LdrComparison {
            test,
            reference,
            metrics: m,
            flip: stats,
            flip_definition,
        };
        write_json(Path::new("-"), "the metrics", &report)?;
    } else {
        println!("{m}");
        println!(
            "FLIP at {:.2} ppd: mean {:.5}, median {:.5}, max {:.5}, weighted quartiles {:.5} / {:.5} / {:.5}",
            stats.ppd,
            stats.mean,
            stats.median,
            stats.max,
            stats.weighted_quartiles[0],
            stats.weighted_quartiles[1],
            stats.weighted_quartiles[2]
        );
    }
    Ok(ExitCode::SUCCESS)
}

fn compare_hdr(a: &CompareArgs, test: &Path, reference: &Path) -> Result<ExitCode> {
    use tonegate::metrics::hdr::{compare_hdr, HdrOptions};
    use tonegate::metrics::hdr_flip::HdrFlipOptions;
    if a.diff.is_some() {
        return Err(invalid(
            "--diff is the 8-bit difference heat map; for HDR inputs use --flip-map or --ssim-map",
        ));
    }
    let load = tonegate::io::LoadOptions::default();
    let (img_a, _) = tonegate::io::load_hdr(test, &load)?;
    let (img_b, _) = tonegate::io::load_hdr(reference, &load)?;
    let opts = HdrOptions {
        peak: a.peak,
        flip: HdrFlipOptions {
            ppd: a.ppd.unwrap_or(tonegate::metrics::flip::DEFAULT_PPD),
            tone_mapper: a.tone_mapper,
            start: a.start_exposure,
            stop: a.stop_exposure,
            exposures: a.exposures,
        },
    };
    let c = compare_hdr(&img_a, &img_b, &opts)?;
    if let Some(path) = &a.flip_map {
        tonegate::io::write_png8(path, &c.flip.magma_image())?;
    }
    if let Some(path) = &a.ssim_map {
        tonegate::io::write_png8(path, &tonegate::metrics::ssim_map_image(&c.pu21.ssim))?;
    }
    let m = &c.metrics;
    if a.json {
        #[derive(serde::Serialize)]
        struct HdrComparison<'p> {
            test: &'p Path,
            reference: &'p Path,
            #[serde(flatten)]
            metrics: &'p tonegate::metrics::hdr::HdrMetrics,
        }
        let report = HdrComparison {
            test,
            reference,
            metrics: m,
        };
        write_json(Path::new("-"), "the HDR metrics", &report)?;
    } else {
        println!(
            "PU21-PSNR {:.4} dB  PU21-SSIM {:.6}  delta E ITP mean {:.4} max {:.4}  (1.0 = {} cd/m2)",
            m.pu21_psnr, m.pu21_ssim, m.delta_e_itp_mean, m.delta_e_itp_max, m.peak
        );
        let r = &m.hdr_flip_exposures;
        println!(
            "HDR-FLIP mean {:.5}, median {:.5}, max {:.5} over {} exposures {:.3} .. {:.3} stops ({:?})",
            m.hdr_flip.mean, m.hdr_flip.median, m.hdr_flip.max, r.count, r.start, r.stop, r.tone_mapper
        );
    }
    Ok(ExitCode::SUCCESS)
}

pub fn plan(a: PlanArgs) -> Result<ExitCode> {
    let scene = Scene::load(&a.scene)?;
    let plan = tonegate::plan::StagePlan::for_scene(&scene, a.spp);
    if a.json {
        write_json(Path::new("-"), "the plan", &plan)?;
    } else {
        println!("{} ({} frames, {}):", scene.name, scene.frames, scene.size);
        print!("{plan}");
    }
    Ok(ExitCode::SUCCESS)
}

pub fn render(a: RenderArgs) -> Result<ExitCode> {
    let scene = Scene::load(&a.scene)?;
    let spp = a.spp.unwrap_or(if a.cpu { scene.reference_spp } else { 1 });
    if spp == 0 || spp > MAX_SPP {
        return Err(invalid(format!(
            "--spp: must be between 1 and {MAX_SPP}, got {spp}"
        )));
    }
    let env = scene_environment(&scene)?;
    std::fs::create_dir_all(&a.out).map_err(|source| Error::File {
        path: a.out.clone(),
        source,
    })?;
    let ctx = if a.cpu {
        None
    } else {
        Some(GpuContext::new(&a.gpu.adapter())?)
    };
    let renderer = match &ctx {
        None => SceneRenderer::cpu(&scene, &env, spp),
        Some(ctx) => SceneRenderer::gpu(&scene, &env, ctx, a.gpu.config(), spp)?,
    };
    let bar = Bar::new();
    bar.start("render", scene.frames as u64, "frames");
    let mut frames = Vec::new();
    // Frames in flight on the GPU: frame n's PNG is written while n+1 renders.
    renderer.each_frame(|out| -> Result<()> {
        let n = out.index;
        tonegate::io::write_frame_png(&a.out.join(frame_file(n)), &out.image)?;
        frames.push(match &out.detail {
            FrameDetail::Cpu(s) => serde_json::json!({
                "frame": n, "file": frame_file(n), "wall_ms": out.wall_ms,
                "stats": s.stats, "tone": s.tone,
            }),
            FrameDetail::Gpu { stats, timings } => serde_json::json!({
                "frame": n, "file": frame_file(n), "wall_ms": out.wall_ms,
                "stats": stats, "timings": timings,
            }),
        });
        bar.advance(1);
        Ok(())
    })?;
    bar.finish();
    // The GPU configuration in effect (after any f16 promotion or staged
    // fallback) and why it differs from the one asked for.
    let gpu = renderer.gpu_renderer();
    let renderer_name = match &ctx {
        Some(ctx) => ctx.adapter.name.clone(),
        None => tonegate::render::CPU_REFERENCE.to_owned(),
    };
    let report = serde_json::json!({
        "scene": scene.name, "renderer": renderer_name,
        "adapter": ctx.as_ref().map(|c| &c.adapter), "spp": spp,
        "plan": renderer.plan().names(), "gpu_config": gpu.map(|r| r.config),
        "notes": gpu.map(|r| r.notes.clone()).unwrap_or_default(), "frames": frames,
    });
    write_json(&a.out.join("frames.json"), "frames.json", &report)?;
    println!(
        "{} frames of {} rendered on {renderer_name}, written to {}",
        scene.frames,
        scene.name,
        a.out.display()
    );
    Ok(ExitCode::SUCCESS)
}

#[derive(Args)]
pub struct OperatorsArgs {
    /// Print them as JSON (what GET /api/v1/operators answers).
    #[arg(long)]
    pub json: bool,
}

pub fn operators(a: OperatorsArgs) -> Result<ExitCode> {
    let all = tonegate::operators::describe();
    if a.json {
        write_json(Path::new("-"), "the operators", &all)?;
        return Ok(ExitCode::SUCCESS);
    }
    for o in all {
        let aliases = if o.aliases.is_empty() {
            String::new()
        } else {
            format!(" (also {})", o.aliases.join(", "))
        };
        let hdr = if o.hdr_output {
            "; --display pq|hlg too"
        } else {
            ""
        };
        println!("{}{aliases}: {}{hdr}", o.name, o.summary);
        for p in o.params {
            let default = match p.default {
                tonegate::operators::Value::Unset => "measured".to_owned(),
                v => v.to_string(),
            };
            println!(
                "  --{:<18} {} (default {default}; {})",
                p.name.replace('_', "-"),
                p.doc,
                p.expected
            );
        }
    }
    Ok(ExitCode::SUCCESS)
}

pub fn env(a: EnvArgs) -> Result<ExitCode> {
    use tonegate::env::BuiltinEnv;
    if a.list || a.name.is_none() {
        for e in BuiltinEnv::ALL {
            println!("{:<9} {}", e.name(), e.description());
        }
        return Ok(ExitCode::SUCCESS);
    }
    let name = a.name.unwrap_or_default();
    let env = BuiltinEnv::from_name(&name).ok_or_else(|| {
        invalid(format!(
            "unknown environment {name:?}; built-in: sky, interior, night, grid, colours"
        ))
    })?;
    let output = a
        .output
        .ok_or_else(|| invalid("-o/--output is required to export an environment"))?;
    let img = env.generate(a.size.width, a.size.height);
    tonegate::io::write_image_hdr(&output, &img)?;
    println!("{name} {} -> {}", a.size, output.display());
    Ok(ExitCode::SUCCESS)
}
