//! The library's progress, drawn as a bar on stderr (indicatif hides it when
//! stderr is not a terminal).

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::sync::Mutex;
use tonegate::progress::Progress;

/// One bar at a time: each job the library starts replaces the last.
pub struct Bar {
    bar: Mutex<Option<ProgressBar>>,
}

impl Bar {
    pub fn new() -> Bar {
        Bar {
            bar: Mutex::new(None),
        }
    }

    fn with(&self, f: impl FnOnce(&ProgressBar)) {
        if let Some(bar) = self
            .bar
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
            .as_ref()
        {
            f(bar);
        }
    }
}

impl Progress for Bar {
    fn start(&self, job: &str, total: u64, unit: &str) {
        let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
        if let Ok(style) = ProgressStyle::with_template(&format!(
            "{{prefix:>8}} [{{bar:30}}] {{pos}}/{{len}} {unit} {{msg}} ({{elapsed}})"
        )) {
            bar.set_style(style.progress_chars("=> "));
        }
        bar.set_prefix(job.to_owned());
        *self
            .bar
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner()) = Some(bar);
    }

    fn working_on(&self, what: &str) {
        self.with(|b| b.set_message(what.to_owned()));
    }

    fn advance(&self, n: u64) {
        self.with(|b| b.inc(n));
    }

    fn finish(&self) {
        self.with(ProgressBar::finish_and_clear);
    }
}
