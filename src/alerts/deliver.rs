//! Sending due deliveries: the body (JSON, or Slack's `text`), signed
//! with HMAC-SHA256 of the body under the webhook's secret, every attempt
//! recorded; a refusal or an unreachable receiver is tried again after the
//! back-off, until the attempts run out.

use super::{Alerts, Format, Webhook};
use crate::history::{Attempted, DueDelivery, HistoryError};
use hmac::{Hmac, Mac};
use sha2::Sha256;
use std::time::Duration;

/// `sha256=<hex>`: the HMAC-SHA256 of `body` under `secret`, as the
/// `X-Tonegate-Signature-256` header carries it.
pub fn signature(secret: &[u8], body: &[u8]) -> String {
    // HMAC takes a key of any length.
    let mut mac = <Hmac<Sha256> as Mac>::new_from_slice(secret).expect("any key length");
    mac.update(body);
    format!("sha256={}", hex::encode(mac.finalize().into_bytes()))
}

/// The body a delivery sends.
pub fn body(format: Format, event_id: i64, key: &str, summary: &str, event: &str) -> String {
    let event: serde_json::Value = serde_json::from_str(event).unwrap_or_default();
    match format {
        Format::Json => serde_json::json!({"id": event_id, "key": key, "event": event}).to_string(),
        Format::Slack => {
            let mut text = summary.to_owned();
            if let Some(links) = event.get("links").and_then(|l| l.get("first_bad")) {
                if let Some(d) = links.get("dashboard").and_then(|d| d.as_str()) {
                    text.push_str(&format!("\n<{d}|first bad>"));
                }
            }
            if let Some(c) = event.get("commits") {
                let word = |k: &str| c.get(k).and_then(|v| v.as_str()).unwrap_or("?").to_owned();
                text.push_str(&format!(
                    "\ncommits {}..{}",
                    word("last_good"),
                    word("first_bad")
                ));
            }
            serde_json::json!({"text": text}).to_string()
        }
    }
}

/// How many due deliveries one look claims.
const CLAIMED: usize = 32;

/// How many deliveries to one webhook are in flight at once. Each webhook
/// has its own: a receiver that never answers holds only its own.
pub(super) const PER_WEBHOOK: usize = 4;

/// The deliveries in flight, by webhook: what keeps one receiver from
/// stalling the others.
#[derive(Clone, Default)]
pub(super) struct InFlight {
    per_webhook: std::sync::Arc<
        std::sync::Mutex<std::collections::HashMap<String, std::sync::Arc<tokio::sync::Semaphore>>>,
    >,
    /// The deliveries sent or waiting to be, by id: a claim that runs out
    /// while one waits behind a slow receiver finds it here instead of
    /// sending it twice.
    ids: std::sync::Arc<std::sync::Mutex<std::collections::HashSet<i64>>>,
}

impl InFlight {
    /// Marks `id` in flight; false when it already was.
    fn start(&self, id: i64) -> bool {
        self.ids
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .insert(id)
    }

    fn end(&self, id: i64) {
        self.ids
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .remove(&id);
    }

    fn permits(&self, webhook: &str) -> std::sync::Arc<tokio::sync::Semaphore> {
        let mut map = self.per_webhook.lock().unwrap_or_else(|p| p.into_inner());
        map.entry(webhook.to_owned())
            .or_insert_with(|| std::sync::Arc::new(tokio::sync::Semaphore::new(PER_WEBHOOK)))
            .clone()
    }
}

/// Claims every delivery due now and sends each in a task of its own, at
/// most [`PER_WEBHOOK`] at a time to one webhook; returns without waiting
/// for them, so the next look for due deliveries (and their webhooks) is
/// not held up by a slow receiver. A claim is held past one request's
/// limit, so no other server, and no later look here, takes it meanwhile.
pub(super) async fn due(
    db: &super::Kept,
    alerts: &std::sync::Arc<Alerts>,
    client: &webhook_http::Client,
    in_flight: &InFlight,
    tasks: &mut tokio::task::JoinSet<()>,
) -> Result<(), HistoryError> {
    // Long enough for a whole claim to wait its turn behind one slow
    // receiver.
    let hold = alerts.timeout * (1 + CLAIMED / PER_WEBHOOK) as u32 + Duration::from_secs(30);
    let due = db
        .run(move |h| h.claim_due_deliveries(hold, CLAIMED as u32))
        .await?;
    for d in due {
        if !in_flight.start(d.id) {
            continue;
        }
        let permits = in_flight.permits(&d.webhook);
        let (db, alerts, client) = (db.clone(), alerts.clone(), client.clone());
        let in_flight = in_flight.clone();
        tasks.spawn(async move {
            let id = d.id;
            if let Ok(_permit) = permits.acquire_owned().await {
                if let Err(e) = attempt(&db, &alerts, &client, d).await {
                    tracing::warn!("alerts: recording a delivery: {e}");
                }
            }
            in_flight.end(id);
        });
    }
    Ok(())
}

/// Sends one delivery and records the attempt.
async fn attempt(
    db: &super::Kept,
    alerts: &Alerts,
    client: &webhook_http::Client,
    d: DueDelivery,
) -> Result<(), HistoryError> {
    let outcome = send(alerts, client, &d).await;
    let id = d.id;
    match outcome {
        Ok(status) => {
            db.run(move |h| h.record_attempt(id, Attempted::Delivered(status)))
                .await
        }
        Err((status, error)) => {
            let n = u32::try_from(d.attempts + 1).unwrap_or(u32::MAX);
            let next_at = (n < alerts.retry.most_attempts).then(|| {
                let at = chrono::Utc::now()
                    + chrono::Duration::from_std(alerts.retry.after(n)).unwrap_or_default();
                at.to_rfc3339_opts(chrono::SecondsFormat::Millis, true)
            });
            tracing::warn!("alerts: {} to {} (attempt {n}): {error}", d.key, d.webhook);
            db.run(move |h| {
                h.record_attempt(
                    id,
                    Attempted::Failed {
                        status,
                        error: &error,
                        next_at,
                    },
                )
            })
            .await
        }
    }
}

async fn send(
    alerts: &Alerts,
    client: &webhook_http::Client,
    d: &DueDelivery,
) -> Result<i64, (Option<i64>, String)> {
    let Some(w): Option<&Webhook> = alerts.webhooks.iter().find(|w| w.name == d.webhook) else {
        return Err((
            None,
            format!("no webhook {:?} in the alerts file now", d.webhook),
        ));
    };
    let text = body(w.format, d.event_id, &d.key, &d.summary, &d.payload);
    let answer = client
        .post(&w.url)
        .header("content-type", "application/json")
        .header("x-tonegate-event", d.event_id.to_string())
        .header("x-tonegate-event-kind", &d.kind)
        .header(
            "x-tonegate-delivery",
            format!("{}-{}", d.id, d.attempts + 1),
        )
        .header(
            "x-tonegate-signature-256",
            signature(&w.secret, text.as_bytes()),
        )
        .body(text)
        .send()
        .await
        .map_err(|e| {
            let why = if e.is_timeout() {
                format!(
                    "timed out: no answer within {} s (timeout_seconds)",
                    alerts.timeout.as_secs_f64()
                )
            } else {
                format!("not reached: {e}")
            };
            (None, why)
        })?;
    let status = answer.status();
    if status.is_success() {
        Ok(i64::from(status.as_u16()))
    } else {
        Err((
            Some(i64::from(status.as_u16())),
            format!("answered {status}"),
        ))
    }
}
