//! `tonegate serve`: the API and dashboard on the run history.

use super::DbArgs;
use super::GpuArgs;
use clap::Args;
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use tonegate::error::{Error, Result};
use tonegate::server::{Limits, ServeOptions, Server};

#[derive(Args)]
pub struct ServeArgs {
    /// Address to listen on (port 0: any free port, printed at start).
    #[arg(long, default_value = "127.0.0.1:8080")]
    pub bind: std::net::SocketAddr,
    #[command(flatten)]
    pub db: DbArgs,
    /// The bearer token for requests that change state; created (random,
    /// mode 0600) when the file does not exist. Default: `token` beside the database.
    #[arg(long, env = "TONEGATE_TOKEN_FILE")]
    pub token_file: Option<PathBuf>,
    /// A token that may only submit frames (what a CI job holds); created
    /// like --token-file's when the file does not exist.
    #[arg(long, env = "TONEGATE_SUBMIT_TOKEN_FILE")]
    pub submit_token_file: Option<PathBuf>,
    /// A token that may only triage frames (mark digests, promote branches,
    /// add ignore rules); created like --token-file's when the file does not exist.
    #[arg(long, env = "TONEGATE_TRIAGE_TOKEN_FILE")]
    pub triage_token_file: Option<PathBuf>,
    /// Require a token for reads too (the dashboard then asks for it).
    #[arg(long)]
    pub private_reads: bool,
    /// Keep the images the server stores (submitted frames) in this object
    /// store (s3://bucket/prefix), each once by its SHA-256.
    #[arg(long, value_name = "s3://BUCKET/PREFIX")]
    pub artifacts: Option<String>,
    /// Scan the history for alerts and deliver them to the webhooks this
    /// file names (docs/alerts.md).
    #[arg(long, value_name = "FILE")]
    pub alerts: Option<PathBuf>,
    /// The suite `POST /api/v1/runs` runs.
    #[arg(long, default_value = "golden/suite.toml")]
    pub suite: PathBuf,
    /// Run the suite once at start (the dashboard shows it as it goes).
    #[arg(long)]
    pub run_suite: bool,
    /// POST /tonemap: largest body in MiB.
    #[arg(long, default_value_t = Limits::default().max_body >> 20)]
    pub max_body_mib: usize,
    /// POST /tonemap: largest image in pixels, checked from the header before decoding.
    #[arg(long, default_value_t = Limits::default().max_pixels)]
    pub max_pixels: u64,
    /// POST /tonemap: jobs that may wait per queue (GPU, CPU) before the answer is 503.
    #[arg(long, default_value_t = Limits::default().queue)]
    pub queue: usize,
    /// POST /tonemap: bodies received at once (a queue place is taken once
    /// a body is in); past it, 503 `busy`.
    #[arg(long, default_value_t = Limits::default().max_uploads)]
    pub max_uploads: usize,
    /// Of those, the most one client may have open, and the same share of
    /// --upload-budget-mib: a client's slow uploads cannot take every place.
    /// A client is its address, or, behind a --trusted-proxy, the address
    /// the proxy forwarded for.
    #[arg(long, default_value_t = Limits::default().max_uploads_per_client)]
    pub max_uploads_per_client: usize,
    /// A proxy (load balancer) in front of the server, by address: its
    /// requests' client is the one its X-Forwarded-For names. Repeatable.
    #[arg(long, value_name = "IP")]
    pub trusted_proxy: Vec<std::net::IpAddr>,
    /// POST /tonemap: MiB the bodies being received may hold together,
    /// charged as their bytes arrive; past it, 503 `busy`.
    #[arg(long, default_value_t = Limits::default().upload_budget >> 20)]
    pub upload_budget_mib: usize,
    /// Seconds the answers in progress have to finish after SIGTERM or
    /// Ctrl-C before their connections are cut and the process exits.
    #[arg(long, default_value_t = tonegate::server::listen::DEFAULT_SHUTDOWN_GRACE.as_secs())]
    pub shutdown_grace_s: u64,
    /// MiB of memory that judging submitted frames may take at once, all
    /// submissions together: each image's decoding and comparing is
    /// reserved from it by its header before it is decoded; an image
    /// larger than all of it is refused (413), and a submission that
    /// waits 30 s for it is answered 503 with Retry-After.
    #[arg(long, default_value_t = tonegate::frames::budget::DEFAULT_BUDGET_BYTES >> 20)]
    pub decode_budget_mib: u64,
    /// POST /tonemap: seconds a request may take, upload and waiting included.
    #[arg(long, default_value_t = Limits::default().timeout.as_secs())]
    pub timeout: u64,
    /// POST /runs on a fleet's history: jobs that may wait in the queue
    /// before a submission is answered 503 `queue_full`.
    #[arg(long, default_value_t = Limits::default().max_queued_jobs)]
    pub max_queued_jobs: u64,
    /// Connections served at once (default 1024, lowered to fit the
    /// open-file limit); past it, health checks are answered and the rest
    /// get 503 with `Connection: close`.
    #[arg(long)]
    pub max_connections: Option<usize>,
    /// Seconds a client has to send a request's head, from connect or from
    /// its previous answer (keep-alive idle time included).
    #[arg(long, default_value_t = 10)]
    pub header_timeout: u64,
    #[command(flatten)]
    pub gpu: GpuArgs,
}

pub fn serve(a: ServeArgs) -> Result<ExitCode> {
    if a.max_body_mib == 0 || a.max_body_mib > 4096 {
        return Err(Error::Invalid(format!(
            "--max-body-mib: must be 1 to 4096, got {}",
            a.max_body_mib
        )));
    }
    if a.max_uploads_per_client == 0 || a.max_uploads_per_client > a.max_uploads {
        return Err(Error::Invalid(format!(
            "--max-uploads-per-client {}: from 1 to --max-uploads ({})",
            a.max_uploads_per_client, a.max_uploads
        )));
    }
    if a.decode_budget_mib == 0 || a.decode_budget_mib > 1 << 20 {
        return Err(Error::Invalid(format!(
            "--decode-budget-mib {}: from 1 to 1048576",
            a.decode_budget_mib
        )));
    }
    tonegate::frames::budget::set_budget(
        a.decode_budget_mib << 20,
        tonegate::frames::budget::DEFAULT_WAIT,
    );
    if a.max_uploads == 0 || a.upload_budget_mib == 0 || a.upload_budget_mib > 65536 {
        return Err(Error::Invalid(format!(
            "--max-uploads and --upload-budget-mib: must be at least 1 (the budget at most 65536), got {} and {}",
            a.max_uploads, a.upload_budget_mib
        )));
    }
    if a.header_timeout == 0 {
        return Err(Error::Invalid(
            "--header-timeout: must be at least 1 second".into(),
        ));
    }
    if a.timeout == 0 {
        return Err(Error::Invalid(
            "--timeout: must be at least 1 second".into(),
        ));
    }
    a.db.set_retry(2);
    // The history's folder first: the token file goes beside it, and a
    // folder that cannot be made is the history's problem, said as such.
    if !a.db.is_url() {
        if let Some(dir) = a.db.db.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| {
                Error::Invalid(format!(
                    "--db {}: cannot create its folder {}: {e}",
                    a.db.shown(),
                    dir.display()
                ))
            })?;
        }
    }
    // Beside a SQLite history; a PostgreSQL one has no folder.
    let token_file = a.token_file.clone().unwrap_or_else(|| {
        let dir = if a.db.is_url() {
            std::path::Path::new(".tonegate")
        } else {
            a.db.db.parent().unwrap_or(std::path::Path::new("."))
        };
        dir.join("token")
    });
    // Each token file, and whether it was created now (said on stderr, so
    // that whoever started the server knows where to find it).
    let token_in = |f: &std::path::Path| -> Result<String> {
        let existed = f.exists();
        let t = tonegate::server::load_or_make_token(f)?;
        if !existed {
            eprintln!("created the token file {} (mode 0600)", f.display());
        }
        Ok(t)
    };
    let token = token_in(&token_file)?;
    let scoped_token = |file: &Option<PathBuf>| -> Result<Option<String>> {
        let Some(f) = file else { return Ok(None) };
        let t = token_in(f)?;
        if t == token {
            return Err(Error::Invalid(format!(
                "{}: the same token as --token-file's; a scoped token must be its own",
                f.display()
            )));
        }
        Ok(Some(t))
    };
    let scoped = tonegate::server::ScopedTokens {
        submit: scoped_token(&a.submit_token_file)?,
        triage: scoped_token(&a.triage_token_file)?,
    };
    if scoped.submit.is_some() && scoped.submit == scoped.triage {
        return Err(Error::Invalid(
            "--submit-token-file and --triage-token-file hold the same token; each scope needs its own"
                .into(),
        ));
    }
    if let Some(url) = &a.artifacts {
        if !tonegate::history::is_store_url(url) {
            return Err(Error::Invalid(format!(
                "--artifacts {url:?}: an object store, s3://bucket/prefix"
            )));
        }
        tonegate::history::set_artifact_store(Some(url))?;
    }
    let alerts = a
        .alerts
        .as_deref()
        .map(tonegate::alerts::Alerts::load)
        .transpose()
        .map_err(Error::Invalid)?;
    let opts = ServeOptions {
        bind: a.bind,
        db: a.db.db.clone(),
        token,
        private_reads: a.private_reads,
        suite: a.suite.clone(),
        adapter: a.gpu.adapter(),
        gpu_config: a.gpu.config(),
        limits: Limits {
            max_body: a.max_body_mib << 20,
            max_pixels: a.max_pixels,
            queue: a.queue,
            timeout: std::time::Duration::from_secs(a.timeout),
            max_uploads: a.max_uploads,
            upload_budget: a.upload_budget_mib << 20,
            max_uploads_per_client: a.max_uploads_per_client,
            trusted_proxies: a.trusted_proxy.clone(),
            max_queued_jobs: a.max_queued_jobs,
        },
        conn: tonegate::server::listen::ConnLimits {
            max_connections: a.max_connections,
            header_timeout: std::time::Duration::from_secs(a.header_timeout),
            shutdown_grace: std::time::Duration::from_secs(a.shutdown_grace_s),
        },
        hold_workers: None,
        scoped,
        alerts,
    };
    // Colour only on a terminal, and never under NO_COLOR (no-color.org):
    // a redirected log gets plain text.
    let colour = {
        use std::io::IsTerminal;
        std::io::stderr().is_terminal() && std::env::var_os("NO_COLOR").is_none_or(|v| v.is_empty())
    };
    let _ = tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_ansi(colour)
        .with_max_level(tracing::Level::INFO)
        .try_init();
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .map_err(|source| Error::Service {
            what: "starting the async runtime".into(),
            source,
        })?;
    let served = rt.block_on(async move {
        let server = Server::bind(opts).await?;
        let addr = server.local_addr().map_err(|source| Error::Service {
            what: "reading the bound address".into(),
            source,
        })?;
        println!(
            "tonegate serving http://{addr}/  (history {}, token in {})",
            a.db.shown(),
            token_file.display()
        );
        if a.run_suite {
            let renderer = tonegate::render::Renderer::Gpu {
                adapter: a.gpu.adapter(),
                config: a.gpu.config(),
            };
            match tonegate::server::start_run(server.state(), renderer, None).await {
                Ok(id) => println!(
                    "running the suite {} as run {id}: http://{addr}/#/runs/{id}",
                    a.suite.display()
                ),
                Err(e) => eprintln!("error: the suite run could not start: {}", e.detail),
            }
        }
        let _ = std::io::stdout().flush();
        server
            .run(shutdown_signal())
            .await
            .map_err(|source| Error::Service {
                what: "serving".into(),
                source,
            })
    });
    // Blocking work still running (a judge, a tone map) does not hold the
    // process past the grace it had: the runtime is left, not waited for.
    rt.shutdown_timeout(std::time::Duration::from_millis(200));
    served?;
    Ok(ExitCode::SUCCESS)
}

async fn shutdown_signal() {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    // SIGTERM where there is one; elsewhere Ctrl-C alone.
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        _ = ctrl_c => {},
        _ = term => {},
    }
}
