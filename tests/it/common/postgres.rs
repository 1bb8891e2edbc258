//! A real PostgreSQL server for the tests: Debian's `postgresql` package
//! (installed by ci/deps.sh), a fresh `initdb` cluster in a temporary folder
//! on a free port, one per test binary, and a fresh database per test.
//!
//! PostgreSQL refuses to run as root, so as root (CI containers) the cluster
//! belongs to the `postgres` user the package creates and is started through
//! `runuser`. A watchdog shell stops the server and removes the folder when
//! the test process ends, however it ends (a test binary's statics are never
//! dropped, and a killed one runs no destructor).
// benches/history.rs includes this file and uses only part of it.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::OnceLock;

pub struct PgServer {
    pub port: u16,
    /// The cluster, its socket and its log (`server.log`).
    pub dir: PathBuf,
    next: AtomicU32,
    bin: PathBuf,
}

/// The newest installed server's binaries.
fn bin_dir() -> Result<PathBuf, String> {
    let mut dirs: Vec<(u32, PathBuf)> = std::fs::read_dir("/usr/lib/postgresql")
        .map_err(|e| format!("/usr/lib/postgresql: {e}"))?
        .filter_map(|e| e.ok())
        .filter_map(|e| {
            let v = e.file_name().to_str()?.parse::<u32>().ok()?;
            let bin = e.path().join("bin");
            bin.join("initdb").exists().then_some((v, bin))
        })
        .collect();
    dirs.sort();
    dirs.pop().map(|(_, b)| b).ok_or_else(|| "no initdb".into())
}

/// The account the server runs as: this one, or `postgres` when this is root.
fn owner() -> Option<(String, u32, u32)> {
    // SAFETY: getuid has no preconditions.
    if unsafe { libc::getuid() } != 0 {
        return None;
    }
    let name = std::ffi::CString::new("postgres").unwrap();
    // SAFETY: a NUL-terminated name; the returned record is read at once.
    let pw = unsafe { libc::getpwnam(name.as_ptr()) };
    assert!(
        !pw.is_null(),
        "running as root and there is no `postgres` user to run PostgreSQL as (install Debian's postgresql package: ci/deps.sh)"
    );
    // SAFETY: non-null, from getpwnam.
    let (uid, gid) = unsafe { ((*pw).pw_uid, (*pw).pw_gid) };
    Some(("postgres".into(), uid, gid))
}

fn as_owner(owner: &Option<(String, u32, u32)>, program: &Path) -> Command {
    match owner {
        Some((user, ..)) => {
            let mut c = Command::new("runuser");
            c.args(["-u", user, "--"]).arg(program);
            c
        }
        None => Command::new(program),
    }
}

fn run(mut c: Command, what: &str) -> Result<(), String> {
    let o = c
        .stdin(Stdio::null())
        .output()
        .map_err(|e| format!("{what}: {e}"))?;
    if o.status.success() {
        Ok(())
    } else {
        Err(format!(
            "{what} failed ({}): {}{}",
            o.status,
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        ))
    }
}

fn start(name: &str) -> Result<PgServer, String> {
    let bin = bin_dir().map_err(|e| {
        format!("PostgreSQL is not installed ({e}): the tests need Debian's postgresql package (ci/deps.sh installs it)")
    })?;
    let owner = owner();
    let dir = std::env::temp_dir().join(format!("tonegate-pg-{}{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    if let Some((_, uid, gid)) = &owner {
        let c = std::ffi::CString::new(dir.to_str().unwrap()).unwrap();
        // SAFETY: a NUL-terminated path.
        let rc = unsafe { libc::chown(c.as_ptr(), *uid, *gid) };
        assert_eq!(rc, 0, "chown {}", dir.display());
    }
    // The watchdog first, so a failure below still cleans up.
    let data = dir.join("data");
    let watchdog = format!(
        "while kill -0 {pid} 2>/dev/null; do sleep 1; done; \
         kill -QUIT $(head -1 '{data}/postmaster.pid' 2>/dev/null) 2>/dev/null; sleep 2; rm -rf '{dir}'",
        pid = std::process::id(),
        data = data.display(),
        dir = dir.display()
    );
    Command::new("sh")
        .args(["-c", &watchdog])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .map_err(|e| format!("starting the watchdog: {e}"))?;
    let mut init = as_owner(&owner, &bin.join("initdb"));
    init.arg("-D")
        .arg(&data)
        .args(["-U", "tonegate", "-A", "trust", "-E", "UTF8", "--no-sync"]);
    run(init, "initdb")?;
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map_err(|e| format!("finding a free port: {e}"))?
        .port();
    let server = PgServer {
        port,
        dir,
        next: AtomicU32::new(0),
        bin,
    };
    server.start_again()?;
    Ok(server)
}

/// A cluster of the calling test's own, which it may stop and start
/// (`stop`, `start_again`) without disturbing the other tests.
pub fn private(name: &str) -> PgServer {
    start(&format!("-{name}")).unwrap_or_else(|e| panic!("starting PostgreSQL for {name}: {e}"))
}

/// This test binary's server, started on first use.
pub fn server() -> &'static PgServer {
    static SERVER: OnceLock<Result<PgServer, String>> = OnceLock::new();
    match SERVER.get_or_init(|| start("")) {
        Ok(s) => s,
        Err(e) => panic!("starting PostgreSQL for the tests: {e}"),
    }
}

impl PgServer {
    /// Starts the server (again), on the same port, waiting until it
    /// accepts connections.
    pub fn start_again(&self) -> Result<(), String> {
        let owner = owner();
        let mut ctl = as_owner(&owner, &self.bin.join("pg_ctl"));
        ctl.arg("-D")
            .arg(self.dir.join("data"))
            .arg("-l")
            .arg(self.dir.join("server.log"))
            .args(["-w", "-t", "60", "-o"])
            .arg(format!(
                "-p {} -k {} -c listen_addresses=127.0.0.1 -c max_connections=200 \
                 -c fsync=off -c full_page_writes=off",
                self.port,
                self.dir.display()
            ))
            .arg("start");
        run(ctl, "pg_ctl start").map_err(|e| format!("{e}\nserver log:\n{}", self.log()))
    }

    /// Stops the server in `mode` (`fast`: connections are terminated and
    /// transactions rolled back; `immediate`: the processes are killed and
    /// the next start recovers from the WAL), waiting until it is down.
    pub fn stop(&self, mode: &str) -> Result<(), String> {
        let owner = owner();
        let mut ctl = as_owner(&owner, &self.bin.join("pg_ctl"));
        ctl.arg("-D")
            .arg(self.dir.join("data"))
            .args(["-w", "-t", "60", "-m", mode, "stop"]);
        run(ctl, "pg_ctl stop")
    }

    /// The server's log so far, for a test's failure message.
    pub fn log(&self) -> String {
        std::fs::read_to_string(self.dir.join("server.log")).unwrap_or_default()
    }

    pub fn url(&self, db: &str) -> String {
        format!("postgres://tonegate@127.0.0.1:{}/{db}", self.port)
    }

    /// A new, empty database; returns its address.
    pub fn database(&self) -> String {
        let name = format!("t{}", self.next.fetch_add(1, Ordering::SeqCst));
        let mut c = postgres::Client::connect(&self.url("postgres"), postgres::NoTls)
            .expect("connecting to the test server");
        c.batch_execute(&format!("CREATE DATABASE {name}"))
            .expect("creating a test database");
        self.url(&name)
    }
}

/// A fresh database on this test binary's server.
pub fn database() -> String {
    server().database()
}

impl Drop for PgServer {
    /// A private cluster is stopped and removed with its test (the shared
    /// one is a static, never dropped: the watchdog ends it).
    fn drop(&mut self) {
        let _ = self.stop("immediate");
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}
