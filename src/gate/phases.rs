//! Where a check run's wall time went, phase by phase: what `check --json`
//! reports as `phases` and the console's `time:` line, so a slow gate says
//! what to cut.

use crate::perf::clock::{Part, Snapshot};
use serde::Serialize;
use std::time::Instant;

/// Seconds of wall time per phase of one check run.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Phases {
    /// The whole run, from reading the suite to the report.
    pub total_s: f64,
    /// Opening the device (its probe included); 0 for the CPU reference.
    pub device_s: f64,
    /// Each scene's renderer: its environment, textures and pipelines.
    pub pipelines_s: f64,
    /// Rendering every frame, readback included.
    pub render_s: f64,
    /// Of that, waiting for the GPU to finish a frame and map it, and
    /// taking the frame off its mapping.
    pub readback_wait_s: f64,
    pub readback_copy_s: f64,
    /// Reading and decoding the goldens.
    pub goldens_s: f64,
    /// Judging every frame: the metrics and the checks.
    pub metrics_s: f64,
    /// Of that, per metric (SSIM, FLIP or HDR-FLIP, the error sums behind
    /// MSE/PSNR/SNR, the fraction over k LSB), summed over a scene's
    /// frames, which are judged in parallel: on a machine of several cores
    /// they add up to more than `metrics_s`.
    pub ssim_s: f64,
    pub flip_s: f64,
    pub errors_s: f64,
    pub fraction_over_s: f64,
    /// Of that, every figure computed on the GPU (`--metrics gpu`), summed
    /// the same way.
    pub gpu_metrics_s: f64,
    /// The kept frames' images: encoding, writing, storing.
    pub artifacts_s: f64,
    /// The history: the run's records and the regression search.
    pub history_s: f64,
    /// The stress suite's wall time; of that, the CPU reference's rows and
    /// the GPU's, each summed over rows (several run at once, so the two
    /// can add up to more than `stress_s`).
    pub stress_s: f64,
    pub stress_cpu_s: f64,
    pub stress_gpu_s: f64,
}

/// Adds phases' times up as a run goes.
pub(super) struct Clock {
    started: Instant,
    pub phases: Phases,
}

impl Clock {
    pub fn start() -> Clock {
        Clock {
            started: Instant::now(),
            phases: Phases::default(),
        }
    }

    /// Runs `f`, adding its wall time to the phase `field` picks, and the
    /// parts counted while it ran (readback, each metric) to theirs: only
    /// the parts of timed phases count (not the stress suite's readbacks).
    pub fn time<T>(&mut self, field: fn(&mut Phases) -> &mut f64, f: impl FnOnce() -> T) -> T {
        let (t, before) = (Instant::now(), Snapshot::now());
        let out = f();
        *field(&mut self.phases) += t.elapsed().as_secs_f64();
        let after = Snapshot::now();
        let part = |p: Part| after.since(&before, p).as_secs_f64();
        let p = &mut self.phases;
        p.readback_wait_s += part(Part::ReadbackWait);
        p.readback_copy_s += part(Part::ReadbackCopy);
        p.ssim_s += part(Part::Ssim);
        p.flip_s += part(Part::Flip);
        p.errors_s += part(Part::Errors);
        p.fraction_over_s += part(Part::FractionOver);
        p.gpu_metrics_s += part(Part::Gpu);
        out
    }

    /// The phases, with the whole run's time.
    pub fn finish(mut self) -> Phases {
        self.phases.total_s = self.started.elapsed().as_secs_f64();
        self.phases
    }
}

impl Phases {
    /// One line for the console.
    pub fn line(&self) -> String {
        let s = |v: f64| format!("{v:.2}");
        format!(
            "time: {} s: device {}, pipelines {}, render {} (readback wait {}, copy {}), \
             goldens {}, metrics {} (SSIM {}, FLIP {}, errors {}, >k LSB {}, on the GPU {}), artifacts {}, \
             history {}, stress {} (CPU {}, GPU {}, summed over rows)",
            s(self.total_s),
            s(self.device_s),
            s(self.pipelines_s),
            s(self.render_s),
            s(self.readback_wait_s),
            s(self.readback_copy_s),
            s(self.goldens_s),
            s(self.metrics_s),
            s(self.ssim_s),
            s(self.flip_s),
            s(self.errors_s),
            s(self.fraction_over_s),
            s(self.gpu_metrics_s),
            s(self.artifacts_s),
            s(self.history_s),
            s(self.stress_s),
            s(self.stress_cpu_s),
            s(self.stress_gpu_s)
        )
    }
}
