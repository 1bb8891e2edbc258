//! `tonegate frames`: a renderer's own frames through the gate
//! (docs/frames.md): `submit` a folder, `triage` a digest, `log` the
//! triage actions.

use super::{write_json, write_text, DbArgs};
use clap::{Args, Subcommand, ValueEnum};
use std::path::PathBuf;
use std::process::ExitCode;
use tonegate::error::Result;
use tonegate::frames::rules::Rules;
use tonegate::frames::{collect_folder_noting, parse_keys, submit, Submission};
use tonegate::gate::MetricsOn;
use tonegate::history::{History, Label, MAIN};

#[derive(Subcommand)]
pub enum FramesCommand {
    /// Judge a folder of images (PNG 8-bit or PQ 16-bit, EXR, Radiance HDR, PFM),
    /// each a frame of the test its path names, and store them. Exit 0 every frame
    /// passed, 1 one did not, 2 the submission could not be judged (nothing stored).
    Submit(SubmitArgs),
    /// Say what a digest of a test is: positive (it may look like this), negative
    /// (it must not) or untriaged.
    Triage(TriageArgs),
    /// Print the triage actions, oldest first.
    Log(LogArgs),
    /// A branch landed: its positives and negatives become the main line's.
    Promote(PromoteArgs),
    /// Ignore failures of matching tests for a while (a known flake, a driver bug).
    Ignore(IgnoreArgs),
}

#[derive(Args)]
pub struct SubmitArgs {
    /// The folder: `ui/button.png` in it is a frame of test `ui/button`.
    pub folder: PathBuf,
    /// A key of the submission, NAME=VALUE (device, backend, branch, commit, …).
    #[arg(long = "key", value_name = "NAME=VALUE")]
    pub keys: Vec<String>,
    /// A retry with the same key stores nothing and answers what the first did.
    #[arg(long, value_name = "KEY")]
    pub idempotency_key: Option<String>,
    /// The tests' thresholds and what an untriaged digest does (docs/frames.md#rules).
    #[arg(long, value_name = "FILE")]
    pub rules: Option<PathBuf>,
    /// Write the report as JSON ("-" for stdout).
    #[arg(long, value_name = "FILE|-")]
    pub json: Option<PathBuf>,
    /// Write JUnit XML, one test case a frame.
    #[arg(long, value_name = "FILE")]
    pub junit: Option<PathBuf>,
    /// MiB of memory that judging the frames may take at once: each
    /// image's decoding and comparing, from its header, before it is
    /// decoded; an image needing more is refused (a server has its own,
    /// `serve --decode-budget-mib`).
    #[arg(long, default_value_t = 2048)]
    pub decode_budget_mib: u64,
    /// Write a Markdown summary here (the failing frames, their figures
    /// and the triage page's link): for a CI job's summary
    /// ($GITHUB_STEP_SUMMARY) or a pull request's comment.
    #[arg(long, value_name = "FILE")]
    pub summary: Option<PathBuf>,
    /// Keep the images in this object store (s3://bucket/prefix) instead of
    /// the history's table, each once by its SHA-256.
    #[arg(long, value_name = "s3://BUCKET/PREFIX")]
    pub artifacts: Option<String>,
    /// Where an untriaged 8-bit frame's figures against a positive are
    /// computed: cpu (NVIDIA's FLIP through nv-flip), gpu (on --adapter:
    /// the check's GPU metrics, trusted once they pass their locks there),
    /// or auto (the GPU on a hardware adapter, else the CPU).
    #[arg(long, default_value = "cpu", value_parser = crate::cli::by_name::<MetricsOn>)]
    pub metrics: MetricsOn,
    /// The adapter of --metrics gpu|auto.
    #[arg(long = "adapter", default_value = "default")]
    pub adapter: tonegate::gpu::AdapterChoice,
    /// Submit to this `tonegate serve` (http(s)://host:port) instead of
    /// writing the history: what a CI job without the database does.
    #[arg(long, value_name = "URL", requires = "token_file")]
    pub server: Option<String>,
    /// The submit token (`serve --submit-token-file`), with --server.
    #[arg(long, value_name = "FILE", env = "TONEGATE_SUBMIT_TOKEN_FILE")]
    pub token_file: Option<PathBuf>,
    #[command(flatten)]
    pub db: DbArgs,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum LabelArg {
    Positive,
    Negative,
    Untriaged,
}

#[derive(Args)]
pub struct TriageArgs {
    /// The test.
    #[arg(long)]
    pub test: String,
    /// The digest (as `submit` reports it).
    #[arg(long)]
    pub digest: String,
    /// What it is.
    #[arg(value_enum)]
    pub label: LabelArg,
    /// Who says so.
    #[arg(long)]
    pub who: String,
    /// Why.
    #[arg(long)]
    pub why: String,
    /// On this branch (its submissions fall back to the main line's triage);
    /// the main line when left out or when it is the rules' main branch.
    #[arg(long)]
    pub branch: Option<String>,
    /// The rules file, for its main branch's name (default "main").
    #[arg(long, value_name = "FILE")]
    pub rules: Option<PathBuf>,
    #[command(flatten)]
    pub db: DbArgs,
}

#[derive(Args)]
pub struct PromoteArgs {
    /// The branch that landed.
    #[arg(long)]
    pub branch: String,
    #[arg(long)]
    pub who: String,
    #[arg(long)]
    pub why: String,
    #[command(flatten)]
    pub db: DbArgs,
}

#[derive(Args)]
pub struct IgnoreArgs {
    /// The tests it covers: a name, `*` any characters but `/`, `**` any.
    #[arg(long, value_name = "PATTERN")]
    pub test: String,
    /// Only in submissions with this key, NAME=VALUE (repeatable: all of them).
    #[arg(long = "key", value_name = "NAME=VALUE")]
    pub keys: Vec<String>,
    /// How long it lasts, in hours (at most a year).
    #[arg(long)]
    pub hours: f64,
    #[arg(long)]
    pub who: String,
    #[arg(long)]
    pub reason: String,
    #[command(flatten)]
    pub db: DbArgs,
}

#[derive(Args)]
pub struct LogArgs {
    /// Only this test's.
    #[arg(long)]
    pub test: Option<String>,
    /// Write JSON instead ("-" for stdout).
    #[arg(long, value_name = "FILE|-")]
    pub json: Option<PathBuf>,
    #[command(flatten)]
    pub db: DbArgs,
}

pub fn frames(c: FramesCommand) -> Result<ExitCode> {
    match c {
        FramesCommand::Submit(a) => submit_folder(a),
        FramesCommand::Triage(a) => triage(a),
        FramesCommand::Log(a) => log(a),
        FramesCommand::Promote(a) => promote(a),
        FramesCommand::Ignore(a) => ignore(a),
    }
}

fn submit_folder(a: SubmitArgs) -> Result<ExitCode> {
    a.db.set_retry(10);
    let rules = match &a.rules {
        Some(path) => Rules::load(path).map_err(super::invalid)?,
        None => Rules::default(),
    };
    let keys = parse_keys(&a.keys)?;
    if let Some(url) = &a.artifacts {
        if !tonegate::history::is_store_url(url) || a.server.is_some() {
            return Err(super::invalid(format!(
                "--artifacts {url:?}: an object store, s3://bucket/prefix, for a history this command writes (not with --server: the server has its own)"
            )));
        }
        tonegate::history::set_artifact_store(Some(url))?;
    }
    if a.decode_budget_mib == 0 || a.decode_budget_mib > 1 << 20 {
        return Err(super::invalid(format!(
            "--decode-budget-mib {}: from 1 to 1048576",
            a.decode_budget_mib
        )));
    }
    tonegate::frames::budget::set_budget(
        a.decode_budget_mib << 20,
        tonegate::frames::budget::DEFAULT_WAIT,
    );
    let (inputs, skipped) = collect_folder_noting(&a.folder)?;
    if let Some(first) = skipped.first() {
        eprintln!(
            "skipped {} file(s) that are not images (.png, .exr, .hdr, .pfm): {first}{}",
            skipped.len(),
            if skipped.len() > 1 { ", …" } else { "" }
        );
    }
    let report = match &a.server {
        Some(server) => super::frames_remote::submit(
            super::frames_remote::Remote {
                server,
                token_file: a.token_file.as_deref(),
                keys: &a.keys,
                rules: a.rules.as_ref(),
                idempotency_key: a.idempotency_key.as_deref(),
            },
            inputs,
        )?,
        None => {
            let history = History::open(&a.db.db)?;
            // The GPU's metrics, where asked for and trusted on the adapter.
            let ctx = match a.metrics {
                MetricsOn::Cpu => None,
                _ => Some(tonegate::gpu::GpuContext::new(&a.adapter)?),
            };
            let gpu = match a.metrics.resolve(ctx.as_ref()) {
                MetricsOn::Gpu => ctx.as_ref().and_then(|c| {
                    let g = tonegate::gpu::compare::GpuCompare::new(c);
                    match g.self_check() {
                        Ok(()) => {
                            eprintln!("untriaged 8-bit frames are compared with the GPU's metrics on {}", c.adapter.name);
                            Some(g)
                        }
                        Err(why) => {
                            eprintln!("the GPU's metrics are not trusted on {}: {why}; comparing on the CPU", c.adapter.name);
                            None
                        }
                    }
                }),
                _ => None,
            };
            let on_gpu = gpu.as_ref().map(|g| {
                move |t: tonegate::metrics::Raster, r: tonegate::metrics::Raster| g.compare(t, r)
            });
            submit(
                &history,
                Submission {
                    inputs,
                    keys,
                    idempotency_key: a.idempotency_key.as_deref(),
                    rules: &rules,
                    compare: on_gpu.as_ref().map(|f| tonegate::metrics::CompareBy(f)),
                },
            )?
        }
    };
    if let Some(path) = &a.json {
        write_json(path, "the submission's report", &report)?;
    }
    if let Some(path) = &a.junit {
        write_text(path, &report.junit()?)?;
    }
    // The submission's page on the server it went to.
    let triage = a.server.as_ref().map(|server| {
        format!(
            "{}/#/frames/{}",
            server.trim_end_matches('/'),
            report.submission
        )
    });
    if let Some(path) = &a.summary {
        write_text(path, &report.markdown(triage.as_deref()))?;
    }
    if a.json.as_deref() != Some(std::path::Path::new("-")) {
        print!("{}", report.console());
        if let Some(link) = &triage {
            println!("triage: {link}");
        }
    }
    Ok(ExitCode::from(report.exit_code() as u8))
}

fn triage(a: TriageArgs) -> Result<ExitCode> {
    a.db.set_retry(10);
    let label = match a.label {
        LabelArg::Positive => Label::Positive,
        LabelArg::Negative => Label::Negative,
        LabelArg::Untriaged => Label::Untriaged,
    };
    let rules = match &a.rules {
        Some(path) => Rules::load(path).map_err(super::invalid)?,
        None => Rules::default(),
    };
    let branch = a
        .branch
        .as_deref()
        .filter(|b| *b != rules.main_branch)
        .unwrap_or(MAIN);
    let history = History::open(&a.db.db)?;
    history.triage(branch, &a.test, &a.digest, label, (&a.who, &a.why))?;
    println!("{} {}: {}", a.test, a.digest, label.as_str());
    Ok(ExitCode::SUCCESS)
}

fn promote(a: PromoteArgs) -> Result<ExitCode> {
    a.db.set_retry(10);
    let history = History::open(&a.db.db)?;
    let n = history.promote(&a.branch, &a.who, &a.why)?;
    let labels = if n == 1 { "label" } else { "labels" };
    println!("{n} {labels} of {} promoted to the main line", a.branch);
    Ok(ExitCode::SUCCESS)
}

/// The longest an ignore rule may last: a year.
const MOST_HOURS: f64 = 24.0 * 366.0;

fn ignore(a: IgnoreArgs) -> Result<ExitCode> {
    a.db.set_retry(10);
    if !(a.hours > 0.0 && a.hours <= MOST_HOURS) {
        return Err(super::invalid(format!(
            "--hours {}: an ignore rule lasts more than 0 and at most {MOST_HOURS} hours",
            a.hours
        )));
    }
    let keys = parse_keys(&a.keys)?;
    let keys = serde_json::to_string(&keys).unwrap_or_default();
    let history = History::open(&a.db.db)?;
    let lasting = std::time::Duration::from_secs_f64(a.hours * 3600.0);
    let rule = history.add_ignore_rule(&a.test, &keys, lasting, (&a.who, &a.reason))?;
    println!(
        "ignore rule {}: {} until {}",
        rule.id, rule.pattern, rule.expires_at
    );
    Ok(ExitCode::SUCCESS)
}

fn log(a: LogArgs) -> Result<ExitCode> {
    a.db.set_retry(10);
    let history = a.db.open_existing()?;
    let entries = history.triage_log(a.test.as_deref())?;
    match &a.json {
        Some(path) => write_json(path, "the triage log", &entries)?,
        None => {
            for e in &entries {
                println!(
                    "{} {} {} {} by {}: {}",
                    e.at,
                    e.test,
                    e.digest,
                    e.label.as_str(),
                    e.who,
                    e.why
                );
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}
