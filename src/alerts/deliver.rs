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

/// Sends every delivery due now, one after another.
pub(super) async fn due(
    db: &super::Kept,
    alerts: &Alerts,
    client: &webhook_http::Client,
) -> Result<(), HistoryError> {
    // Held past one request's limit, so no other server takes it meanwhile.
    let hold = alerts.timeout + Duration::from_secs(30);
    let due = db.run(move |h| h.claim_due_deliveries(hold, 32)).await?;
    for d in due {
        let outcome = send(alerts, client, &d).await;
        let id = d.id;
        let recorded = match outcome {
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
        };
        recorded?;
    }
    Ok(())
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
        .map_err(|e| (None, format!("not reached: {e}")))?;
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
