//! Memory for judging submitted frames, bounded for the whole process:
//! before an image is decoded, what decoding and comparing it will take is
//! reserved from one budget, from its header's size alone, and given back
//! once its verdict is in. An image that could never fit is refused at
//! once; one that must wait for others waits a bounded time, then the
//! submission is refused as busy (the server's 503 with `Retry-After`).
//! Without it, eight submissions of eight 8192² PNGs (216 KB each on the
//! wire) took 6.7 GB.

use super::FramesError;
use std::sync::{Condvar, Mutex, OnceLock};
use std::time::{Duration, Instant};

/// The budget when nothing sets one: 384 MiB, enough to compare a 4K UHD
/// 8-bit frame with its positive (docs/operations.md#memory).
pub const DEFAULT_BUDGET_BYTES: u64 = 384 << 20;

/// How long a submission waits for the budget by default.
pub const DEFAULT_WAIT: Duration = Duration::from_secs(30);

/// Bytes per pixel to decode a frame (the decoder's buffer and the
/// frame's own), by what it is.
const DECODE_8BIT: u64 = 8;
const DECODE_16BIT: u64 = 16;
const DECODE_HDR: u64 = 32;
/// Bytes per pixel to compare it with a positive, which is decoded too:
/// SSIM's and FLIP's working images (measured: 241 MB of peak RSS for a
/// 4096×2048 `tonegate compare` of two PNGs, about 23 bytes a pixel over
/// the process's own; rounded up).
const COMPARE: u64 = 32;

struct Budget {
    total: u64,
    wait: Duration,
    used: Mutex<u64>,
    freed: Condvar,
}

static BUDGET: OnceLock<Budget> = OnceLock::new();

fn budget() -> &'static Budget {
    BUDGET.get_or_init(|| Budget {
        total: DEFAULT_BUDGET_BYTES,
        wait: DEFAULT_WAIT,
        used: Mutex::new(0),
        freed: Condvar::new(),
    })
}

/// Sets the process's budget and wait, once, before any submission
/// (`serve --decode-budget-mib`); false when it was set already.
pub fn set_budget(total: u64, wait: Duration) -> bool {
    BUDGET
        .set(Budget {
            total,
            wait,
            used: Mutex::new(0),
            freed: Condvar::new(),
        })
        .is_ok()
}

/// The budget in force, in bytes.
pub fn total() -> u64 {
    budget().total
}

/// What judging `bytes` (a submitted file) will take, from its header:
/// decoding it, and comparing it when its test has a positive
/// (`compared`). None when the header says no size (the decoder then
/// refuses the file).
pub fn cost(bytes: &[u8], compared: bool) -> Option<u64> {
    const PNG: [u8; 8] = [0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, b'\n'];
    let (w, h) =
        crate::io::peek::png_dimensions(bytes).or_else(|| crate::io::peek::dimensions(bytes))?;
    let decode = if bytes.starts_with(&PNG) {
        // The IHDR chunk's bit depth is byte 24.
        if bytes.get(24) == Some(&16) {
            DECODE_16BIT
        } else {
            DECODE_8BIT
        }
    } else {
        DECODE_HDR
    };
    let per_pixel = decode + if compared { COMPARE } else { 0 };
    Some(w.saturating_mul(h).saturating_mul(per_pixel))
}

/// A part of the budget, given back when dropped.
pub struct Reservation {
    bytes: u64,
}

impl Drop for Reservation {
    fn drop(&mut self) {
        let b = budget();
        let mut used = b.used.lock().unwrap_or_else(|p| p.into_inner());
        *used = used.saturating_sub(self.bytes);
        b.freed.notify_all();
    }
}

/// Reserves `bytes` for the images `what` names, all at once (so that two
/// submissions each holding a part can never wait on each other): refused
/// at once when more than the whole budget, after the wait when the budget
/// stays too full.
pub fn reserve(bytes: u64, what: &str) -> Result<Reservation, FramesError> {
    let b = budget();
    if bytes > b.total {
        return Err(FramesError::OverBudget {
            what: what.to_owned(),
            mib: bytes.div_ceil(1 << 20),
            budget_mib: b.total >> 20,
        });
    }
    let deadline = Instant::now() + b.wait;
    let mut used = b.used.lock().unwrap_or_else(|p| p.into_inner());
    while *used + bytes > b.total {
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Err(FramesError::Busy {
                seconds: b.wait.as_secs().max(1),
            });
        }
        used = b
            .freed
            .wait_timeout(used, left)
            .unwrap_or_else(|p| p.into_inner())
            .0;
    }
    *used += bytes;
    Ok(Reservation { bytes })
}
