//! Where a process's time goes, by part: wall time summed over every call
//! of each timed part (the GPU's readback, each metric), read as the
//! difference of two snapshots around a piece of work (`check` reports its
//! run's). Counters are process-wide: in a server, a check run's figures
//! include any other run's made at the same time.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// A part whose time is counted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    /// Waiting for a frame's submission to finish on the GPU (rendering
    /// included) and its buffers to be mapped.
    ReadbackWait,
    /// Taking a frame off its mapped buffer into memory.
    ReadbackCopy,
    /// SSIM, with its map.
    Ssim,
    /// FLIP (or HDR-FLIP for PQ frames), with its map.
    Flip,
    /// The error sums behind MSE, RMSE, PSNR, SNR and the differences.
    Errors,
    /// The fraction of pixels over k codes.
    FractionOver,
    /// Every figure of a pair on the GPU (`check --metrics gpu`): upload,
    /// passes, readback and the host's sums.
    Gpu,
}

const PARTS: usize = 7;
static NANOS: [AtomicU64; PARTS] = [const { AtomicU64::new(0) }; PARTS];

impl Part {
    pub const ALL: [Part; PARTS] = [
        Part::ReadbackWait,
        Part::ReadbackCopy,
        Part::Ssim,
        Part::Flip,
        Part::Errors,
        Part::FractionOver,
        Part::Gpu,
    ];
}

/// Runs `f`, counting its wall time to `part`.
pub fn timed<T>(part: Part, f: impl FnOnce() -> T) -> T {
    let t = Instant::now();
    let out = f();
    NANOS[part as usize].fetch_add(
        u64::try_from(t.elapsed().as_nanos()).unwrap_or(u64::MAX),
        Ordering::Relaxed,
    );
    out
}

/// Every part's time so far.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Snapshot([u64; PARTS]);

impl Snapshot {
    pub fn now() -> Snapshot {
        Snapshot(std::array::from_fn(|i| NANOS[i].load(Ordering::Relaxed)))
    }

    /// The time `part` took between `earlier` and this snapshot.
    pub fn since(&self, earlier: &Snapshot, part: Part) -> Duration {
        let i = part as usize;
        Duration::from_nanos(self.0[i].saturating_sub(earlier.0[i]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_part_counts_the_time_of_its_calls_between_snapshots() {
        let before = Snapshot::now();
        timed(Part::FractionOver, || {
            std::thread::sleep(Duration::from_millis(20))
        });
        let after = Snapshot::now();
        assert!(after.since(&before, Part::FractionOver) >= Duration::from_millis(20));
        assert!(after.since(&before, Part::FractionOver) < Duration::from_secs(5));
        assert!(after.since(&after, Part::FractionOver).is_zero());
    }
}
