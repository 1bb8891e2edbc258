//! The validation policy, one deliberately bad file per rule, all generated
//! here: hand-written PFMs (independent of the crate's own writer), EXRs from
//! both writers, patched headers, truncated and bit-flipped files.
//!
//! "Refused before allocation" is measured, not assumed: this test binary's
//! allocator records the largest single allocation made by the current
//! thread, and the absurd-size tests assert it stays small.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::fs;
use std::io::Cursor;
use std::time::{Duration, Instant};

use exr::prelude::traits::*;
use exr::prelude::{
    f16, AnyChannel, AnyChannels, Blocks, Compression, Encoding, FlatSamples, Image as ExrImage,
    Layer, LayerAttributes, LineOrder,
};
use tonegate::image::{HdrImage, Image};
use tonegate::io::{decode_hdr, encode_png8, read_png8, write_image_hdr, HdrIoError, LoadOptions};

// ---- allocation probe ----------------------------------------------------

/// Records, per thread, the largest single allocation; otherwise `System`.
struct LargestAllocation;

thread_local! {
    static LARGEST: Cell<usize> = const { Cell::new(0) };
}

fn note(size: usize) {
    // `try_with`: allocations during thread teardown must not panic.
    let _ = LARGEST.try_with(|largest| largest.set(largest.get().max(size)));
}

// SAFETY: every call is forwarded unchanged to `System`; `note` neither
// allocates nor unwinds.
unsafe impl GlobalAlloc for LargestAllocation {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note(new_size);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: LargestAllocation = LargestAllocation;

/// Runs `f`, returning its result, the largest allocation it made and its duration.
fn probe<T>(f: impl FnOnce() -> T) -> (T, usize, Duration) {
    LARGEST.with(|largest| largest.set(0));
    let start = Instant::now();
    let result = f();
    let elapsed = start.elapsed();
    (result, LARGEST.with(Cell::get), elapsed)
}

/// An absurd header must be refused with the right error, without a large
/// allocation (1 MiB allows for buffered readers and headers), and quickly.
fn assert_refused_early(
    result: Result<(HdrImage, tonegate::io::LoadReport), HdrIoError>,
    largest: usize,
    elapsed: Duration,
    expect: fn(&HdrIoError) -> bool,
) {
    let error = result.expect_err("an absurd header must be refused");
    assert!(expect(&error), "unexpected error: {error:?}");
    assert!(
        largest < 1 << 20,
        "allocated {largest} bytes before refusing: {error}"
    );
    assert!(
        elapsed < Duration::from_secs(1),
        "took {elapsed:?}: {error}"
    );
}

// ---- bad-file makers -----------------------------------------------------

/// A hand-written PFM; `rows` are in image order (top first) and stored
/// bottom to top as the format requires.
fn pfm(magic: &str, width: usize, height: usize, little_endian: bool, samples: &[f32]) -> Vec<u8> {
    let scale = if little_endian { "-1.0" } else { "1.0" };
    let mut bytes = format!("{magic}\n{width} {height}\n{scale}\n").into_bytes();
    let row_len = samples.len() / height.max(1);
    for row in samples.chunks(row_len.max(1)).rev() {
        for v in row {
            bytes.extend_from_slice(&if little_endian {
                v.to_le_bytes()
            } else {
                v.to_be_bytes()
            });
        }
    }
    bytes
}

fn exr_with_our_writer(image: &HdrImage) -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.exr");
    write_image_hdr(&path, image).unwrap();
    fs::read(path).unwrap()
}

/// Sets the data window's xMax and yMax of a single-part EXR, and the
/// `chunkCount` attribute exr writes, so that the header stays consistent and
/// only the size is absurd.
fn patch_data_window(mut bytes: Vec<u8>, x_max: i32, y_max: i32) -> Vec<u8> {
    let value_at = |bytes: &[u8], key: &[u8]| {
        bytes
            .windows(key.len())
            .position(|w| w == key)
            .unwrap_or_else(|| panic!("attribute {:?}", String::from_utf8_lossy(key)))
            + key.len()
            + 4 // the attribute's byte size
    };
    let at = value_at(&bytes, b"dataWindow\0box2i\0");
    bytes[at + 8..at + 12].copy_from_slice(&x_max.to_le_bytes());
    bytes[at + 12..at + 16].copy_from_slice(&y_max.to_le_bytes());
    // Our writer uses ZIP16: 16 scan lines per block.
    let chunks = (y_max + 1 + 15) / 16;
    let at = value_at(&bytes, b"chunkCount\0int\0");
    bytes[at..at + 4].copy_from_slice(&chunks.to_le_bytes());
    bytes
}

fn rgbe(header_lines: &str, pixels: &[[u8; 4]]) -> Vec<u8> {
    let mut bytes = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n{header_lines}\n").into_bytes();
    bytes.extend(pixels.iter().flatten());
    bytes
}

fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 == 1 {
                (crc >> 1) ^ 0xedb8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

fn decode(bytes: &[u8], name: &str) -> Result<(HdrImage, tonegate::io::LoadReport), HdrIoError> {
    decode_hdr(bytes, name, &LoadOptions::default())
}

// ---- rule: negatives are clamped and counted -----------------------------

#[test]
fn negative_components_are_clamped_to_zero_and_counted() {
    let samples = [0.5, -0.25, 1.0, -1e-6, -3.0, 2.0];
    let (image, report) = decode(&pfm("PF", 2, 1, true, &samples), "ringing.pfm").unwrap();
    assert_eq!(image.pixels, vec![[0.5, 0.0, 1.0], [0.0, 0.0, 2.0]]);
    assert_eq!(report.clamped_negative, 3);

    // The same through EXR, as real lossy EXRs carry them.
    let mut exr_image = Image::filled(4, 3, [1.0f32, 1.0, 1.0]);
    exr_image.pixels[5] = [-0.01, 1.0, -0.02];
    let (image, report) = decode(&exr_with_our_writer(&exr_image), "ringing.exr").unwrap();
    assert_eq!(image.pixels[5], [0.0, 1.0, 0.0]);
    assert_eq!(report.clamped_negative, 2);
    assert_eq!(report.min_luminance, 0.7152); // only G is left
}

// ---- rule: NaN/Inf refused unless sanitising -----------------------------

/// 12 non-finite values, the first (in row-major image order) at (3, 7).
fn twelve_nonfinite() -> HdrImage {
    let mut image = Image::filled(10, 9, [0.25f32; 3]);
    image.pixels[7 * 10 + 3] = [f32::NAN, f32::NAN, f32::NAN];
    image.pixels[7 * 10 + 4] = [f32::INFINITY, 0.25, f32::NEG_INFINITY];
    for x in 0..7 {
        image.pixels[8 * 10 + x][1] = if x % 2 == 0 { f32::NAN } else { f32::INFINITY };
    }
    image
}

#[test]
fn nonfinite_values_are_refused_with_their_count_and_first_position() {
    let bytes = exr_with_our_writer(&twelve_nonfinite());
    assert_eq!(
        decode(&bytes, "in.exr").unwrap_err().to_string(),
        "in.exr: 12 non-finite values (NaN or ±Inf), first at (3, 7); pass --sanitize to set them to 0"
    );

    // PFM stores rows bottom to top; the position is still in image order.
    let image = twelve_nonfinite();
    let flat: Vec<f32> = image.pixels.iter().flatten().copied().collect();
    let bytes = pfm("PF", 10, 9, false, &flat);
    let error = decode(&bytes, "in.pfm").unwrap_err();
    assert!(
        matches!(
            error,
            HdrIoError::NonFinite {
                count: 12,
                x: 3,
                y: 7,
                ..
            }
        ),
        "{error:?}"
    );

    // f16 infinity from a half-float EXR (a common overflow of 65504).
    let mut y_plane = vec![f16::from_f32(1.0); 6];
    y_plane[4] = f16::INFINITY;
    let channels = [AnyChannel::new("Y", FlatSamples::F16(y_plane))]
        .into_iter()
        .collect();
    let layer = Layer::new(
        (3, 2),
        LayerAttributes::default(),
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(channels),
    );
    let mut half = Cursor::new(Vec::new());
    ExrImage::from_layer(layer)
        .write()
        .to_buffered(&mut half)
        .unwrap();
    let error = decode(half.get_ref(), "half.exr").unwrap_err();
    // A grey sample fills three components.
    assert!(
        matches!(
            error,
            HdrIoError::NonFinite {
                count: 3,
                x: 1,
                y: 1,
                ..
            }
        ),
        "{error:?}"
    );
}

#[test]
fn sanitize_sets_nonfinite_values_to_zero_and_counts_them() {
    let opts = LoadOptions {
        sanitize: true,
        ..LoadOptions::default()
    };
    let mut image = twelve_nonfinite();
    image.pixels[0] = [-1.0, 0.25, 0.25];
    let (read, report) = decode_hdr(&exr_with_our_writer(&image), "in.exr", &opts).unwrap();
    assert_eq!(report.sanitized_nonfinite, 12);
    assert_eq!(report.clamped_negative, 1);
    assert_eq!(read.get(3, 7), [0.0; 3]);
    assert_eq!(read.get(4, 7), [0.0, 0.25, 0.0]);
    assert!(read
        .pixels
        .iter()
        .flatten()
        .all(|v| v.is_finite() && *v >= 0.0));
}

// ---- rule: sizes checked from the header before allocation ---------------

#[test]
fn a_pfm_claiming_100000_by_100000_is_refused_before_allocation() {
    let bytes = pfm("PF", 100_000, 100_000, true, &[1.0; 3]);
    let (result, largest, elapsed) = probe(|| decode(&bytes, "huge.pfm"));
    assert_refused_early(result, largest, elapsed, |e| {
        matches!(
            e,
            HdrIoError::TooLarge {
                width: 100_000,
                height: 100_000,
                ..
            }
        )
    });
}

#[test]
fn an_exr_whose_data_window_is_huge_is_refused_before_allocation() {
    let bytes = patch_data_window(
        exr_with_our_writer(&Image::filled(4, 4, [1.0f32; 3])),
        99_999,
        99_999,
    );
    let (result, largest, elapsed) = probe(|| decode(&bytes, "huge.exr"));
    assert_refused_early(result, largest, elapsed, |e| {
        matches!(
            e,
            HdrIoError::TooLarge {
                width: 100_000,
                height: 100_000,
                ..
            }
        )
    });
}

#[test]
fn a_radiance_header_claiming_a_huge_image_is_refused_before_allocation() {
    let bytes = rgbe("-Y 100000 +X 100000", &[[128, 128, 128, 129]]);
    let (result, largest, elapsed) = probe(|| decode(&bytes, "huge.hdr"));
    assert_refused_early(result, largest, elapsed, |e| {
        matches!(e, HdrIoError::TooLarge { .. })
    });
}

#[test]
fn a_png_claiming_a_huge_image_is_refused_before_allocation() {
    let mut png = encode_png8(&Image::filled(2, 2, [9u8; 3])).unwrap();
    // IHDR data follows the 8-byte signature, a 4-byte length and "IHDR".
    png[16..20].copy_from_slice(&100_000u32.to_be_bytes());
    png[20..24].copy_from_slice(&100_000u32.to_be_bytes());
    let crc = crc32(&png[12..29]);
    png[29..33].copy_from_slice(&crc.to_be_bytes());
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("huge.png");
    fs::write(&path, &png).unwrap();
    let (result, largest, elapsed) = probe(|| read_png8(&path));
    let error = result.expect_err("huge PNG");
    assert!(matches!(error, HdrIoError::TooLarge { .. }), "{error:?}");
    assert!(
        largest < 1 << 20 && elapsed < Duration::from_secs(1),
        "{largest} bytes, {elapsed:?}"
    );
}

#[test]
fn headers_promising_more_data_than_the_file_holds_are_refused_before_allocation() {
    // 8000×8000 is under the 64 Mi-pixel limit (768 MB as f32 RGB), but the
    // files are a few hundred bytes: refused from the length, not after
    // allocating and failing to read.
    let bytes = pfm("PF", 8000, 8000, true, &[1.0; 3]);
    let (result, largest, elapsed) = probe(|| decode(&bytes, "short.pfm"));
    assert_refused_early(result, largest, elapsed, |e| {
        matches!(e, HdrIoError::Truncated { .. })
    });

    let bytes = patch_data_window(
        exr_with_our_writer(&Image::filled(4, 4, [1.0f32; 3])),
        7999,
        7999,
    );
    let (result, largest, elapsed) = probe(|| decode(&bytes, "short.exr"));
    assert_refused_early(result, largest, elapsed, |e| {
        matches!(e, HdrIoError::Truncated { .. })
    });
}

#[test]
fn zero_width_or_height_is_refused() {
    for (bytes, name) in [
        (pfm("PF", 0, 5, true, &[]), "empty.pfm"),
        (pfm("Pf", 5, 0, true, &[]), "empty.pfm"),
        (rgbe("-Y 5 +X 0", &[]), "empty.hdr"),
    ] {
        let error = decode(&bytes, name).unwrap_err();
        assert!(
            matches!(error, HdrIoError::EmptyImage { .. }),
            "{name}: {error:?}"
        );
        assert!(error.to_string().starts_with(name));
    }
}

#[test]
fn the_pixel_limit_is_configurable() {
    let bytes = pfm("PF", 8, 8, true, &[0.5; 192]);
    let opts = |max_pixels| LoadOptions {
        max_pixels,
        ..LoadOptions::default()
    };
    let error = decode_hdr(&bytes, "a.pfm", &opts(63)).unwrap_err();
    assert!(
        error.to_string().contains("over the limit of 63 pixels"),
        "{error}"
    );
    assert!(decode_hdr(&bytes, "a.pfm", &opts(64)).is_ok());
}

// ---- rule: truncated or corrupt files are errors naming the file ---------

/// One valid file per reader path: EXR from both writers (ZIP16, PIZ with
/// tiles, B44) and OpenEXR's DWAA, RGBE with RLE and flat scan lines, PFM.
fn valid_hdr_files() -> Vec<(&'static str, Vec<u8>)> {
    let image = Image::from_fn(40, 20, |x, y| {
        [x as f32 * 0.3, y as f32 * 0.1, 1.0 + (x * y) as f32]
    });
    let dir = tempfile::tempdir().unwrap();
    let mut files = Vec::new();
    for name in ["zip16.exr", "rle.hdr", "a.pfm"] {
        let path = dir.path().join(name);
        write_image_hdr(&path, &image).unwrap();
        files.push((name, fs::read(&path).unwrap()));
    }
    let narrow = dir.path().join("flat.hdr");
    write_image_hdr(&narrow, &Image::filled(5, 9, [0.5f32, 2.0, 7.0])).unwrap();
    files.push(("flat.hdr", fs::read(narrow).unwrap()));

    // Half-float EXRs from exr's writer: PIZ in tiles, and B44 (whose decoder
    // in exr 1.74.2 panics on some corrupt blocks, which exercises the
    // `catch_unwind` defence in the bit-flip test).
    for (name, compression, blocks) in [
        (
            "piz-tiled.exr",
            Compression::PIZ,
            Blocks::Tiles(exr::prelude::Vec2(16, 16)),
        ),
        ("b44.exr", Compression::B44, Blocks::ScanLines),
    ] {
        let channels = ["R", "G", "B"]
            .iter()
            .map(|name| {
                let plane = (0..40 * 20)
                    .map(|i| f16::from_f32((i % 37) as f32 * 0.1))
                    .collect();
                AnyChannel::new(*name, FlatSamples::F16(plane))
            })
            .collect();
        let encoding = Encoding {
            compression,
            blocks,
            line_order: LineOrder::Increasing,
        };
        let layer = Layer::new(
            (40, 20),
            LayerAttributes::default(),
            encoding,
            AnyChannels::sort(channels),
        );
        let mut bytes = Cursor::new(Vec::new());
        ExrImage::from_layer(layer)
            .write()
            .to_buffered(&mut bytes)
            .unwrap();
        files.push((name, bytes.into_inner()));
    }

    let dwaa = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/dwaa_rgb_half.exr");
    files.push(("dwaa.exr", fs::read(dwaa).unwrap()));
    files
}

#[test]
fn truncated_files_of_every_format_are_errors_naming_the_file() {
    for (name, bytes) in valid_hdr_files() {
        assert!(
            decode(&bytes, name).is_ok(),
            "{name} must be valid before cutting"
        );
        let len = bytes.len();
        let mut cuts = vec![
            0,
            1,
            2,
            5,
            11,
            30,
            60,
            len / 4,
            len / 2,
            len * 3 / 4,
            len - 4,
            len - 1,
        ];
        cuts.retain(|&cut| cut < len);
        for cut in cuts {
            let error = decode(&bytes[..cut], name).expect_err(&format!("{name} cut at {cut}"));
            let message = error.to_string();
            assert!(message.starts_with(&format!("{name}: ")), "{message}");
            assert!(
                !matches!(error, HdrIoError::DecoderPanic { .. }),
                "{name} cut at {cut}: {message}"
            );
        }
    }
}

#[test]
fn truncated_pngs_are_errors_naming_the_file() {
    let png = encode_png8(&Image::from_fn(30, 30, |x, y| [x as u8, y as u8, 7])).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cut.png");
    for cut in [
        0,
        4,
        8,
        20,
        33,
        png.len() / 2,
        png.len() - 13,
        png.len() - 1,
    ] {
        fs::write(&path, &png[..cut]).unwrap();
        let error = read_png8(&path).expect_err(&format!("cut at {cut}"));
        let message = error.to_string();
        assert!(
            message.starts_with(&path.display().to_string()),
            "{message}"
        );
        assert!(
            !matches!(error, HdrIoError::DecoderPanic { .. }),
            "{message}"
        );
    }
}

#[test]
fn corrupt_header_fields_are_named_errors() {
    type Expect = fn(&HdrIoError) -> bool;
    let cases: Vec<(&str, Vec<u8>, Expect)> = vec![
        (
            "xyze.hdr",
            b"#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 1\n\x80\x80\x80\x80".to_vec(),
            |e| matches!(e, HdrIoError::Unsupported { .. }),
        ),
        (
            "orientation.hdr",
            rgbe("+Y 1 +X 1", &[[128, 128, 128, 128]]),
            |e| matches!(e, HdrIoError::Unsupported { .. }),
        ),
        (
            "dimensions.hdr",
            rgbe("-Y one +X 1", &[[128, 128, 128, 128]]),
            |e| matches!(e, HdrIoError::Corrupt { .. }),
        ),
        (
            "version.exr",
            {
                let mut bytes = exr_with_our_writer(&Image::filled(2, 2, [1.0f32; 3]));
                bytes[4] = 99; // format version
                bytes
            },
            |e| {
                matches!(
                    e,
                    HdrIoError::Unsupported { .. } | HdrIoError::Corrupt { .. }
                )
            },
        ),
        (
            "scale.pfm",
            b"PF\n1 1\n0.0\n\0\0\0\0\0\0\0\0\0\0\0\0".to_vec(),
            |e| matches!(e, HdrIoError::Corrupt { .. }),
        ),
    ];
    for (name, bytes, expect) in cases {
        let error = decode(&bytes, name).expect_err(name);
        assert!(expect(&error), "{name}: {error:?}");
        assert!(
            error.to_string().starts_with(&format!("{name}: ")),
            "{error}"
        );
    }
}

#[test]
fn bit_flipped_files_never_crash_the_caller() {
    // Deterministic xorshift so a failure names a reproducible variant. Each
    // variant flips one to three bytes after the first 8 (the magic stays, so
    // the decoders themselves are exercised). A flipped file may still decode
    // (a flipped sample is a valid float); what matters is that every outcome
    // is a value or an error naming the file. A panic inside a decoder is
    // caught and reported as `DecoderPanic` (the second line of defence), so
    // the count of those is printed, not forbidden.
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let opts = LoadOptions {
        sanitize: true,
        ..LoadOptions::default()
    };
    let mut outcomes = [0usize; 3]; // ok, error, caught panic
    for (name, bytes) in valid_hdr_files() {
        for variant in 0..150 {
            let mut corrupted = bytes.clone();
            for _ in 0..1 + next() % 3 {
                let at = 8 + (next() as usize) % (corrupted.len() - 8);
                corrupted[at] ^= 1 << (next() % 8);
            }
            match decode_hdr(&corrupted, name, &opts) {
                Ok(_) => outcomes[0] += 1,
                Err(error) => {
                    assert!(
                        error.to_string().starts_with(&format!("{name}: ")),
                        "{name} #{variant}: {error}"
                    );
                    outcomes[if matches!(error, HdrIoError::DecoderPanic { .. }) {
                        2
                    } else {
                        1
                    }] += 1;
                }
            }
        }
    }
    eprintln!(
        "bit flips: {} decoded, {} errors, {} caught panics",
        outcomes[0], outcomes[1], outcomes[2]
    );
    assert_eq!(outcomes.iter().sum::<usize>(), 7 * 150);
    assert!(
        outcomes[1] > 0,
        "some flips must hit headers or compressed streams"
    );
}

#[test]
fn a_dwa_block_declaring_a_huge_section_is_refused_not_allocated() {
    // exr 1.74.2 would ask for a buffer of the declared size; a failed
    // allocation aborts the process, so the reader checks the counters first.
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/dwaa_rgb_half.exr");
    let mut bytes = fs::read(path).unwrap();
    let u64_at = |b: &[u8], at: usize| u64::from_le_bytes(b[at..at + 8].try_into().unwrap());
    // The 2-entry offset table sits right before the first block, which it points at.
    let table = (0..bytes.len() - 16)
        .find(|&p| u64_at(&bytes, p) == p as u64 + 16 && u64_at(&bytes, p + 8) > p as u64 + 16)
        .expect("offset table");
    // Block: y (i32), byte size (i32), then the 11 DWA counters; the 10th is the DC count.
    let dc_count = table + 16 + 8 + 9 * 8;
    bytes[dc_count..dc_count + 8].copy_from_slice(&(1u64 << 54).to_le_bytes());
    let (result, largest, elapsed) = probe(|| decode(&bytes, "dwa-bomb.exr"));
    assert_refused_early(result, largest, elapsed, |e| {
        matches!(e, HdrIoError::Corrupt { .. })
    });
}

/// Found by a hostile client (a4e9bd9, 2026-11-21): `exr` swaps an inverted window's
/// corners, so an empty window said "compressed ZIP16 data" and an inverted
/// one "decompressed data"; a Radiance file cut in its header said "format
/// `32` is not supported".
#[test]
fn empty_or_inverted_windows_and_cut_headers_say_what_is_wrong() {
    let good = exr_with_our_writer(&Image::filled(4, 4, [1.0f32; 3]));
    for (x_max, y_max, expect) in [
        (-1, 3, "empty 0×4 image"),
        (3, -1, "empty 4×0 image"),
        (-5, 3, "data window of part 0 is inverted: (xMin, yMin) = (0, 0) lies past (xMax, yMax) = (-5, 3)"),
        (3, -7, "(xMax, yMax) = (3, -7)"),
    ] {
        let e = decode(&patch_data_window(good.clone(), x_max, y_max), "w.exr")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("w.exr: ") && e.contains(expect), "{x_max} {y_max}: {e}");
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.hdr");
    write_image_hdr(&path, &Image::filled(8, 8, [1.0f32; 3])).unwrap();
    let whole = fs::read(&path).unwrap();
    let blank = whole.windows(2).position(|w| w == b"\n\n").unwrap();
    for (cut, expect) in [
        (20, "ends inside the header, after 20 bytes"),
        (blank + 1, "ends inside the header"),
        (blank + 5, "ends inside the dimensions line"),
        (whole.len() - 3, "the data ends early"),
    ] {
        let e = decode(&whole[..cut], "c.hdr").unwrap_err();
        assert!(matches!(e, HdrIoError::Truncated { .. }), "{cut}: {e:?}");
        assert!(e.to_string().contains(expect), "{cut}: {e}");
    }
}
