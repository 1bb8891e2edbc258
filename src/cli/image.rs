//! The commands on single images and scenes: `tonemap`, `plan`, `render`,
//! `operators` and `env` (`compare` is in `compare.rs`, `bench` in
//! `bench.rs`).

use super::progress::Bar;
use super::{invalid, write_json, GpuArgs};
use clap::Args;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use tonegate::error::{Error, Result};
use tonegate::golden::frame_file;
use tonegate::gpu::GpuContext;
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
pub struct PlanArgs {
    pub scene: PathBuf,
    /// Samples per pixel of the sphere stage (default: what `check` renders
    /// the scene with, its `reference_spp`, or 1 for a TAA scene).
    #[arg(long)]
    pub spp: Option<u32>,
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
pub fn plan(a: PlanArgs) -> Result<ExitCode> {
    let scene = Scene::load(&a.scene)?;
    let plan = tonegate::plan::StagePlan::for_scene(&scene, a.spp.unwrap_or(scene.default_spp()));
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
