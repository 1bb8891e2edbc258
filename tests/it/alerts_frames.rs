//! The frames' own alerts: a digest someone marked negative coming back
//! on the main line raises a `negative` alert once, with the same trace's
//! commit range; an ignore rule about to expire raises `ignore_expiring`
//! once per expiry.

use crate::frames::{frame, frame8, submit, triage};
use serde_json::Value;
use std::time::Duration;
use tonegate::alerts::{Alerts, Format, Kind, Retry, Webhook};
use tonegate::history::History;
use tonegate::image::Frame;
use tonegate::io::write_frame_png;

/// Alerts with one webhook that takes `kind`.
fn alerts_for(kind: Kind) -> Alerts {
    Alerts {
        public_url: "http://tonegate.test".into(),
        scan_every: Duration::from_secs(1),
        retry: Retry {
            first: Duration::from_secs(3600),
            most_attempts: 3,
        },
        timeout: Duration::from_secs(1),
        webhooks: vec![Webhook {
            name: "team".into(),
            url: "http://127.0.0.1:9/".into(),
            format: Format::Json,
            secret: b"a secret of sixteen bytes or more".to_vec(),
            events: vec![kind],
        }],
    }
}

#[test]
fn a_negative_that_comes_back_raises_an_alert_once() {
    let tmp = tempfile::tempdir().unwrap();
    let (db, dir) = (tmp.path().join("h.sqlite"), tmp.path().join("frames"));
    std::fs::create_dir_all(&dir).unwrap();
    let alerts = alerts_for(Kind::Negative);
    let path = dir.join("scene.png");
    write_frame_png(&path, &Frame::Rgb8(frame8(0))).unwrap();
    let key = |commit: &str| format!("commit={commit}");
    // A good submission, then a broken frame marked negative.
    let good = submit(&db, &dir, &["--key", &key("g1")]);
    let digest = frame(&good.report, "scene")["digest"]
        .as_str()
        .unwrap()
        .to_owned();
    triage(&db, "scene", &digest, "positive");
    assert_eq!(submit(&db, &dir, &["--key", &key("g2")]).code, 0);
    let h = History::open(&db).unwrap();
    assert_eq!(tonegate::alerts::scan(&h, &alerts).unwrap(), 0);
    write_frame_png(&path, &Frame::Rgb8(frame8(7))).unwrap();
    let broken = submit(&db, &dir, &["--key", &key("b1")]);
    let bad = frame(&broken.report, "scene")["digest"]
        .as_str()
        .unwrap()
        .to_owned();
    triage(&db, "scene", &bad, "negative");
    // Nothing came back yet: its first sighting raised an `untriaged`
    // event, which this webhook does not take.
    assert_eq!(tonegate::alerts::scan(&h, &alerts).unwrap(), 1);
    let hold = Duration::from_secs(60);
    assert!(h.claim_due_deliveries(hold, 10).unwrap().is_empty());
    // It comes back.
    let back = submit(&db, &dir, &["--key", &key("b2")]);
    assert_eq!(frame(&back.report, "scene")["status"], "negative");
    assert_eq!(tonegate::alerts::scan(&h, &alerts).unwrap(), 1);
    assert_eq!(
        tonegate::alerts::scan(&h, &alerts).unwrap(),
        0,
        "raised twice"
    );
    let due = h.claim_due_deliveries(hold, 10).unwrap();
    assert_eq!(due.len(), 1);
    assert_eq!(due[0].kind, "negative");
    let event: Value = serde_json::from_str(&due[0].payload).unwrap();
    assert_eq!(event["digests"][0]["digest"], bad.as_str());
    assert_eq!(event["digests"][0]["test"], "scene");
    assert_eq!(event["commits"]["last_good"], "g2");
    assert_eq!(event["commits"]["first_bad"], "b2");
    assert!(event["summary"]
        .as_str()
        .unwrap()
        .contains("marked negative came back"));
}

#[test]
fn an_ignore_rule_about_to_expire_raises_an_alert_once() {
    let tmp = tempfile::tempdir().unwrap();
    let h = History::open(&tmp.path().join("h.sqlite")).unwrap();
    let alerts = alerts_for(Kind::IgnoreExpiring);
    assert_eq!(tonegate::alerts::scan(&h, &alerts).unwrap(), 0);
    let hours = |n: u64| Duration::from_secs(n * 3600);
    let soon = h
        .add_ignore_rule(
            "ui/*",
            "{}",
            hours(48),
            ("ada", "font hinting, fixed in 2.1"),
        )
        .unwrap();
    h.add_ignore_rule("hud/*", "{}", hours(30 * 24), ("ada", "a month away"))
        .unwrap();
    assert_eq!(tonegate::alerts::scan(&h, &alerts).unwrap(), 1);
    assert_eq!(
        tonegate::alerts::scan(&h, &alerts).unwrap(),
        0,
        "raised twice"
    );
    let due = h.claim_due_deliveries(Duration::from_secs(60), 10).unwrap();
    assert_eq!(due.len(), 1);
    assert_eq!(due[0].kind, "ignore_expiring");
    let event: Value = serde_json::from_str(&due[0].payload).unwrap();
    assert_eq!(event["rule"]["id"], soon.id);
    assert_eq!(event["rule"]["pattern"], "ui/*");
    assert_eq!(event["rule"]["expires_at"], soon.expires_at.as_str());
    assert!(
        event["summary"].as_str().unwrap().contains("font hinting"),
        "{event}"
    );
}
