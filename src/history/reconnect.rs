//! Riding out a lost database connection: which errors mean the connection
//! (not the statement) failed, how long this process keeps trying, and the
//! back-off between tries. `postgres.rs` replaces the connection and sends
//! the statement again; the fleet reads when the database last came back.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// How long this process retries a statement through a lost connection, in
/// milliseconds: `set_retry_budget`.
static RETRY_BUDGET_MS: AtomicU64 = AtomicU64::new(10_000);

/// When this process last had the database back after losing it.
static RECOVERED: Mutex<Option<Instant>> = Mutex::new(None);

/// Sets how long this process keeps retrying a statement (reconnecting
/// between tries, backing off with jitter) while the database is
/// unreachable or restarting: a runner waits minutes for its database, the
/// server a moment before it answers 503.
pub fn set_retry_budget(budget: Duration) {
    RETRY_BUDGET_MS.store(
        u64::try_from(budget.as_millis()).unwrap_or(u64::MAX),
        Ordering::Relaxed,
    );
}

#[cfg(any(feature = "postgres", feature = "s3"))]
pub(super) fn retry_budget() -> Duration {
    Duration::from_millis(RETRY_BUDGET_MS.load(Ordering::Relaxed))
}

/// When this process last got the database back after losing the
/// connection, if it ever did.
pub fn last_recovery() -> Option<Instant> {
    *RECOVERED.lock().unwrap_or_else(|p| p.into_inner())
}

#[cfg(feature = "postgres")]
/// Whether an error means the connection, not the statement, failed: the
/// socket closed, the server refused or dropped the connection (SQLSTATE
/// class 08), or it is shutting down or starting (57P01 admin shutdown,
/// 57P02 crash shutdown, 57P03 cannot connect now). Such a statement did not
/// run, or ran in a transaction the server rolled back, so it may be sent
/// again on a new connection. (The one exception is a COMMIT whose answer is
/// lost after the server wrote it; the fleet's statements that matter, the
/// claim and the end of a job, are written to be run twice.)
pub fn connection_lost(e: &postgres::Error) -> bool {
    if e.is_closed() {
        return true;
    }
    if let Some(code) = e.code() {
        let c = code.code();
        return c.starts_with("08") || matches!(c, "57P01" | "57P02" | "57P03");
    }
    let mut cause = std::error::Error::source(e);
    while let Some(c) = cause {
        if c.is::<std::io::Error>() {
            return true;
        }
        cause = c.source();
    }
    false
}

#[cfg(any(feature = "postgres", feature = "s3"))]
/// Waits between tries: 50 ms doubling to 2 s, each wait drawn between half
/// and all of that (so a fleet that lost its database together does not
/// reconnect in step), until the budget is spent.
pub(super) struct Backoff {
    started: Instant,
    next: Duration,
    seed: u64,
    tries: u32,
}

#[cfg(any(feature = "postgres", feature = "s3"))]
impl Backoff {
    pub(super) fn new() -> Backoff {
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.subsec_nanos());
        let thread = {
            use std::hash::{Hash, Hasher};
            let mut h = std::collections::hash_map::DefaultHasher::new();
            std::thread::current().id().hash(&mut h);
            h.finish()
        };
        Backoff {
            started: Instant::now(),
            next: Duration::from_millis(50),
            seed: (u64::from(nanos) ^ thread ^ u64::from(std::process::id()) << 32) | 1,
            tries: 0,
        }
    }

    /// Sleeps before the next try; false when the budget is spent.
    pub(super) fn wait(&mut self) -> bool {
        let left = retry_budget().saturating_sub(self.started.elapsed());
        if left.is_zero() {
            return false;
        }
        // xorshift64: jitter needs no better randomness.
        self.seed ^= self.seed << 13;
        self.seed ^= self.seed >> 7;
        self.seed ^= self.seed << 17;
        let fraction = 0.5 + (self.seed % 1000) as f64 / 2000.0;
        std::thread::sleep(self.next.mul_f64(fraction).min(left));
        self.next = (self.next * 2).min(Duration::from_secs(2));
        self.tries += 1;
        true
    }

    /// Records that the database answered after this many lost tries.
    #[cfg_attr(not(feature = "postgres"), allow(dead_code))]
    pub(super) fn answered(&self) {
        if self.tries > 0 {
            *RECOVERED.lock().unwrap_or_else(|p| p.into_inner()) = Some(Instant::now());
            tracing::info!(
                "history database back after {} tries in {:.1} s",
                self.tries,
                self.started.elapsed().as_secs_f64()
            );
        }
    }
}
