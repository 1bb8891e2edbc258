//! `tonegate bench`: every stage of the full plan timed on the GPU against
//! the floor passes (`tonegate::gpu::bench`).

use super::{invalid, write_json, GpuArgs};
use clap::Args;
use std::path::Path;
use std::process::ExitCode;
use tonegate::error::Result;
use tonegate::gpu::GpuContext;
use tonegate::scene::Size;

#[derive(Args)]
pub struct BenchArgs {
    #[arg(long, default_value = "1920x1080")]
    pub size: Size,
    /// Measured frames (after the warm-up).
    #[arg(long, default_value_t = 60)]
    pub frames: u32,
    #[arg(long, default_value_t = 10)]
    pub warmup: u32,
    /// TAA stages after `sphere` (off, clip, edge-aware, variance), timed
    /// with a history to resolve every frame; the other TAA keys at a
    /// scene's defaults (docs/taa.md).
    #[arg(long, value_enum, default_value = "off")]
    pub taa: tonegate::scene::TaaVariant,
    /// How the TAA history is read.
    #[arg(long, value_enum, default_value = "catmull-rom")]
    pub taa_history: tonegate::scene::HistoryFilter,
    /// How the TAA blend's current-frame weight is chosen.
    #[arg(long, value_enum, default_value = "motion")]
    pub taa_feedback: tonegate::scene::FeedbackRule,
    /// Where the TAA blend is taken.
    #[arg(long, value_enum, default_value = "tonemapped")]
    pub taa_blend: tonegate::scene::BlendSpace,
    /// Time this operator instead of the bench's own (reinhard-auto-key
    /// with the automatic key), with the operator parameters given (the
    /// rest at their defaults); `tonegate operators` lists them.
    #[arg(long)]
    pub operator: Option<String>,
    #[command(flatten)]
    pub params: tonegate::toning::OperatorParams,
    /// Eye adaptation in the plan, metered by `histogram` or
    /// `log-average`, the other keys at their defaults
    /// (docs/adaptation.md).
    #[arg(long)]
    pub adaptation: Option<String>,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
    /// Also time FLIP at this size, on the GPU (tonegate's port) and the CPU
    /// (nv-flip, on every core), and every metric of a pair on each: `flip`
    /// in the report.
    #[arg(long)]
    pub flip: bool,
    #[command(flatten)]
    pub gpu: GpuArgs,
}

pub fn bench(a: BenchArgs) -> Result<ExitCode> {
    let ctx = GpuContext::new(&a.gpu.adapter())?;
    if a.frames == 0 {
        return Err(invalid("--frames must be at least 1"));
    }
    if a.operator.is_none() && !a.params.0.is_empty() {
        return Err(invalid(format!(
            "{}: operator parameters need --operator",
            a.params.0[0].0
        )));
    }
    let operator = a
        .operator
        .as_deref()
        .map(|name| {
            let def = tonegate::operators::find(name).ok_or_else(|| {
                invalid(format!(
                    "--operator: unknown operator {name:?}; expected one of {}",
                    tonegate::operators::names().join(", ")
                ))
            })?;
            tonegate::operators::Operator::from_text(def, &a.params.0)
                .map_err(|e| invalid(e.to_string()))
        })
        .transpose()?;
    let adaptation = match a.adaptation.as_deref() {
        None => None,
        Some("histogram") => Some(tonegate::scene::Adaptation::default()),
        Some("log-average") => Some(tonegate::scene::Adaptation {
            metering: tonegate::scene::Metering::LogAverage,
            ..Default::default()
        }),
        Some(other) => {
            return Err(invalid(format!(
                "--adaptation: {other:?} is no metering; expected histogram or log-average"
            )))
        }
    };
    let opts = tonegate::gpu::bench::BenchOptions {
        width: a.size.width,
        height: a.size.height,
        frames: a.frames,
        warmup: a.warmup,
        config: a.gpu.config(),
        taa: tonegate::scene::TaaParams {
            variant: a.taa,
            history_filter: a.taa_history,
            feedback: a.taa_feedback,
            blend: a.taa_blend,
            ..Default::default()
        },
        operator,
        adaptation,
    };
    let report = tonegate::gpu::bench::run(&ctx, &opts)?;
    let flip = a
        .flip
        .then(|| tonegate::gpu::compare::time_flip(&ctx, a.size.width, a.size.height, 10))
        .transpose()
        .map_err(|e| invalid(format!("--flip: {e}")))?;
    if a.json {
        let mut value =
            serde_json::to_value(&report).map_err(|e| invalid(format!("the bench report: {e}")))?;
        if let (Some(flip), Some(o)) = (&flip, value.as_object_mut()) {
            o.insert(
                "flip".into(),
                serde_json::to_value(flip).unwrap_or_default(),
            );
        }
        write_json(Path::new("-"), "the bench report", &value)?;
    } else {
        println!("{report}");
        if let Some(f) = &flip {
            println!(
                "FLIP {}: {:.2} ms on the GPU (median of {}), {:.2} ms nv-flip on the CPU (median of 3); means {:.6} and {:.6}; every figure: {:.2} ms on the GPU, {:.2} ms on the CPU",
                f.size, f.gpu_ms, f.runs, f.cpu_ms, f.gpu_mean, f.cpu_mean, f.gpu_all_ms, f.cpu_all_ms
            );
        }
    }
    Ok(ExitCode::SUCCESS)
}
