//! A real server on loopback for the API tests: started in-process on a
//! seeded history, with a client, a worker hold and the error-answer check.

use crate::common;
use reqwest::StatusCode;
use std::sync::{Arc, RwLock};
use tonegate::server::{Limits, ServeOptions, Server};

pub const TOKEN: &str = "test-token-0123456789";

pub struct Running {
    pub base: String,
    pub client: reqwest::Client,
    _stop: tokio::sync::oneshot::Sender<()>,
}

pub async fn start(seeded: &common::Seeded, tweak: impl FnOnce(&mut ServeOptions)) -> Running {
    let mut opts = ServeOptions {
        bind: "127.0.0.1:0".parse().unwrap(),
        db: seeded.db.clone(),
        token: TOKEN.into(),
        private_reads: false,
        suite: seeded.suite.clone(),
        adapter: Default::default(),
        gpu_config: Default::default(),
        limits: Limits::default(),
        conn: Default::default(),
        hold_workers: None,
        scoped: Default::default(),
        alerts: None,
    };
    tweak(&mut opts);
    let server = Server::bind(opts).await.expect("server binds");
    let addr = server.local_addr().unwrap();
    let (tx, rx) = tokio::sync::oneshot::channel::<()>();
    tokio::spawn(server.run(async move {
        let _ = rx.await;
    }));
    Running {
        base: format!("http://{addr}"),
        client: reqwest::Client::new(),
        _stop: tx,
    }
}

impl Running {
    pub async fn get(&self, path: &str) -> reqwest::Response {
        self.client
            .get(format!("{}{path}", self.base))
            .send()
            .await
            .unwrap()
    }
    pub async fn json(&self, path: &str) -> (StatusCode, serde_json::Value) {
        let r = self.get(path).await;
        let status = r.status();
        let text = r.text().await.unwrap();
        // +inf PSNR is the literal 1e999, which serde_json's Value cannot hold.
        let v = serde_json::from_str(&text.replace("1e999", "1e308"))
            .unwrap_or_else(|e| panic!("{path}: {e}: {text}"));
        (status, v)
    }
    pub async fn tonemap(&self, query: &str, body: Vec<u8>) -> reqwest::Response {
        self.client
            .post(format!("{}/api/v1/tonemap?{query}", self.base))
            .body(body)
            .send()
            .await
            .unwrap()
    }
}

/// Write-holds the workers' lock on a thread of its own (the workers are
/// plain threads) until dropped: jobs queue up but none finishes.
pub struct Held(
    Option<std::sync::mpsc::Sender<()>>,
    Option<std::thread::JoinHandle<()>>,
);

pub fn hold_workers(lock: &Arc<RwLock<()>>) -> Held {
    let (release, released) = std::sync::mpsc::channel::<()>();
    let (ready, is_ready) = std::sync::mpsc::channel();
    let lock = lock.clone();
    let t = std::thread::spawn(move || {
        let _guard = lock.write().unwrap();
        ready.send(()).unwrap();
        let _ = released.recv();
    });
    is_ready.recv().unwrap();
    Held(Some(release), Some(t))
}

impl Drop for Held {
    fn drop(&mut self) {
        drop(self.0.take());
        if let Some(t) = self.1.take() {
            t.join().unwrap();
        }
    }
}

/// An error answer: the status, JSON with the code, and the detail.
pub async fn expect_error(r: reqwest::Response, status: StatusCode, code: &str) -> String {
    assert_eq!(r.status(), status, "{:?}", r.headers());
    assert_eq!(
        r.headers()["content-type"].to_str().unwrap(),
        "application/json"
    );
    let v: serde_json::Value = r.json().await.unwrap();
    assert_eq!(v["error"], code, "{v}");
    let detail = v["detail"].as_str().unwrap().to_owned();
    assert!(!detail.is_empty());
    detail
}
