//! Alerts (docs/alerts.md): `serve --alerts FILE` scans the history for
//! events — a gate red after green, new untriaged digests on the main line,
//! a change point in a performance series — and delivers each to the
//! webhooks that want it: JSON (or a Slack-compatible body), signed with
//! HMAC-SHA256, retried with back-off, every attempt logged in the history
//! and served at `GET /api/v1/alerts`. An event is stored once under its
//! key, so it fires once however often the history is scanned.

mod deliver;
mod scan;

pub use deliver::{body, signature};
pub use scan::scan;

use serde::Deserialize;
use std::path::Path;
use std::time::Duration;

/// What an alert is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Kind {
    /// A check run failed where the run before it (same suite, same
    /// adapter) passed.
    GateRed,
    /// A main-line submission brought digests nobody has triaged.
    Untriaged,
    /// A change point in a scene's FPS series.
    ChangePoint,
    /// A main-line submission brought back a digest someone marked
    /// negative (a known-wrong image came back).
    Negative,
    /// An ignore rule expires within `IGNORE_NOTICE` (three days): the
    /// failures it passes will fail again.
    IgnoreExpiring,
}

impl Kind {
    pub const ALL: [Kind; 5] = [
        Kind::GateRed,
        Kind::Untriaged,
        Kind::ChangePoint,
        Kind::Negative,
        Kind::IgnoreExpiring,
    ];

    pub fn as_str(self) -> &'static str {
        match self {
            Kind::GateRed => "gate_red",
            Kind::Untriaged => "untriaged",
            Kind::ChangePoint => "change_point",
            Kind::Negative => "negative",
            Kind::IgnoreExpiring => "ignore_expiring",
        }
    }
}

/// The body a webhook gets.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Format {
    /// The event as JSON (docs/alerts.md#body).
    #[default]
    Json,
    /// `{"text": …}` with the summary and links, as Slack's (and
    /// Mattermost's) incoming webhooks take.
    Slack,
}

/// One receiver.
#[derive(Clone, Debug)]
pub struct Webhook {
    pub name: String,
    pub url: String,
    pub format: Format,
    /// The HMAC-SHA256 key the body is signed with.
    pub secret: Vec<u8>,
    pub events: Vec<Kind>,
}

/// How failed deliveries are retried: the first retry after `first`, each
/// next after twice the last (at most an hour), `most_attempts` in all.
#[derive(Clone, Copy, Debug)]
pub struct Retry {
    pub first: Duration,
    pub most_attempts: u32,
}

impl Retry {
    /// The wait after attempt `n` (1 is the first) failed.
    pub fn after(&self, n: u32) -> Duration {
        let doubled = self
            .first
            .checked_mul(1u32 << n.saturating_sub(1).min(20))
            .unwrap_or(Duration::MAX);
        doubled.min(Duration::from_secs(3600))
    }
}

/// The alerts file, checked.
#[derive(Clone, Debug)]
pub struct Alerts {
    /// Where the links in alerts point: the server as its users reach it.
    pub public_url: String,
    /// How often the history is scanned for events.
    pub scan_every: Duration,
    pub retry: Retry,
    /// Each request's limit, connecting included.
    pub timeout: Duration,
    pub webhooks: Vec<Webhook>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    public_url: String,
    #[serde(default = "scan_seconds")]
    scan_seconds: f64,
    #[serde(default = "timeout_seconds")]
    timeout_seconds: f64,
    #[serde(default)]
    retry: RetryFile,
    #[serde(default)]
    webhook: Vec<WebhookFile>,
}

fn scan_seconds() -> f64 {
    10.0
}

fn timeout_seconds() -> f64 {
    10.0
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RetryFile {
    #[serde(default = "first_seconds")]
    first_seconds: f64,
    #[serde(default = "most_attempts")]
    most_attempts: u32,
}

fn first_seconds() -> f64 {
    5.0
}

fn most_attempts() -> u32 {
    8
}

impl Default for RetryFile {
    fn default() -> Self {
        RetryFile {
            first_seconds: first_seconds(),
            most_attempts: most_attempts(),
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct WebhookFile {
    name: String,
    url: String,
    #[serde(default)]
    format: Format,
    secret_file: String,
    #[serde(default)]
    events: Option<Vec<Kind>>,
}

fn seconds(v: f64, key: &str, low: f64, high: f64) -> Result<Duration, String> {
    if !(v.is_finite() && v >= low && v <= high) {
        return Err(format!("{key} = {v}: from {low} to {high} seconds"));
    }
    Ok(Duration::from_secs_f64(v))
}

impl Alerts {
    /// Reads and checks an alerts file; errors name the file and the key.
    /// A webhook's `secret_file` is read relative to the alerts file.
    pub fn load(path: &Path) -> Result<Alerts, String> {
        let at = |e: String| format!("{}: {e}", path.display());
        let text = crate::io::read_small_text(path)
            .map_err(|e| format!("reading {}: {e}", path.display()))?;
        let f: File = toml::from_str(&text).map_err(|e| at(crate::io::toml_error(&text, &e)))?;
        // A key's line, for the checks after parsing: `key = …` at the top
        // level or in `[retry]`, and the `n`-th `[[webhook]]` table.
        let key_line = |key: &str| -> String {
            text.lines()
                .position(|l| {
                    l.trim_start()
                        .strip_prefix(key)
                        .is_some_and(|r| r.trim_start().starts_with('='))
                })
                .map_or(String::new(), |i| format!("line {}: ", i + 1))
        };
        let webhook_line = |n: usize| -> String {
            crate::io::nth_line_starting(&text, "[[webhook]]", n)
                .map_or(String::new(), |l| format!("line {l}: "))
        };
        let url_ok = |u: &str| u.starts_with("http://") || u.starts_with("https://");
        if !url_ok(&f.public_url) {
            return Err(at(format!(
                "{}public_url {:?}: an http:// or https:// address",
                key_line("public_url"),
                f.public_url
            )));
        }
        if !(1..=30).contains(&f.retry.most_attempts) {
            return Err(at(format!(
                "{}retry.most_attempts = {}: from 1 to 30",
                key_line("most_attempts"),
                f.retry.most_attempts
            )));
        }
        let mut webhooks: Vec<Webhook> = Vec::new();
        for (i, w) in f.webhook.into_iter().enumerate() {
            let here = format!("{}webhook[{i}] ({:?})", webhook_line(i), w.name);
            let plain = |c: char| c.is_ascii_alphanumeric() || "_-.".contains(c);
            if w.name.is_empty() || w.name.len() > 64 || !w.name.chars().all(plain) {
                return Err(at(format!(
                    "{here}: a name is 1 to 64 letters, digits, '_', '-' or '.'"
                )));
            }
            if webhooks.iter().any(|o| o.name == w.name) {
                return Err(at(format!("{here}: two webhooks with this name")));
            }
            if !url_ok(&w.url) || w.url.parse::<webhook_http::Url>().is_err() {
                return Err(at(format!("{here}: url {:?} is not an http(s) URL", w.url)));
            }
            let secret_path = path.parent().unwrap_or(Path::new(".")).join(&w.secret_file);
            let secret = crate::io::read_small(&secret_path).map_err(|e| {
                at(format!(
                    "{here}: secret_file {}: {e}",
                    secret_path.display()
                ))
            })?;
            let secret = secret.trim_ascii().to_vec();
            if secret.len() < 16 {
                return Err(at(format!(
                    "{here}: secret_file {} holds under 16 bytes: use a long random secret",
                    secret_path.display()
                )));
            }
            let events = w.events.unwrap_or_else(|| Kind::ALL.to_vec());
            if events.is_empty() {
                return Err(at(format!("{here}: events is empty")));
            }
            webhooks.push(Webhook {
                name: w.name,
                url: w.url,
                format: w.format,
                secret,
                events,
            });
        }
        Ok(Alerts {
            public_url: f.public_url.trim_end_matches('/').to_owned(),
            scan_every: seconds(f.scan_seconds, "scan_seconds", 0.1, 86400.0)
                .map_err(|e| at(key_line("scan_seconds") + &e))?,
            timeout: seconds(f.timeout_seconds, "timeout_seconds", 0.1, 300.0)
                .map_err(|e| at(key_line("timeout_seconds") + &e))?,
            retry: Retry {
                first: seconds(f.retry.first_seconds, "retry.first_seconds", 0.01, 3600.0)
                    .map_err(|e| at(key_line("first_seconds") + &e))?,
                most_attempts: f.retry.most_attempts,
            },
            webhooks,
        })
    }

    /// The webhooks that want `kind`.
    pub fn wanting(&self, kind: Kind) -> Vec<&str> {
        self.webhooks
            .iter()
            .filter(|w| w.events.contains(&kind))
            .map(|w| w.name.as_str())
            .collect()
    }
}

/// Scans and delivers until the server stops: the history is scanned
/// every `scan_every`, and due deliveries are claimed every quarter second
/// and sent in tasks of their own, a few at a time per webhook, so that a
/// receiver that never answers delays no other webhook.
pub async fn run(
    db: std::path::PathBuf,
    alerts: Alerts,
    mut stop: tokio::sync::watch::Receiver<bool>,
) {
    let alerts = std::sync::Arc::new(alerts);
    let client = match webhook_http::Client::builder()
        .timeout(alerts.timeout)
        .redirect(webhook_http::redirect::Policy::none())
        .user_agent(concat!("tonegate/", env!("CARGO_PKG_VERSION")))
        .build()
    {
        Ok(c) => c,
        Err(e) => {
            tracing::error!("alerts: no HTTP client: {e}; no alerts are delivered");
            return;
        }
    };
    let kept = Kept {
        db,
        open: Default::default(),
    };
    let mut last_scan: Option<std::time::Instant> = None;
    let in_flight = deliver::InFlight::default();
    let mut tasks = tokio::task::JoinSet::new();
    loop {
        if last_scan.is_none_or(|t| t.elapsed() >= alerts.scan_every) {
            last_scan = Some(std::time::Instant::now());
            let a = alerts.clone();
            match kept.run(move |h| scan(h, &a)).await {
                Ok(n) if n > 0 => tracing::info!("alerts: {n} new events"),
                Ok(_) => {}
                Err(e) => tracing::warn!("alerts: scanning the history: {e}"),
            }
        }
        if let Err(e) = deliver::due(&kept, &alerts, &client, &in_flight, &mut tasks).await {
            tracing::warn!("alerts: delivering: {e}");
        }
        // Finished deliveries leave the set; their outcomes are recorded.
        while tasks.try_join_next().is_some() {}
        tokio::select! {
            _ = tokio::time::sleep(Duration::from_millis(250)) => {}
            _ = stop.changed() => return,
        }
        if *stop.borrow() {
            // Deliveries in flight end with the server; their claims run
            // out and they are sent again, by this server or another.
            tasks.abort_all();
            return;
        }
    }
}

/// The history alerts work on, opened once and kept between the scans and
/// the four looks a second for due deliveries (a PostgreSQL history would
/// otherwise be connected to each time), and opened again after an error.
#[derive(Clone)]
struct Kept {
    db: std::path::PathBuf,
    open: std::sync::Arc<std::sync::Mutex<Option<crate::history::History>>>,
}

impl Kept {
    async fn run<T: Send + 'static>(
        &self,
        f: impl FnOnce(&crate::history::History) -> Result<T, crate::history::HistoryError>
            + Send
            + 'static,
    ) -> Result<T, crate::history::HistoryError> {
        let (db, open) = (self.db.clone(), self.open.clone());
        tokio::task::spawn_blocking(move || {
            let mut slot = open.lock().unwrap_or_else(|p| p.into_inner());
            let h = match slot.take() {
                Some(h) => h,
                None => crate::history::History::open(&db)?,
            };
            let out = f(&h);
            if out.is_ok() {
                *slot = Some(h);
            }
            out
        })
        .await
        .map_err(|e| crate::history::HistoryError::Invalid(format!("the history's thread: {e}")))?
    }
}

#[cfg(test)]
mod tests {
    use super::Alerts;

    /// Every error of an alerts file names its line: TOML's own, a value
    /// out of range and a webhook's problem alike.
    #[test]
    fn an_alerts_files_errors_name_their_line() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("s.secret"), "0123456789abcdef0123\n").unwrap();
        let file = dir.path().join("alerts.toml");
        let hook = "[[webhook]]\nname = \"team\"\nurl = \"http://127.0.0.1:9/h\"\nsecret_file = \"s.secret\"\n";
        let cases = [
            (
                format!("public_url = \"http://x\"\nscan_seconds = 0.2\nbogus = 1\n{hook}"),
                "line 3",
                "bogus",
            ),
            (
                format!("public_url = \"http://x\"\ntimeout_seconds = 1000\n{hook}"),
                "line 2",
                "timeout_seconds",
            ),
            (
                format!(
                    "public_url = \"http://x\"\n{hook}{}",
                    hook.replace("http://127.0.0.1:9/h", "ftp://h")
                ),
                "line 6",
                "webhook[1]",
            ),
        ];
        for (text, line, says) in cases {
            std::fs::write(&file, &text).unwrap();
            let e = Alerts::load(&file).unwrap_err();
            assert!(e.contains(line) && e.contains(says), "{says}: {e}");
        }
    }
}
