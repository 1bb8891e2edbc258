//! The library's progress on stderr: a bar on a terminal, and elsewhere (a
//! CI log, a pipe) a line per finished item with its time, and a line at
//! least every few seconds while a job advances, so that a log shows the
//! run is alive. `--quiet` shows neither.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::{IsTerminal, Write};
use std::sync::Mutex;
use std::time::{Duration, Instant};
use tonegate::progress::Progress;

/// How often a job that advances without finishing an item prints a line.
const LINE_EVERY: Duration = Duration::from_secs(2);

/// How progress is shown.
pub struct Bar {
    shown: Shown,
}

enum Shown {
    /// One bar at a time: each job the library starts replaces the last.
    Terminal(Mutex<Option<ProgressBar>>),
    /// Lines on stderr.
    Lines(Mutex<Option<Lines>>),
    Nothing,
}

/// The job being told in lines.
struct Lines {
    job: String,
    unit: String,
    total: u64,
    done: u64,
    started: Instant,
    last_line: Instant,
    /// The item being worked on, when it started, and the units done then.
    item: Option<(String, Instant, u64)>,
}

impl Lines {
    fn line(&mut self, text: std::fmt::Arguments) {
        let mut err = std::io::stderr().lock();
        let _ = writeln!(
            err,
            "{}: {text} ({}/{} {}, {:.1} s)",
            self.job,
            self.done,
            self.total,
            self.unit,
            self.started.elapsed().as_secs_f64()
        );
        self.last_line = Instant::now();
    }

    /// The line of the item worked on until now, if any.
    fn end_item(&mut self) {
        if let Some((what, since, at)) = self.item.take() {
            let n = self.done - at;
            let s = since.elapsed().as_secs_f64();
            let unit = self.unit.clone();
            self.line(format_args!("{what}: {n} {unit} in {s:.1} s"));
        }
    }
}

impl Bar {
    /// A bar when stderr is a terminal, lines otherwise.
    pub fn new() -> Bar {
        Bar::quiet_if(false)
    }

    /// Nothing when `quiet`, else [`Bar::new`].
    pub fn quiet_if(quiet: bool) -> Bar {
        let shown = if quiet {
            Shown::Nothing
        } else if std::io::stderr().is_terminal() {
            Shown::Terminal(Mutex::new(None))
        } else {
            Shown::Lines(Mutex::new(None))
        };
        Bar { shown }
    }

    fn bar(&self, f: impl FnOnce(&ProgressBar)) {
        if let Shown::Terminal(bar) = &self.shown {
            if let Some(bar) = bar.lock().unwrap_or_else(|p| p.into_inner()).as_ref() {
                f(bar);
            }
        }
    }

    fn lines(&self, f: impl FnOnce(&mut Lines)) {
        if let Shown::Lines(lines) = &self.shown {
            if let Some(lines) = lines.lock().unwrap_or_else(|p| p.into_inner()).as_mut() {
                f(lines);
            }
        }
    }
}

impl Progress for Bar {
    fn start(&self, job: &str, total: u64, unit: &str) {
        match &self.shown {
            Shown::Terminal(slot) => {
                let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
                if let Ok(style) = ProgressStyle::with_template(&format!(
                    "{{prefix:>8}} [{{bar:30}}] {{pos}}/{{len}} {unit} {{msg}} ({{elapsed}})"
                )) {
                    bar.set_style(style.progress_chars("=> "));
                }
                bar.set_prefix(job.to_owned());
                *slot.lock().unwrap_or_else(|p| p.into_inner()) = Some(bar);
            }
            Shown::Lines(slot) => {
                let now = Instant::now();
                *slot.lock().unwrap_or_else(|p| p.into_inner()) = Some(Lines {
                    job: job.to_owned(),
                    unit: unit.to_owned(),
                    total,
                    done: 0,
                    started: now,
                    last_line: now,
                    item: None,
                });
            }
            Shown::Nothing => {}
        }
    }

    fn working_on(&self, what: &str) {
        self.bar(|b| b.set_message(what.to_owned()));
        self.lines(|l| {
            l.end_item();
            l.item = Some((what.to_owned(), Instant::now(), l.done));
        });
    }

    fn advance(&self, n: u64) {
        self.bar(|b| b.inc(n));
        self.lines(|l| {
            l.done += n;
            if l.last_line.elapsed() >= LINE_EVERY {
                let what = l.item.as_ref().map_or("working", |i| i.0.as_str());
                let what = what.to_owned();
                l.line(format_args!("{what} …"));
            }
        });
    }

    fn finish(&self) {
        self.bar(ProgressBar::finish_and_clear);
        self.lines(|l| {
            l.end_item();
            l.line(format_args!("done"));
        });
        if let Shown::Lines(slot) = &self.shown {
            *slot.lock().unwrap_or_else(|p| p.into_inner()) = None;
        }
    }
}
