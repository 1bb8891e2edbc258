//! `tonegate serve`: the HTTP API under `/api/v1`, Prometheus metrics at
//! `/metrics`, the OpenAPI document at `/api/v1/openapi.json` and the
//! embedded dashboard at `/` (static files compiled into the binary; no CDN).
//!
//! Reads are open unless `private_reads`; everything that changes state
//! needs a bearer token: the server's for `POST /runs`, the submit scope's
//! (or the server's) for submitting frames, the triage scope's (or the
//! server's) for triaging them. `POST /tonemap` changes nothing stored: it
//! is open like a read, and bounded by its queues instead.

mod alerts;
mod artifacts;
mod assets;
mod auth;
mod edge;
pub mod error;
mod fleet;
mod frames;
mod health;
pub mod listen;
mod matrix;
pub mod params;
mod prom;
pub mod queue;
pub mod runs;
pub(crate) mod tonemap;
mod trends;
pub mod uploads;

use crate::gpu::{AdapterChoice, GpuConfig};
use crate::render::Renderer;
use axum::http::StatusCode;
use axum::routing::{get, post};
use axum::Router;
use error::ApiError;
use queue::Queue;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::{Arc, Mutex, RwLock};
use std::time::Duration;
use utoipa::OpenApi;

/// Request limits of `POST /tonemap`.
#[derive(Clone, Debug)]
pub struct Limits {
    /// Largest body, in bytes.
    pub max_body: usize,
    /// Largest image, in pixels, checked from the file's header before decoding.
    pub max_pixels: u64,
    /// Jobs that may wait per queue (GPU, CPU) besides the running one.
    pub queue: usize,
    /// Whole-request limit: upload, waiting and rendering.
    pub timeout: Duration,
    /// Bodies received at once, and the bytes they may hold together
    /// (`uploads`): apart from the queues, which take a body once it is in.
    pub max_uploads: usize,
    pub upload_budget: usize,
    /// Of those, the uploads one client may have open (and that share of
    /// the bytes): a client is its peer address, or for a trusted proxy the
    /// address it forwarded for (`trusted_proxies`).
    pub max_uploads_per_client: usize,
    /// Peers whose `X-Forwarded-For` names the client (a load balancer in
    /// front of the server); any other peer is the client itself.
    pub trusted_proxies: Vec<std::net::IpAddr>,
    /// A fleet's queue: jobs that may wait before `POST /runs` answers 503.
    pub max_queued_jobs: u64,
}

impl Default for Limits {
    fn default() -> Self {
        // Sized for a 2 GiB container (README, "Memory"): two jobs of 8 Mi
        // pixels (4K UHD) running, one per queue, one 128 MiB body waiting
        // in each, and 128 MiB of bodies being received.
        Limits {
            max_body: 128 << 20,
            max_pixels: crate::request::MAX_UPLOAD_PIXELS,
            queue: 1,
            timeout: Duration::from_secs(60),
            max_uploads: 256,
            upload_budget: 128 << 20,
            max_uploads_per_client: 32,
            trusted_proxies: Vec::new(),
            max_queued_jobs: crate::history::MAX_QUEUED_JOBS,
        }
    }
}

#[derive(Clone, Debug)]
pub struct ServeOptions {
    pub bind: SocketAddr,
    pub db: PathBuf,
    /// The bearer token state-changing requests must carry.
    pub token: String,
    /// Require the token for reads too.
    pub private_reads: bool,
    /// The suite `POST /runs` runs.
    pub suite: PathBuf,
    pub adapter: AdapterChoice,
    pub gpu_config: GpuConfig,
    pub limits: Limits,
    pub conn: listen::ConnLimits,
    /// Tests only: the tone-map workers read-lock this around every job.
    pub hold_workers: Option<Arc<RwLock<()>>>,
    /// The tokens that may only submit frames, or only triage them.
    pub scoped: ScopedTokens,
    /// Alerts to scan for and deliver (`--alerts FILE`).
    pub alerts: Option<crate::alerts::Alerts>,
}

pub use auth::{load_or_make_token, Scope, ScopedTokens, MIN_TOKEN_CHARS};

/// The one suite run the server lets go at a time.
pub enum RunSlot {
    Idle,
    Starting,
    Running(i64),
}

pub struct AppState {
    pub db: PathBuf,
    token: String,
    scoped: ScopedTokens,
    private_reads: bool,
    pub suite: PathBuf,
    pub adapter: AdapterChoice,
    pub gpu_config: GpuConfig,
    pub limits: Limits,
    pub gpu: Queue,
    pub cpu: Queue,
    pub uploads: Arc<uploads::Uploads>,
    pub slot: Mutex<RunSlot>,
    pub(crate) requests: prom::Requests,
    /// Set when the server starts stopping: body reads in progress give up.
    pub closing: tokio::sync::watch::Sender<bool>,
}

impl AppState {
    /// Why runs cannot be recorded now, if they cannot (a read-only history
    /// file or folder); checked when asked, since permissions can change.
    pub async fn history_problem(&self) -> Option<String> {
        let db = self.db.clone();
        tokio::task::spawn_blocking(move || crate::history::write_problem(&db))
            .await
            .unwrap_or_else(|e| Some(format!("checking the history: {e}")))
    }
}

/// Starts a check run of the server's suite on a blocking thread; answers
/// with its id once the history has it, 409 when one is already going.
pub async fn start_run(
    st: Arc<AppState>,
    renderer: crate::render::Renderer,
    spp: Option<u32>,
) -> Result<i64, ApiError> {
    {
        let mut slot = st.slot.lock().unwrap_or_else(|p| p.into_inner());
        match *slot {
            RunSlot::Idle => *slot = RunSlot::Starting,
            RunSlot::Starting => {
                return Err(ApiError::new(
                    StatusCode::CONFLICT,
                    "conflict",
                    "a run is starting",
                ))
            }
            RunSlot::Running(id) => {
                return Err(ApiError::new(
                    StatusCode::CONFLICT,
                    "conflict",
                    format!("run {id} is going; one run at a time (GET /api/v1/runs/{id})"),
                ))
            }
        }
    }
    let (tx, rx) = std::sync::mpsc::channel();
    let opts = crate::gate::CheckOptions {
        suite: st.suite.clone(),
        renderer,
        spp,
        artifacts: None,
        db: Some(st.db.clone()),
        started: Some(tx),
        scenes: Vec::new(),
        metrics: crate::gate::MetricsOn::Auto,
    };
    let state = st.clone();
    std::thread::Builder::new()
        .name("suite-run".into())
        .spawn(move || {
            let outcome = crate::gate::run(&opts, &crate::progress::Silent);
            if let crate::gate::CheckOutcome::Error(e, id) = &outcome {
                tracing::warn!("run {id:?} could not happen: {e}");
            }
            *state.slot.lock().unwrap_or_else(|p| p.into_inner()) = RunSlot::Idle;
        })
        .map_err(|e| ApiError::internal(e.to_string()))?;
    let got = tokio::task::spawn_blocking(move || rx.recv_timeout(Duration::from_secs(60)))
        .await
        .map_err(|e| ApiError::internal(e.to_string()))?;
    match got {
        Ok(id) => {
            let mut slot = st.slot.lock().unwrap_or_else(|p| p.into_inner());
            if matches!(*slot, RunSlot::Starting) {
                *slot = RunSlot::Running(id);
            }
            Ok(id)
        }
        Err(_) => Err(ApiError::internal(
            "the run could not start (the history could not be opened or written); see the server log",
        )),
    }
}

#[derive(OpenApi)]
#[openapi(
    info(title = "tonegate", description = "HDR tone-mapper validation: runs, metrics, trends, tradeoffs, tone-mapping."),
    paths(
        runs::list_runs, runs::get_run, runs::post_run, artifacts::get_artifact, trends::trends,
        trends::tradeoff, health::healthz, tonemap::sample, tonemap::tonemap, tonemap::operators, fleet::queue,
        fleet::runners, matrix::matrix, frames::submit, frames::list, frames::get, frames::digests,
        frames::log, frames::triage, frames::bulk, frames::promote, frames::ignore, frames::ignores,
        frames::image, frames::compare, alerts::alerts
    ),
    components(schemas(error::ErrorBody)),
    modifiers(&BearerAuth, &OperatorParams)
)]
pub struct ApiDoc;

use tonemap::OperatorParams;

struct BearerAuth;

impl utoipa::Modify for BearerAuth {
    fn modify(&self, doc: &mut utoipa::openapi::OpenApi) {
        use utoipa::openapi::security::{Http, HttpAuthScheme, SecurityScheme};
        if let Some(c) = doc.components.as_mut() {
            c.add_security_scheme(
                "bearer",
                SecurityScheme::Http(Http::new(HttpAuthScheme::Bearer)),
            );
        }
    }
}

async fn openapi() -> axum::response::Response {
    use axum::response::IntoResponse;
    let mut doc = ApiDoc::openapi();
    tonemap::describe_operators(&mut doc);
    axum::Json(doc).into_response()
}

/// The whole application.
pub fn router(st: Arc<AppState>) -> Router {
    let api = Router::new()
        .route("/runs", get(runs::list_runs).post(runs::post_run))
        .route("/runs/{id}", get(runs::get_run))
        .route("/runs/{id}/artifacts/{name}", get(artifacts::get_artifact))
        .route("/trends", get(trends::trends))
        .route("/matrix", get(matrix::matrix))
        .route("/queue", get(fleet::queue))
        .route("/runners", get(fleet::runners))
        .route("/tradeoff/{run}", get(trends::tradeoff))
        .route("/healthz", get(health::healthz))
        .route("/samples/{name}", get(tonemap::sample))
        .route("/operators", get(tonemap::operators))
        .route("/openapi.json", get(openapi))
        .route(
            "/frames/submissions",
            get(frames::list)
                .post(frames::submit)
                // The handler reads the form itself against this limit.
                .layer(axum::extract::DefaultBodyLimit::max(st.limits.max_body)),
        )
        .route("/frames/submissions/{id}", get(frames::get))
        .route("/frames/submissions/{id}/triage", post(frames::bulk))
        .route("/frames/digests", get(frames::digests))
        .route("/frames/log", get(frames::log))
        .route("/frames/triage", post(frames::triage))
        .route("/frames/promote", post(frames::promote))
        .route("/frames/ignore", post(frames::ignore))
        .route("/frames/ignores", get(frames::ignores))
        .route("/frames/images/{digest}", get(frames::image))
        .route("/frames/compare/{digest}/{against}", get(frames::compare))
        .route("/alerts", get(alerts::alerts))
        .route(
            "/tonemap",
            post(tonemap::tonemap)
                // The handler reads the body itself against this limit.
                .layer(axum::extract::DefaultBodyLimit::max(st.limits.max_body)),
        )
        .fallback(edge::not_found)
        .method_not_allowed_fallback(edge::method_not_allowed);
    Router::new()
        .nest("/api/v1", api)
        .route("/metrics", get(prom::metrics))
        .route("/healthz", get(health::healthz))
        .merge(assets::routes())
        .fallback(edge::not_found)
        .method_not_allowed_fallback(edge::method_not_allowed)
        .layer(axum::middleware::from_fn(edge::head_limits))
        .layer(axum::middleware::from_fn_with_state(
            st.clone(),
            prom::track,
        ))
        .with_state(st)
}

/// A bound server, ready to run.
pub struct Server {
    listener: tokio::net::TcpListener,
    state: Arc<AppState>,
    conn: listen::ConnLimits,
    alerts: Option<crate::alerts::Alerts>,
}

/// Opens (and migrates) the history the server records runs in. A history
/// that exists but cannot be written is served read-only (a copied history,
/// a read-only mount): reads work, runs are refused with the reason, and
/// healthz says so. One that cannot be created, or read, stops the server
/// here with its path.
fn check_history(db: &std::path::Path) -> Result<(), crate::Error> {
    if let Err(e) = crate::history::History::open(db) {
        let problem = db
            .exists()
            .then(|| crate::history::write_problem(db))
            .flatten();
        let Some(problem) = problem else {
            return Err(e.into());
        };
        crate::history::History::open_read_only(db)?;
        tracing::warn!("{problem}; serving it read-only, runs are refused");
    } else if let Some(problem) = crate::history::write_problem(db) {
        tracing::warn!("{problem}; runs are refused until it is writable");
    }
    Ok(())
}

impl Server {
    /// Opens (and migrates) the history, starts the tone-map workers and
    /// binds the address; port 0 picks a free port (see `local_addr`).
    pub async fn bind(opts: ServeOptions) -> Result<Server, crate::Error> {
        // A history that exists but cannot be written is served read-only
        // (a copied history, a read-only mount): reads work, runs are
        // refused with the reason, and healthz says so. One that cannot be
        // created, or read, stops the server here with its path.
        // Off the async threads: a PostgreSQL history is reached through a
        // blocking client.
        let db = opts.db.clone();
        tokio::task::spawn_blocking(move || check_history(&db))
            .await
            .map_err(|e| crate::Error::Invalid(format!("opening the history: {e}")))??;
        let file = |source| crate::Error::Service {
            what: "starting a tone-map worker".into(),
            source,
        };
        let gpu = Queue::start(
            "gpu",
            opts.limits.queue,
            Renderer::Gpu {
                adapter: opts.adapter.clone(),
                config: opts.gpu_config,
            },
            opts.hold_workers.clone(),
        )
        .map_err(file)?;
        let cpu = Queue::start(
            "cpu",
            opts.limits.queue,
            Renderer::Cpu,
            opts.hold_workers.clone(),
        )
        .map_err(file)?;
        let listener = tokio::net::TcpListener::bind(opts.bind)
            .await
            .map_err(|source| crate::Error::Service {
                what: format!("binding {}", opts.bind),
                source,
            })?;
        // Refuse at start a file limit that leaves no room for clients.
        listen::connection_cap(opts.conn.max_connections, listen::open_file_limit())
            .map_err(crate::Error::Invalid)?;
        Ok(Server {
            listener,
            conn: opts.conn,
            alerts: opts.alerts,
            state: Arc::new(AppState {
                db: opts.db,
                token: opts.token,
                scoped: opts.scoped,
                private_reads: opts.private_reads,
                suite: opts.suite,
                adapter: opts.adapter,
                gpu_config: opts.gpu_config,
                uploads: uploads::Uploads::with_share(
                    opts.limits.max_uploads,
                    opts.limits.upload_budget,
                    opts.limits.max_uploads_per_client,
                ),
                limits: opts.limits,
                gpu,
                cpu,
                slot: Mutex::new(RunSlot::Idle),
                requests: Default::default(),
                closing: tokio::sync::watch::Sender::new(false),
            }),
        })
    }

    pub fn local_addr(&self) -> std::io::Result<SocketAddr> {
        self.listener.local_addr()
    }

    pub fn state(&self) -> Arc<AppState> {
        self.state.clone()
    }

    /// Serves until `shutdown` resolves, then lets answers in flight finish.
    pub async fn run(
        self,
        shutdown: impl std::future::Future<Output = ()> + Send + 'static,
    ) -> std::io::Result<()> {
        let app = router(self.state.clone());
        let st = self.state.clone();
        if let Some(alerts) = self.alerts {
            tokio::spawn(crate::alerts::run(
                st.db.clone(),
                alerts,
                st.closing.subscribe(),
            ));
        }
        let served = listen::serve(self.listener, app, self.state, &self.conn, shutdown).await;
        // A suite run of this server's that is still going ends with it:
        // marked aborted now rather than found `running` by the next start.
        let running = match *st.slot.lock().unwrap_or_else(|p| p.into_inner()) {
            RunSlot::Running(id) => Some(id),
            _ => None,
        };
        if let Some(id) = running {
            let db = st.db.clone();
            let marked = tokio::task::spawn_blocking(move || {
                crate::history::History::open(&db).and_then(|h| {
                    h.abort_run(
                        id,
                        "the server stopped (SIGTERM or Ctrl-C) before the run finished",
                    )
                })
            })
            .await;
            match marked {
                Ok(Ok(_)) => tracing::info!("run {id} marked aborted: the server stopped"),
                Ok(Err(e)) => tracing::warn!("run {id} could not be marked aborted: {e}"),
                Err(e) => tracing::warn!("run {id} could not be marked aborted: {e}"),
            }
        }
        served
    }
}
