//! The command line: argument definitions, and the commands that call the
//! library. Only the binary has it; it draws the progress bars.
//!
//! Exit codes: 0 success, 1 a check or verification failed, 2 the run could
//! not happen (bad arguments, unreadable files, missing goldens).

use clap::{Args, Parser, Subcommand};
use serde::de::DeserializeOwned;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use tonegate::error::{Error, Result};
use tonegate::gpu::{
    AdapterChoice, BackendChoice, EnvFilter, Execution, GpuConfig, HdrFormat, ReductionMethod,
};

/// `println!` and `print!` for everything under `cli`: a closed standard
/// output ends the output quietly instead of panicking (`out`).
macro_rules! println {
    () => {
        $crate::cli::out::write(format_args!(""), true)
    };
    ($($arg:tt)*) => {
        $crate::cli::out::write(format_args!($($arg)*), true)
    };
}

macro_rules! print {
    ($($arg:tt)*) => {
        $crate::cli::out::write(format_args!($($arg)*), false)
    };
}

mod adapters;
mod bench;
mod compare;
mod fleet;
mod frames;
mod frames_remote;
mod gate;
mod golden;
mod image;
mod out;
mod pending;
mod progress;
mod serve;
mod sweep;

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
    Tradeoff(sweep::TradeoffArgs),
    /// Stiff and extreme inputs through both renderers: finiteness, error against f64, time.
    Stress(sweep::StressArgs),
    /// Time every stage of the full plan on the GPU: per-stage table, floor ratio, FPS.
    Bench(bench::BenchArgs),
    /// Tone-map one HDR image (.hdr, .exr, .pfm); output format from the extension.
    Tonemap(image::TonemapArgs),
    /// Compare an image with a reference: two 8-bit PNGs (MSE, RMSE, PSNR, SNR, SSIM,
    /// FLIP) or two linear HDR files (HDR-FLIP, PU21, delta E ITP); -t TEST -r REFERENCE.
    Compare(compare::CompareArgs),
    /// Print the stage plan of a scene: the stages it needs and nothing else.
    Plan(image::PlanArgs),
    /// Render a scene's frames on the GPU (or --cpu) with per-frame statistics and timings.
    Render(image::RenderArgs),
    /// Bless or verify the golden images.
    #[command(subcommand)]
    Golden(golden::GoldenCommand),
    /// Your renderer's frames through the gate: submit a folder of images, triage
    /// their digests, read the triage log. Exit 0 pass, 1 fail, 2 could not run.
    #[command(subcommand)]
    Frames(frames::FramesCommand),
    /// Export a built-in HDR environment, or list them.
    Env(image::EnvArgs),
    /// List the tone-mapping operators with their parameters, ranges and defaults.
    Operators(image::OperatorsArgs),
    /// Serve the HTTP API (/api/v1), Prometheus metrics (/metrics) and the dashboard (/).
    Serve(serve::ServeArgs),
    /// Take queued check runs from a shared history (--db postgres://...) and run them on this machine's adapter.
    Runner(fleet::RunnerArgs),
    /// Queue check runs for the fleet's runners.
    Enqueue(fleet::EnqueueArgs),
    /// Print the fleet: runners (adapter, labels, heartbeat, job) and the queue.
    Fleet(fleet::FleetArgs),
    /// List every adapter on every backend: name, backend, type, driver, limits, features, and whether it flushes subnormals (measured).
    Adapters(adapters::AdaptersArgs),
}

/// Parses a knob by its serde name (the words reports and the API use), so
/// the command line has no parser of its own for the library's enums.
fn by_name<T: DeserializeOwned>(s: &str) -> std::result::Result<T, String> {
    T::deserialize(serde::de::value::StrDeserializer::<serde::de::value::Error>::new(s))
        .map_err(|e| e.to_string())
}

/// The GPU knobs shared by every GPU command.
#[derive(Args, Clone)]
pub struct GpuArgs {
    /// Adapter: "default" (lavapipe/llvmpipe when present, for reproducible results, else the first), "hardware" (the best GPU: discrete, integrated, virtual), "any" (the first), or a name substring ("swiftshader" finds Chromium's SwiftShader without VK_ICD_FILENAMES); "gl:llvmpipe" names the backend too. Reports say which was chosen and why. `tonegate adapters` lists them.
    #[arg(long = "adapter", id = "adapter", default_value = "default")]
    pub adapter_choice: AdapterChoice,
    #[command(flatten)]
    pub backend: BackendArg,
    /// HDR intermediates: rgba32float (f32) or rgba16float (f16).
    #[arg(long, default_value = "rgba32float", value_parser = by_name::<HdrFormat>)]
    pub hdr_format: HdrFormat,
    /// Luminance reduction: auto (block on a CPU adapter; on a GPU subgroup where it has subgroup operations, else tree), block (single-pass block partials), pingpong (2x2 ping-pong levels), tree (workgroup shared-memory tree) or subgroup (the tree with subgroup shuffles).
    #[arg(long, default_value = "auto", value_parser = by_name::<ReductionMethod>)]
    pub reduction: ReductionMethod,
    /// Texture filtering in `sphere` (the environment) and `taa` (the history): manual (the reference's arithmetic from loads) or hardware (the sampler; needs float32-filterable textures with rgba32float).
    #[arg(long, default_value = "manual", value_parser = by_name::<EnvFilter>)]
    pub env_filter: EnvFilter,
    /// Kernels: staged (one per stage, each timed and readable) or fused (tonemap+composite+encode and bright+downsample merged; fewer full-frame passes).
    #[arg(long, default_value = "staged", value_parser = by_name::<Execution>)]
    pub execution: Execution,
}

/// `--backend`, for every command that opens an adapter.
#[derive(Args, Clone)]
pub struct BackendArg {
    /// Graphics API: vulkan, gl (OpenGL through EGL; headless Mesa on Linux), metal, dx12, any, or default (Vulkan where it has an adapter, else any).
    #[arg(long, value_parser = by_parse::<BackendChoice>)]
    pub backend: Option<BackendChoice>,
}

impl BackendArg {
    /// `choice` on the backend this flag names (when it names one).
    pub fn apply(&self, choice: &AdapterChoice) -> AdapterChoice {
        match self.backend {
            Some(b) => choice.clone().on(b),
            None => choice.clone(),
        }
    }
}

fn by_parse<T: std::str::FromStr<Err = String>>(s: &str) -> std::result::Result<T, String> {
    s.parse()
}

impl GpuArgs {
    /// The adapter asked for, on the backend asked for.
    pub fn adapter(&self) -> AdapterChoice {
        self.backend.apply(&self.adapter_choice)
    }

    pub fn config(&self) -> GpuConfig {
        GpuConfig {
            hdr_format: self.hdr_format,
            reduction: self.reduction,
            env_filter: self.env_filter,
            execution: self.execution,
            fault_gain: None,
            taa_fault: None,
            fault_delay_ms: None,
        }
    }
}

/// Parses the process arguments and runs the command.
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    // An adapter asked for by name may be a Vulkan driver outside the
    // loader's folders: they are added now, while the process has one thread.
    if names_an_adapter(std::env::args().skip(1)) {
        tonegate::gpu::adapters::add_extra_vulkan_drivers();
    }
    match run(cli) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(exit_code(&e))
        }
    }
}

/// Whether the arguments are `adapters` or name an adapter (`--adapter
/// NAME`, not `default`, `hardware` or `any`).
fn names_an_adapter(args: impl Iterator<Item = String>) -> bool {
    let args: Vec<String> = args.collect();
    if args.first().is_some_and(|a| a == "adapters") {
        return true;
    }
    let values = args
        .iter()
        .enumerate()
        .filter_map(|(i, a)| match a.as_str() {
            "--adapter" => args.get(i + 1).map(String::as_str),
            _ => a.strip_prefix("--adapter="),
        });
    values
        .filter_map(|v| v.parse::<AdapterChoice>().ok())
        .any(|c| matches!(c.pick, tonegate::gpu::AdapterPick::Name(_)))
}

/// The exit code of a command that failed with `e`: every error means the
/// run could not happen (2); a failed check or verification is not an error
/// but an outcome (1), decided by the command.
fn exit_code(e: &Error) -> u8 {
    match e {
        Error::HdrIo(_)
        | Error::Metrics(_)
        | Error::File { .. }
        | Error::Gpu(_)
        | Error::Plan(_)
        | Error::Scene(_)
        | Error::Render(_)
        | Error::Golden(_)
        | Error::History(_)
        | Error::Tradeoff(_)
        | Error::Json { .. }
        | Error::Junit(_)
        | Error::Service { .. }
        | Error::Frames(_)
        | Error::Invalid(_) => 2,
    }
}

pub fn run(cli: Cli) -> Result<ExitCode> {
    match cli.command {
        Command::Check(a) => gate::check(a),
        Command::History(a) => gate::history(a),
        Command::Tradeoff(a) => sweep::tradeoff(a),
        Command::Stress(a) => sweep::stress(a),
        Command::Bench(a) => bench::bench(a),
        Command::Tonemap(a) => image::tonemap(a),
        Command::Compare(a) => compare::compare(a),
        Command::Plan(a) => image::plan(a),
        Command::Render(a) => image::render(a),
        Command::Golden(c) => golden::golden(c),
        Command::Frames(c) => frames::frames(c),
        Command::Env(a) => image::env(a),
        Command::Operators(a) => image::operators(a),
        Command::Serve(a) => serve::serve(a),
        Command::Runner(a) => fleet::runner(a),
        Command::Enqueue(a) => fleet::enqueue(a),
        Command::Fleet(a) => fleet::fleet(a),
        Command::Adapters(a) => adapters::adapters(a),
    }
}

/// Where the history lives.
#[derive(Args, Clone)]
pub struct DbArgs {
    /// The history database: a SQLite file (created when absent by the
    /// commands that write to it), or a PostgreSQL database shared by a
    /// fleet (postgres://user@host/db).
    #[arg(long, env = "TONEGATE_DB", default_value = ".tonegate/history.sqlite")]
    pub db: PathBuf,
    /// Seconds to keep retrying a PostgreSQL history that is down or
    /// restarting (reconnecting, backing off with jitter), and an artifact
    /// store's writes, before giving up (an image is then kept pending)
    /// (default: 600 for `runner`, 2 for `serve`, which then answers 503
    /// with Retry-After, 10 for the other commands).
    #[arg(long, env = "TONEGATE_DB_RETRY_S")]
    pub db_retry_s: Option<u64>,
}

impl DbArgs {
    /// Sets the process's retry budget for a lost database connection:
    /// `--db-retry-s`, or the command's own default.
    pub fn set_retry(&self, default_s: u64) {
        tonegate::history::set_retry_budget(std::time::Duration::from_secs(
            self.db_retry_s.unwrap_or(default_s),
        ));
    }

    /// Whether the history is a PostgreSQL database.
    pub fn is_url(&self) -> bool {
        tonegate::history::is_url(&self.db.to_string_lossy())
    }

    /// The history as the console shows it: a PostgreSQL address without its password.
    pub fn shown(&self) -> String {
        tonegate::history::redacted(&self.db.to_string_lossy())
    }

    /// The history opened to read, refused with the path when a SQLite
    /// file is not there: a command that only reads does not create one.
    pub fn open_existing(&self) -> Result<tonegate::history::History> {
        if !self.is_url() && !self.db.exists() {
            return Err(invalid(format!(
                "no history at {} (run `tonegate check` or `tonegate frames submit` first, or pass --db)",
                self.shown()
            )));
        }
        Ok(tonegate::history::History::open_read_only(&self.db)?)
    }
}

fn invalid(msg: impl Into<String>) -> Error {
    Error::Invalid(msg.into())
}

/// Pretty JSON of `value`; `what` names it in the error.
fn json_text(what: &'static str, value: &impl serde::Serialize) -> Result<String> {
    serde_json::to_string_pretty(value).map_err(|source| Error::Json { what, source })
}

/// Writes `value` as pretty JSON to `path`, or to stdout for "-".
fn write_json(path: &Path, what: &'static str, value: &impl serde::Serialize) -> Result<()> {
    let text = json_text(what, value)?;
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

/// Writes `text` to `path`, creating its folder.
fn write_text(path: &Path, text: &str) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| Error::File {
            path: dir.to_owned(),
            source,
        })?;
    }
    std::fs::write(path, text).map_err(|source| Error::File {
        path: path.to_owned(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::names_an_adapter;

    fn names(line: &str) -> bool {
        names_an_adapter(line.split_whitespace().map(String::from))
    }

    #[test]
    fn only_a_named_adapter_or_the_listing_adds_the_extra_drivers() {
        assert!(names("adapters --json"));
        assert!(names("check --adapter swiftshader"));
        assert!(names("render s.toml --adapter=vulkan:SwiftShader --out o"));
        for plain in [
            "check",
            "check --adapter default",
            "check --adapter hardware",
            "bench --adapter gl:any",
            "tonemap in.exr -o out.png",
        ] {
            assert!(!names(plain), "{plain}");
        }
    }
}
