//! What a history stamps on what it writes: the time (and a time some span
//! ago), this machine and process, the git commit; and whether a history
//! file can be written at all.

use super::is_url;
use rusqlite::Connection;
use std::path::Path;
use std::time::Duration;

/// The current UTC time, RFC 3339 with milliseconds (sorts as text).
pub fn now() -> String {
    chrono::Utc::now().to_rfc3339_opts(chrono::SecondsFormat::Millis, true)
}

/// The current time less `d`, in the stored form (RFC 3339 UTC, ms). A
/// span reaching back before 1970 gives 1970-01-01, before anything a
/// history holds: `history prune --keep-days 100000000` keeps everything
/// rather than overflowing (a negative year would also sort as text after
/// today under some PostgreSQL collations).
pub(super) fn ago(d: Duration) -> String {
    let epoch = chrono::DateTime::<chrono::Utc>::UNIX_EPOCH;
    let t = chrono::Duration::from_std(d)
        .ok()
        .and_then(|d| chrono::Utc::now().checked_sub_signed(d))
        .filter(|t| *t > epoch)
        .unwrap_or(epoch);
    t.to_rfc3339_opts(chrono::SecondsFormat::Millis, true)
}

/// The current time plus `d`, in the stored form; a span past what the
/// calendar holds gives the last time it does.
pub(super) fn later(d: Duration) -> String {
    let t = chrono::Duration::from_std(d)
        .ok()
        .and_then(|d| chrono::Utc::now().checked_add_signed(d))
        .unwrap_or(chrono::DateTime::<chrono::Utc>::MAX_UTC);
    t.to_rfc3339_opts(chrono::SecondsFormat::Millis, true)
}

/// This machine's name, for telling whose `running` rows may be judged dead.
pub fn host_name() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|s| s.trim().to_owned())
        .ok()
        .filter(|s| !s.is_empty())
        .or_else(|| std::env::var("HOSTNAME").ok())
        .unwrap_or_else(|| "unknown".into())
}

/// The start time of process `pid` in clock ticks since boot (field 22 of
/// /proc/PID/stat): with the pid it names one process even after pid reuse.
pub(super) fn process_start(pid: u32) -> Option<String> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // The command name (field 2) is in parentheses and may contain spaces.
    let after = &stat[stat.rfind(')')? + 2..];
    after.split_whitespace().nth(19).map(str::to_owned)
}

/// The commit of the working tree at `dir`, from CI variables or git.
pub fn git_commit(dir: &Path) -> Option<String> {
    for var in [
        "TONEGATE_COMMIT",
        "GITHUB_SHA",
        "CI_COMMIT_SHA",
        "GIT_COMMIT",
    ] {
        if let Ok(v) = std::env::var(var) {
            if !v.trim().is_empty() {
                return Some(v.trim().to_owned());
            }
        }
    }
    let out = std::process::Command::new("git")
        .arg("-C")
        .arg(dir)
        .args(["rev-parse", "HEAD"])
        .stderr(std::process::Stdio::null())
        .output()
        .ok()?;
    let s = String::from_utf8(out.stdout).ok()?;
    (out.status.success() && !s.trim().is_empty()).then(|| s.trim().to_owned())
}

/// Why a run cannot be recorded in the history at `path`, if it cannot: the
/// file, or the folder SQLite writes its `-wal` and `-shm` files in, is not
/// writable. Takes (and at once releases) the write lock, writing nothing.
pub fn write_problem(path: &Path) -> Option<String> {
    if is_url(&path.to_string_lossy()) {
        // A database server: its permissions show when a run opens it.
        return None;
    }
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let advice = format!(
        "check the permissions of {} and of its folder {} (SQLite writes -wal and -shm files there)",
        path.display(),
        dir.display()
    );
    let conn = match Connection::open_with_flags(path, rusqlite::OpenFlags::SQLITE_OPEN_READ_WRITE)
    {
        Ok(c) => c,
        Err(e) => {
            return Some(format!(
                "history database {} cannot be opened for writing ({e}): {advice}",
                path.display()
            ))
        }
    };
    // SQLite opens a file it may not write read-only without a word, and
    // an empty transaction then succeeds: ask it.
    if conn.is_readonly(rusqlite::MAIN_DB).unwrap_or(false) {
        return Some(format!(
            "history database {} is read-only for this user: {advice}",
            path.display()
        ));
    }
    let _ = conn.busy_timeout(Duration::from_secs(5));
    match conn.execute_batch("BEGIN IMMEDIATE; ROLLBACK;") {
        Ok(()) => None,
        Err(e) => Some(format!(
            "history database {} is not writable ({e}): {advice}",
            path.display()
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_span_before_1970_stops_there_instead_of_overflowing() {
        let far = Duration::from_secs(100_000_000 * 86_400);
        assert_eq!(ago(far), "1970-01-01T00:00:00.000Z");
        assert_eq!(ago(Duration::MAX), "1970-01-01T00:00:00.000Z");
        // A day ago is a day ago, and sorts before now.
        let day = ago(Duration::from_secs(86_400));
        assert!(day.starts_with("20") && day < now(), "{day}");
    }
}
