//! The command line: argument definitions and the commands that call the library.
//!
//! Exit codes: 0 success, 1 a check or verification failed, 2 the run could
//! not happen (bad arguments, unreadable files, missing goldens).

use crate::error::{Error, Result};
use crate::scene::{Scene, Size};
use crate::toning::ToneSettings;
use clap::{Args, Parser, Subcommand};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

mod gate;
mod serve;

#[derive(Parser)]
#[command(
    name = "tonegate",
    version,
    about = "Headless regression and image-quality validation for a GPU HDR tone mapper"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand)]
pub enum Command {
    /// The CI gate: render the suite on the GPU, compare every frame with its golden,
    /// evaluate the checks, write artifacts/JUnit/JSON, record the run. Exit 0 pass, 1 fail, 2 could not run.
    #[command(alias = "suite")]
    Check(gate::CheckArgs),
    /// Print the run history, or one metric's trend per scene.
    History(gate::HistoryArgs),
    /// Sweep every knob that trades accuracy for speed; time and error per configuration, Pareto front.
    Tradeoff(gate::TradeoffArgs),
    /// Stiff and extreme inputs through both renderers: finiteness, error against f64, time.
    Stress(gate::StressArgs),
    /// Time every stage of the full plan on the GPU: per-stage table, floor ratio, FPS.
    Bench(BenchArgs),
    /// Tone-map one HDR image (.hdr, .exr, .pfm); output format from the extension.
    Tonemap(TonemapArgs),
    /// Compare two 8-bit images: MSE, RMSE, PSNR, SNR, SSIM, max abs diff.
    Compare(CompareArgs),
    /// Print the stage plan of a scene: the stages it needs and nothing else.
    Plan(PlanArgs),
    /// Render a scene's frames on the GPU (or --cpu) with per-frame statistics and timings.
    Render(RenderArgs),
    /// Bless or verify the golden images.
    #[command(subcommand)]
    Golden(GoldenCommand),
    /// Export a built-in HDR environment, or list them.
    Env(EnvArgs),
    /// Serve the HTTP API (/api/v1), Prometheus metrics (/metrics) and the dashboard (/).
    Serve(serve::ServeArgs),
}

/// The GPU knobs shared by every GPU command.
#[derive(Args, Clone)]
pub struct GpuArgs {
    /// Adapter: "default" (lavapipe/llvmpipe when present, else the first), "any", or a name substring.
    #[arg(long, default_value = "default")]
    pub adapter: crate::gpu::AdapterChoice,
    /// HDR intermediates: rgba32float (f32) or rgba16float (f16).
    #[arg(long, default_value = "rgba32float")]
    pub hdr_format: crate::gpu::HdrFormat,
    /// Luminance reduction: block (seed 001's block partials) or pingpong (seed 000's 2x2).
    #[arg(long, default_value = "block")]
    pub reduction: crate::gpu::ReductionMethod,
    /// Environment filtering in `sphere`: manual (the reference's bilinear) or hardware (the sampler).
    #[arg(long, default_value = "manual")]
    pub env_filter: crate::gpu::EnvFilter,
    /// Kernels: staged (one per stage, each timed and readable) or fused (tonemap+composite+encode and bright+downsample merged; fewer full-frame passes).
    #[arg(long, default_value = "staged")]
    pub execution: crate::gpu::Execution,
}

impl GpuArgs {
    pub fn config(&self) -> crate::gpu::GpuConfig {
        crate::gpu::GpuConfig {
            hdr_format: self.hdr_format,
            reduction: self.reduction,
            env_filter: self.env_filter,
            execution: self.execution,
            fault_gain: None,
        }
    }
}

#[derive(Args)]
pub struct BenchArgs {
    #[arg(long, default_value = "1920x1080")]
    pub size: Size,
    /// Measured frames (after the warm-up).
    #[arg(long, default_value_t = 60)]
    pub frames: u32,
    #[arg(long, default_value_t = 10)]
    pub warmup: u32,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub gpu: GpuArgs,
}

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
    #[arg(long, default_value_t = crate::io::LoadOptions::default().max_pixels)]
    pub max_pixels: u64,
    /// Print a JSON report (load report, plan, statistics, parameters) on stdout.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct CompareArgs {
    /// The image under test.
    pub a: PathBuf,
    /// The reference image.
    pub b: PathBuf,
    /// Write the per-pixel SSIM map as a greyscale PNG.
    #[arg(long)]
    pub ssim_map: Option<PathBuf>,
    /// Write a heat map of the absolute differences.
    #[arg(long)]
    pub diff: Option<PathBuf>,
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

#[derive(Subcommand)]
pub enum GoldenCommand {
    /// Re-render goldens with the CPU reference (all scenes, or the named ones).
    Bless {
        scenes: Vec<String>,
        #[arg(long, default_value = "golden/suite.toml")]
        suite: PathBuf,
    },
    /// Re-render and require bit-identical frames and an up-to-date manifest.
    Verify {
        scenes: Vec<String>,
        #[arg(long, default_value = "golden/suite.toml")]
        suite: PathBuf,
    },
}

#[derive(Args)]
pub struct EnvArgs {
    /// sky, interior, night or grid.
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

/// Parses the process arguments and runs the command.
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}

pub fn run(cli: Cli) -> Result<ExitCode> {
    match cli.command {
        Command::Check(a) => gate::check(a),
        Command::History(a) => gate::history(a),
        Command::Tradeoff(a) => gate::tradeoff(a),
        Command::Stress(a) => gate::stress(a),
        Command::Bench(a) => bench(a),
        Command::Tonemap(a) => tonemap(a),
        Command::Compare(a) => compare(a),
        Command::Plan(a) => plan(a),
        Command::Render(a) => render(a),
        Command::Golden(GoldenCommand::Bless { scenes, suite }) => golden_bless(&suite, &scenes),
        Command::Golden(GoldenCommand::Verify { scenes, suite }) => golden_verify(&suite, &scenes),
        Command::Env(a) => env(a),
        Command::Serve(a) => serve::serve(a),
    }
}

fn invalid(msg: impl Into<String>) -> Error {
    Error::Invalid(msg.into())
}

fn write_json(path: &Path, value: &impl serde::Serialize) -> Result<()> {
    let text = serde_json::to_string_pretty(value).map_err(|e| invalid(e.to_string()))?;
    if path == Path::new("-") {
        println!("{text}");
        Ok(())
    } else {
        std::fs::write(path, text).map_err(|source| Error::File {
            path: path.to_owned(),
            source,
        })
    }
}

fn tonemap(a: TonemapArgs) -> Result<ExitCode> {
    let resolved = a.settings.resolve()?;
    let opts = crate::io::LoadOptions {
        sanitize: a.sanitize,
        max_pixels: a.max_pixels,
    };
    let (img, load_report) = crate::io::load_hdr(&a.input, &opts)?;
    let ctx = if a.gpu {
        Some(crate::gpu::GpuContext::new(&a.gpu_options.adapter).map_err(gpu_error)?)
    } else {
        None
    };
    let ext = a
        .output
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    let out = crate::toning::tone_map(
        &img,
        &resolved.pipeline(),
        ctx.as_ref().map(|c| (c, a.gpu_options.config())),
        ext != "png",
    )?;
    let plan = &out.plan;
    match &out.display {
        Some(display) if ext != "png" => crate::io::write_image_hdr(&a.output, &display.to_hdr())?,
        _ => crate::io::write_png8(&a.output, &out.frame)?,
    }
    if a.json {
        let report = serde_json::json!({
            "input": load_report,
            "output": a.output,
            "renderer": if a.gpu { "gpu" } else { "cpu-reference" },
            "plan": plan.names(),
            "stats": out.stats,
            "tone": out.tone,
        });
        write_json(Path::new("-"), &report)?;
    } else {
        eprintln!(
            "{}: {}x{}, Y {:.4e} .. {:.4e} ({:.1} stops), key {:.4}, log-average {:.4e} -> {}",
            a.input.display(),
            load_report.width,
            load_report.height,
            load_report.min_luminance,
            load_report.max_luminance,
            load_report.dynamic_range_stops,
            out.tone.key,
            out.tone.log_average,
            a.output.display()
        );
    }
    Ok(ExitCode::SUCCESS)
}

fn gpu_error(e: crate::gpu::GpuError) -> Error {
    invalid(e.to_string())
}

fn bench(a: BenchArgs) -> Result<ExitCode> {
    let ctx = crate::gpu::GpuContext::new(&a.gpu.adapter).map_err(gpu_error)?;
    if a.frames == 0 {
        return Err(invalid("--frames must be at least 1"));
    }
    let opts = crate::gpu::bench::BenchOptions {
        width: a.size.width,
        height: a.size.height,
        frames: a.frames,
        warmup: a.warmup,
        config: a.gpu.config(),
    };
    let report = crate::gpu::bench::run(&ctx, &opts).map_err(gpu_error)?;
    if a.json {
        write_json(Path::new("-"), &report)?;
    } else {
        println!("{report}");
    }
    Ok(ExitCode::SUCCESS)
}

fn compare(a: CompareArgs) -> Result<ExitCode> {
    let img_a = crate::io::read_png8(&a.a)?;
    let img_b = crate::io::read_png8(&a.b)?;
    let m = crate::metrics::compare(img_a.raster(), img_b.raster())?;
    if let Some(path) = &a.ssim_map {
        let s = crate::metrics::ssim(img_a.raster(), img_b.raster())?;
        crate::io::write_png8(path, &crate::metrics::ssim_map_image(&s))?;
    }
    if let Some(path) = &a.diff {
        crate::io::write_png8(
            path,
            &crate::metrics::diff_heatmap(img_a.raster(), img_b.raster())?,
        )?;
    }
    if a.json {
        write_json(Path::new("-"), &m)?;
    } else {
        println!("{m}");
    }
    Ok(ExitCode::SUCCESS)
}

fn plan(a: PlanArgs) -> Result<ExitCode> {
    let scene = Scene::load(&a.scene).map_err(|e| invalid(e.to_string()))?;
    let plan = crate::plan::StagePlan::for_scene(&scene, a.spp);
    if a.json {
        write_json(Path::new("-"), &plan)?;
    } else {
        println!("{} ({} frames, {}):", scene.name, scene.frames, scene.size);
        print!("{plan}");
    }
    Ok(ExitCode::SUCCESS)
}

fn render(a: RenderArgs) -> Result<ExitCode> {
    let scene = Scene::load(&a.scene).map_err(|e| invalid(e.to_string()))?;
    let spp = a.spp.unwrap_or(if a.cpu { scene.reference_spp } else { 1 });
    if spp == 0 || spp > crate::scene::MAX_SPP {
        return Err(invalid(format!(
            "--spp: must be between 1 and {}, got {spp}",
            crate::scene::MAX_SPP
        )));
    }
    let env = crate::golden::scene_environment(&scene).map_err(|e| invalid(e.to_string()))?;
    std::fs::create_dir_all(&a.out).map_err(|source| Error::File {
        path: a.out.clone(),
        source,
    })?;
    let plan = crate::plan::StagePlan::for_scene(&scene, spp);
    let bar = crate::golden::progress_bar(scene.frames as u64, "render");
    let mut frames = Vec::new();
    let renderer_name;
    let mut adapter = None;
    // The GPU configuration in effect (after any f16 promotion or staged
    // fallback) and why it differs from the one asked for.
    let mut gpu_config = None;
    let mut notes: Vec<String> = Vec::new();
    if a.cpu {
        renderer_name = "cpu-reference".to_owned();
        for n in 0..scene.frames {
            let t = std::time::Instant::now();
            let out = crate::reference::render_frame(&scene, &env, n, spp);
            let ms = t.elapsed().as_secs_f64() * 1e3;
            crate::io::write_png8(&a.out.join(crate::golden::frame_file(n)), &out.frame)?;
            frames.push(serde_json::json!({
                "frame": n, "file": crate::golden::frame_file(n), "wall_ms": ms,
                "stats": out.stats, "tone": out.tone,
            }));
            bar.inc(1);
        }
    } else {
        let ctx = crate::gpu::GpuContext::new(&a.gpu.adapter).map_err(gpu_error)?;
        renderer_name = ctx.adapter.name.clone();
        let r = crate::gpu::GpuRenderer::new(
            &ctx,
            plan.clone(),
            crate::gpu::GpuInput::Sphere {
                env: &env,
                camera: crate::reference::scene_camera(&scene),
                spp,
            },
            &crate::reference::Pipeline::of_scene(&scene),
            a.gpu.config(),
        )
        .map_err(gpu_error)?;
        gpu_config = Some(r.config);
        notes.clone_from(&r.notes);
        for n in 0..scene.frames {
            r.set_rotation(&crate::conventions::rotation_matrix(
                scene.rotation.axis,
                scene.angle(n),
            ));
            let out = r.render(true).map_err(gpu_error)?;
            let frame = out
                .frame
                .ok_or_else(|| invalid("GPU frame was not read back"))?;
            crate::io::write_png8(&a.out.join(crate::golden::frame_file(n)), &frame)?;
            frames.push(serde_json::json!({
                "frame": n, "file": crate::golden::frame_file(n), "wall_ms": out.wall_ms,
                "stats": out.stats, "timings": out.timings,
            }));
            bar.inc(1);
        }
        adapter = Some(ctx.adapter.clone());
    }
    bar.finish_and_clear();
    let report = serde_json::json!({
        "scene": scene.name, "renderer": renderer_name, "adapter": adapter, "spp": spp,
        "plan": plan.names(), "gpu_config": gpu_config, "notes": notes, "frames": frames,
    });
    write_json(&a.out.join("frames.json"), &report)?;
    println!(
        "{} frames of {} rendered on {renderer_name}, written to {}",
        scene.frames,
        scene.name,
        a.out.display()
    );
    Ok(ExitCode::SUCCESS)
}

/// The suite's scenes, or only the named ones (an unknown name is an error).
fn select_scenes(suite: &Path, names: &[String]) -> Result<Vec<Scene>> {
    let all = crate::scene::load_suite(suite).map_err(|e| invalid(e.to_string()))?;
    if names.is_empty() {
        return Ok(all);
    }
    names
        .iter()
        .map(|n| {
            all.iter().find(|s| &s.name == n).cloned().ok_or_else(|| {
                let known: Vec<&str> = all.iter().map(|s| s.name.as_str()).collect();
                invalid(format!(
                    "no scene {n:?} in {}; known: {}",
                    suite.display(),
                    known.join(", ")
                ))
            })
        })
        .collect()
}

fn golden_root(suite: &Path) -> PathBuf {
    suite
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."))
}

fn golden_bless(suite: &Path, names: &[String]) -> Result<ExitCode> {
    let scenes = select_scenes(suite, names)?;
    let root = golden_root(suite);
    crate::golden::bless(&root, &scenes, true).map_err(|e| invalid(e.to_string()))?;
    let frames: u32 = scenes.iter().map(|s| s.frames).sum();
    println!(
        "blessed {} scenes, {frames} frames; golden/ is {:.1} MB",
        scenes.len(),
        crate::golden::directory_bytes(&root) as f64 / 1e6
    );
    Ok(ExitCode::SUCCESS)
}

fn golden_verify(suite: &Path, names: &[String]) -> Result<ExitCode> {
    let scenes = select_scenes(suite, names)?;
    let root = golden_root(suite);
    let problems =
        crate::golden::verify(&root, &scenes, true).map_err(|e| invalid(e.to_string()))?;
    if problems.is_empty() {
        let frames: u32 = scenes.iter().map(|s| s.frames).sum();
        println!(
            "{} scenes, {frames} frames: bit-identical to their goldens",
            scenes.len()
        );
        Ok(ExitCode::SUCCESS)
    } else {
        for p in &problems {
            println!("{p}");
        }
        Ok(ExitCode::from(1))
    }
}

fn env(a: EnvArgs) -> Result<ExitCode> {
    use crate::env::BuiltinEnv;
    if a.list || a.name.is_none() {
        for e in BuiltinEnv::ALL {
            println!("{:<9} {}", e.name(), e.description());
        }
        return Ok(ExitCode::SUCCESS);
    }
    let name = a.name.unwrap_or_default();
    let env = BuiltinEnv::from_name(&name).ok_or_else(|| {
        invalid(format!(
            "unknown environment {name:?}; built-in: sky, interior, night, grid"
        ))
    })?;
    let output = a
        .output
        .ok_or_else(|| invalid("-o/--output is required to export an environment"))?;
    let img = env.generate(a.size.width, a.size.height);
    crate::io::write_image_hdr(&output, &img)?;
    println!("{name} {} -> {}", a.size, output.display());
    Ok(ExitCode::SUCCESS)
}
