//! What a hostile OpenEXR file can make the decoder allocate. This binary
//! counts every allocation (its own global allocator) and holds one test,
//! so the peak it reads belongs to the decode alone.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};

struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            let live = LIVE.fetch_add(layout.size(), Relaxed) + layout.size();
            PEAK.fetch_max(live, Relaxed);
        }
        p
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            let live = LIVE.fetch_add(layout.size(), Relaxed) + layout.size();
            PEAK.fetch_max(live, Relaxed);
        }
        p
    }
    unsafe fn dealloc(&self, p: *mut u8, layout: Layout) {
        unsafe { System.dealloc(p, layout) };
        LIVE.fetch_sub(layout.size(), Relaxed);
    }
}

#[global_allocator]
static A: Counting = Counting;

/// Found by `exr_structured` (fuzz/regressions/exr/): a 396-byte tiled file
/// whose tile description allows blocks of 1.49 GB and whose one block
/// declares that many bytes. `exr` zero-fills a buffer of the declared size
/// before reading; the decoder must refuse the block first. The bound, 16
/// MiB, is far above what a 396-byte file needs (a few KiB of headers and
/// buffers) and far below the 1.49 GB it asked for before.
#[test]
fn a_block_larger_than_the_file_is_refused_before_it_is_allocated() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/fuzz/regressions/exr/tiled-block-declared-size.exr"
    );
    let bytes = std::fs::read(path).unwrap();
    let opts = tonegate::io::LoadOptions::default();
    let before = LIVE.load(Relaxed);
    PEAK.store(before, Relaxed);
    let outcome = tonegate::io::decode_hdr(&bytes, "hostile.exr", &opts);
    let peak = PEAK.load(Relaxed) - before;
    let err = outcome.expect_err("a block larger than the file decoded");
    let message = err.to_string();
    assert!(
        matches!(err, tonegate::io::HdrIoError::Truncated { .. }),
        "{message}"
    );
    assert!(message.starts_with("hostile.exr: "), "{message}");
    assert!(message.contains("declares"), "{message}");
    assert!(
        peak < 16 << 20,
        "decoding allocated {peak} bytes at its peak"
    );
}
