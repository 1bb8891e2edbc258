//! The command line's standard output. Rust ignores SIGPIPE, so a write to
//! a closed pipe (`tonegate history | head`) is an error, and `println!`
//! panics on it. Here the first failed write closes the output quietly: the
//! command goes on with its work (a `check` still stores its run, as what it
//! was) and exits with its own code (docs/commands.md#exit-codes). Every
//! `println!` and `print!` under `cli` is this one (`cli/mod.rs`).

use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};

static CLOSED: AtomicBool = AtomicBool::new(false);

/// Writes `args` to standard output, unless it is closed or this write
/// finds it closed.
pub fn write(args: std::fmt::Arguments<'_>, newline: bool) {
    if CLOSED.load(Ordering::Relaxed) {
        return;
    }
    let mut out = std::io::stdout().lock();
    let written = out.write_fmt(args).and_then(|()| {
        if newline {
            out.write_all(b"\n")
        } else {
            Ok(())
        }
    });
    if written.is_err() {
        CLOSED.store(true, Ordering::Relaxed);
    }
}
