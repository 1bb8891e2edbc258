//! Finding events in the history. Each has a key that names what it is
//! about (`gate_red:<run>`, `untriaged:<submission>`, `negative:<submission>`,
//! `change_point:fps:<scene>:<adapter>:<run>`), and the history stores an
//! event once per key: a scan may see the same run again, and several
//! servers may scan one history, and still each fires once. Only what was
//! recorded after alerts were first scanned for raises one.

use super::{Alerts, Kind};
use crate::history::{History, HistoryError, RunBrief, TrendFilter};
use serde_json::{json, Value};

/// How many of the newest runs and submissions a scan reads.
const WINDOW: u32 = 500;

/// Raises the events the history holds that were not raised yet; returns
/// how many were new.
pub fn scan(h: &History, alerts: &Alerts) -> Result<usize, HistoryError> {
    let (runs_now, submissions_now) = h.alert_starts()?;
    let since_run = h.alert_mark("runs", runs_now)?;
    let since_submission = h.alert_mark("submissions", submissions_now)?;
    let mut events = Vec::new();
    gate_red(h, alerts, since_run, &mut events)?;
    submissions(h, alerts, since_submission, &mut events)?;
    expiring(h, alerts, &mut events)?;
    change_points(h, alerts, since_run, &mut events)?;
    let mut raised = 0;
    for (kind, key, summary, event) in events {
        let wanting = alerts.wanting(kind);
        if h.raise_alert(&key, kind.as_str(), &summary, &event.to_string(), &wanting)?
            .is_some()
        {
            raised += 1;
        }
    }
    Ok(raised)
}

type Event = (Kind, String, String, Value);

fn run_links(alerts: &Alerts, id: i64) -> Value {
    json!({
        "dashboard": format!("{}/#/runs/{id}", alerts.public_url),
        "api": format!("{}/api/v1/runs/{id}", alerts.public_url),
    })
}

fn short(commit: Option<&str>) -> &str {
    commit.map_or("?", |c| &c[..c.len().min(10)])
}

fn gate_red(
    h: &History,
    alerts: &Alerts,
    since: i64,
    out: &mut Vec<Event>,
) -> Result<(), HistoryError> {
    for run in h.finished_runs_since(since, WINDOW)? {
        if run.status != "failed" {
            continue;
        }
        let Some(good) = h.previous_finished_run(&run)? else {
            continue;
        };
        if good.status != "passed" {
            continue;
        }
        let summary = format!(
            "tonegate: the gate went red at run {} ({}) on {}; run {} ({}) passed",
            run.id,
            short(run.git_commit.as_deref()),
            run.adapter.as_deref().unwrap_or("?"),
            good.id,
            short(good.git_commit.as_deref()),
        );
        let event = json!({
            "kind": "gate_red",
            "summary": summary,
            "suite": run.suite,
            "adapter": run.adapter,
            "commits": {"last_good": good.git_commit, "first_bad": run.git_commit},
            "runs": {"last_good": good.id, "first_bad": run.id},
            "links": {"last_good": run_links(alerts, good.id), "first_bad": run_links(alerts, run.id)},
        });
        out.push((
            Kind::GateRed,
            format!("gate_red:{}", run.id),
            summary,
            event,
        ));
    }
    Ok(())
}

fn commit_of(keys: &str) -> Option<String> {
    serde_json::from_str::<serde_json::Map<String, Value>>(keys)
        .ok()?
        .get("commit")?
        .as_str()
        .map(str::to_owned)
}

/// Each main-line submission's frames events: digests nobody has triaged
/// that no earlier submission of their test had (`untriaged`), and digests
/// someone marked negative that came back (`negative`).
fn submissions(
    h: &History,
    alerts: &Alerts,
    since: i64,
    out: &mut Vec<Event>,
) -> Result<(), HistoryError> {
    for (id, keys) in h.main_submissions_since(since, WINDOW)? {
        let negative: Vec<(String, String)> = h
            .submission_frames(id, Some("negative"))?
            .into_iter()
            .map(|f| (f.test, f.digest))
            .collect();
        for (kind, digests, what) in [
            (
                Kind::Untriaged,
                h.new_untriaged(id)?,
                "new untriaged digest",
            ),
            (Kind::Negative, negative, "digest"),
        ] {
            if digests.is_empty() {
                continue;
            }
            let plural = if digests.len() == 1 { "" } else { "s" };
            let how = match kind {
                Kind::Negative => " marked negative came back",
                _ => "",
            };
            let what = format!("{} {what}{plural}{how} on the main line", digests.len());
            out.push(submission_event(
                h,
                alerts,
                kind,
                (id, &keys),
                &what,
                &digests,
            )?);
        }
    }
    Ok(())
}

/// How long before an ignore rule expires its `ignore_expiring` event is
/// raised: three days, a weekend and a working day to act.
pub const IGNORE_NOTICE: std::time::Duration = std::time::Duration::from_secs(3 * 24 * 3600);

/// The ignore rules that expire within [`IGNORE_NOTICE`]: one event per rule
/// and expiry (a rule extended later warns again before its new expiry).
fn expiring(h: &History, alerts: &Alerts, out: &mut Vec<Event>) -> Result<(), HistoryError> {
    let now = chrono::Utc::now();
    let notice = chrono::Duration::from_std(IGNORE_NOTICE).unwrap_or_default();
    for rule in h.active_ignore_rules()? {
        let Ok(at) = chrono::DateTime::parse_from_rfc3339(&rule.expires_at) else {
            continue;
        };
        if at.with_timezone(&chrono::Utc) - now > notice {
            continue;
        }
        let summary = format!(
            "tonegate: ignore rule {} ({:?}, {}) expires at {}: the failures it passes will fail again",
            rule.id, rule.pattern, rule.reason, rule.expires_at
        );
        let event = json!({
            "kind": Kind::IgnoreExpiring.as_str(),
            "summary": summary,
            "rule": rule,
            "links": {
                "dashboard": format!("{}/#/frames", alerts.public_url),
                "api": format!("{}/api/v1/frames/ignores", alerts.public_url),
            },
        });
        let key = format!(
            "{}:{}:{}",
            Kind::IgnoreExpiring.as_str(),
            rule.id,
            rule.expires_at
        );
        out.push((Kind::IgnoreExpiring, key, summary, event));
    }
    Ok(())
}

/// The event of `kind` about submission `id` (with `keys`) and its
/// `digests` (test, digest): `what` happened, the commit range from the
/// last passing main-line submission of its trace, links.
fn submission_event(
    h: &History,
    alerts: &Alerts,
    kind: Kind,
    (id, keys): (i64, &str),
    what: &str,
    digests: &[(String, String)],
) -> Result<Event, HistoryError> {
    let good = h.last_passing_main_submission(id, keys)?;
    let (good_commit, bad_commit) = (good.as_ref().and_then(|g| commit_of(&g.1)), commit_of(keys));
    let summary = format!(
        "tonegate: {what} in submission {id} ({})",
        short(bad_commit.as_deref()),
    );
    let link = |id: i64| {
        json!({
            "dashboard": format!("{}/#/frames/{id}", alerts.public_url),
            "api": format!("{}/api/v1/frames/submissions/{id}", alerts.public_url),
        })
    };
    let event = json!({
        "kind": kind.as_str(),
        "summary": summary,
        "digests": digests.iter().map(|(t, d)| json!({"test": t, "digest": d})).collect::<Vec<_>>(),
        "keys": serde_json::from_str::<Value>(keys).unwrap_or_default(),
        "commits": {"last_good": good_commit, "first_bad": bad_commit},
        "submissions": {"last_good": good.as_ref().map(|g| g.0), "first_bad": id},
        "links": {"last_good": good.as_ref().map(|g| link(g.0)), "first_bad": link(id)},
    });
    Ok((kind, format!("{}:{id}", kind.as_str()), summary, event))
}

fn change_points(
    h: &History,
    alerts: &Alerts,
    since: i64,
    out: &mut Vec<Event>,
) -> Result<(), HistoryError> {
    let points = h.trend(
        "fps",
        &TrendFilter {
            finished_only: true,
            limit: 200,
            ..Default::default()
        },
    )?;
    for (i, p) in points.iter().enumerate() {
        let Some(ratio) = p.change.filter(|_| p.run_id > since) else {
            continue;
        };
        // The point before it in its series: the last run at the old level.
        let before = points[..i]
            .iter()
            .rev()
            .find(|q| q.scene == p.scene && q.adapter == p.adapter);
        let run: Option<RunBrief> = h.run_brief(p.run_id)?;
        let good: Option<RunBrief> = before.map(|b| h.run_brief(b.run_id)).transpose()?.flatten();
        let adapter = p.adapter.as_deref().unwrap_or("?");
        let summary = format!(
            "tonegate: {} FPS changed ×{ratio:.2} at run {} ({}) on {adapter}",
            p.scene,
            p.run_id,
            short(run.as_ref().and_then(|r| r.git_commit.as_deref())),
        );
        let event = json!({
            "kind": "change_point",
            "summary": summary,
            "metric": "fps",
            "scene": p.scene,
            "adapter": p.adapter,
            "ratio": ratio,
            "commits": {
                "last_good": good.as_ref().and_then(|g| g.git_commit.clone()),
                "first_bad": run.as_ref().and_then(|r| r.git_commit.clone()),
            },
            "runs": {"last_good": good.as_ref().map(|g| g.id), "first_bad": p.run_id},
            "links": {
                "last_good": good.as_ref().map(|g| run_links(alerts, g.id)),
                "first_bad": run_links(alerts, p.run_id),
                "trend": format!("{}/#/trends?scene={}", alerts.public_url, p.scene),
            },
        });
        let key = format!("change_point:fps:{}:{adapter}:{}", p.scene, p.run_id);
        out.push((Kind::ChangePoint, key, summary, event));
    }
    Ok(())
}
