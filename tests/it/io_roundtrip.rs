//! Write-then-read round trips for every output format, the load report, and
//! the writers' refusals (unknown extensions, unstorable values, bad images),
//! which must never replace a good file.

use std::fs;
use std::path::Path;

use tonegate::image::{HdrImage, Image, Rgb8Image};
use tonegate::io::{
    decode_hdr, encode_png8, load_hdr, read_png16, read_png8, write_image_hdr, write_png16,
    write_png8, HdrFormat, HdrIoError, LoadOptions, Rgb16Image,
};

/// Positive values over 60 stops, including f32 subnormals and huge values,
/// so that an exact round trip means the bits survive, not just the look.
fn wide_range_image(width: u32, height: u32) -> HdrImage {
    Image::from_fn(width, height, |x, y| {
        let i = (y * width + x) as i32;
        [
            2f32.powi(i % 61 - 30) * 1.37,
            1e-40 * (i + 1) as f32, // subnormal
            (x as f32 + 0.1) * 3.0e30 + y as f32,
        ]
    })
}

fn only_entries(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn exr_and_pfm_round_trip_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let image = wide_range_image(37, 21);
    for (name, format) in [
        ("a.exr", HdrFormat::Exr),
        ("a.pfm", HdrFormat::Pfm),
        ("B.EXR", HdrFormat::Exr),
    ] {
        let path = dir.path().join(name);
        write_image_hdr(&path, &image).unwrap();
        let (read, report) = load_hdr(&path, &LoadOptions::default()).unwrap();
        assert_eq!(report.format, format, "{name}");
        let same_bits = read
            .pixels
            .iter()
            .flatten()
            .zip(image.pixels.iter().flatten())
            .all(|(a, b)| a.to_bits() == b.to_bits());
        assert!(same_bits && read.width == 37 && read.height == 21, "{name}");
    }
}

#[test]
fn radiance_round_trips_within_a_255th_of_each_pixels_largest_component() {
    // RGBE keeps an 8-bit mantissa per component under the exponent of the
    // largest one, m. The writer rounds to nearest: half a unit is at most
    // m / 256, or m / 255.5 when m rounds up into the next exponent (see
    // src/io/radiance.rs), so that is the bound; the pixel (7.995, 0.03125)
    // below hits it. Widths 5 (flat scan lines) and 300 (RLE).
    let dir = tempfile::tempdir().unwrap();
    for width in [5, 300] {
        let image = Image::from_fn(width, 7, |x, y| {
            let t = (x + width * y) as f32;
            [
                2f32.powf(t % 40.0 - 20.0),
                t * 0.013,
                if x % 3 == 0 { 0.0 } else { 0.5 },
            ]
        });
        let path = dir.path().join(format!("w{width}.hdr"));
        write_image_hdr(&path, &image).unwrap();
        let (read, report) = load_hdr(&path, &LoadOptions::default()).unwrap();
        assert_eq!(report.format, HdrFormat::Radiance);
        assert_eq!((read.width, read.height), (width, 7));
        for (got, want) in read.pixels.iter().zip(&image.pixels) {
            let largest = want.iter().fold(0.0f64, |m, &c| m.max(f64::from(c)));
            for c in 0..3 {
                let error = (f64::from(got[c]) - f64::from(want[c])).abs();
                assert!(error <= largest / 255.5, "{want:?} came back as {got:?}");
            }
        }
    }
}

#[test]
fn png8_and_png16_round_trip_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let rgb8: Rgb8Image = Image::from_fn(19, 11, |x, y| {
        [(x * 13) as u8, (y * 23) as u8, (x ^ y) as u8]
    });
    let path8 = dir.path().join("golden.png");
    write_png8(&path8, &rgb8).unwrap();
    assert_eq!(read_png8(&path8).unwrap(), rgb8);
    assert_eq!(encode_png8(&rgb8).unwrap(), fs::read(&path8).unwrap());

    let rgb16: Rgb16Image = Image::from_fn(19, 11, |x, y| {
        [(x * 3001) as u16, (y * 5953) as u16, 65535 - x as u16]
    });
    let path16 = dir.path().join("deep.PNG");
    write_png16(&path16, &rgb16).unwrap();
    assert_eq!(read_png16(&path16).unwrap(), rgb16);

    // The bit depth is never converted silently.
    assert!(matches!(
        read_png16(&path8),
        Err(HdrIoError::Unsupported { .. })
    ));
    assert!(matches!(
        read_png8(&path16),
        Err(HdrIoError::Unsupported { .. })
    ));
}

#[test]
fn grey_and_opaque_alpha_pngs_read_as_rgb_but_transparency_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let grey = dir.path().join("grey.png");
    image::GrayImage::from_fn(4, 3, |x, y| image::Luma([(x * 10 + y) as u8]))
        .save(&grey)
        .unwrap();
    assert_eq!(read_png8(&grey).unwrap().get(3, 2), [32, 32, 32]);

    let opaque = dir.path().join("opaque.png");
    image::RgbaImage::from_fn(4, 3, |x, _| image::Rgba([x as u8, 1, 2, 255]))
        .save(&opaque)
        .unwrap();
    assert_eq!(read_png8(&opaque).unwrap().get(2, 1), [2, 1, 2]);

    let clear = dir.path().join("clear.png");
    image::RgbaImage::from_fn(4, 3, |x, y| {
        image::Rgba([0, 0, 0, if (x, y) == (1, 2) { 7 } else { 255 }])
    })
    .save(&clear)
    .unwrap();
    let message = read_png8(&clear).unwrap_err().to_string();
    assert!(
        message.contains("clear.png") && message.contains("pixel 9"),
        "{message}"
    );
}

#[test]
fn the_format_comes_from_the_bytes_not_the_extension() {
    let dir = tempfile::tempdir().unwrap();
    let pfm = dir.path().join("really-a-pfm.pfm");
    write_image_hdr(&pfm, &wide_range_image(3, 2)).unwrap();
    let misnamed = dir.path().join("misnamed.exr");
    fs::copy(&pfm, &misnamed).unwrap();
    let (_, report) = load_hdr(&misnamed, &LoadOptions::default()).unwrap();
    assert_eq!(report.format, HdrFormat::Pfm);
}

#[test]
fn decode_hdr_and_load_hdr_agree() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("same.exr");
    let image = wide_range_image(8, 8);
    write_image_hdr(&path, &image).unwrap();
    let from_file = load_hdr(&path, &LoadOptions::default()).unwrap();
    let (from_bytes, report) = decode_hdr(
        &fs::read(&path).unwrap(),
        "upload-17",
        &LoadOptions::default(),
    )
    .unwrap();
    assert_eq!(from_bytes, from_file.0);
    assert_eq!(report.source, "upload-17");
    assert_eq!(
        report.log_average_luminance,
        from_file.1.log_average_luminance
    );
}

#[test]
fn the_report_describes_the_image() {
    // 2×2 grey: Y = 0, 0.5, 2 and 8 (grey RGB has Y = v since the weights sum to 1).
    let image = Image {
        width: 2,
        height: 2,
        pixels: vec![[0.0; 3], [0.5; 3], [2.0; 3], [8.0; 3]],
    };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("stats.pfm");
    write_image_hdr(&path, &image).unwrap();
    let (_, report) = load_hdr(&path, &LoadOptions::default()).unwrap();
    assert_eq!((report.width, report.height), (2, 2));
    assert_eq!(report.channels, vec!["R", "G", "B"]);
    assert_eq!(report.min_luminance, 0.0);
    assert!((report.max_luminance - 8.0).abs() < 1e-12);
    assert!((report.dynamic_range_stops - 4.0).abs() < 1e-12); // log2(8 / 0.5)
    let expected = ((1e-4f64.ln() + 0.5001f64.ln() + 2.0001f64.ln() + 8.0001f64.ln()) / 4.0).exp();
    assert!((report.log_average_luminance - expected).abs() < 1e-12);
    assert_eq!(
        (report.clamped_negative, report.sanitized_nonfinite),
        (0, 0)
    );

    let json = serde_json::to_value(&report).unwrap();
    assert_eq!(json["format"], "pfm");
    assert_eq!(
        json["dynamic_range_stops"].as_f64().map(f64::round),
        Some(4.0)
    );
}

#[test]
fn writing_exr_is_deterministic() {
    let dir = tempfile::tempdir().unwrap();
    let image = wide_range_image(64, 48);
    let (a, b) = (dir.path().join("a.exr"), dir.path().join("b.exr"));
    write_image_hdr(&a, &image).unwrap();
    write_image_hdr(&b, &image).unwrap();
    assert_eq!(fs::read(a).unwrap(), fs::read(b).unwrap());
}

#[test]
fn unknown_extensions_are_refused_with_the_supported_list() {
    let dir = tempfile::tempdir().unwrap();
    let image = wide_range_image(2, 2);
    let message = write_image_hdr(&dir.path().join("out.tiff"), &image)
        .unwrap_err()
        .to_string();
    assert!(
        message.contains("out.tiff")
            && message.contains(".exr")
            && message.contains(".pfm")
            && message.contains(".hdr"),
        "{message}"
    );
    let no_extension = write_image_hdr(&dir.path().join("out"), &image).unwrap_err();
    assert!(matches!(
        no_extension,
        HdrIoError::UnsupportedExtension { .. }
    ));
    let png = write_png8(
        &dir.path().join("golden.jpg"),
        &Image::filled(2, 2, [0u8; 3]),
    )
    .unwrap_err();
    assert!(png.to_string().contains(".png"), "{png}");
    assert!(only_entries(dir.path()).is_empty());
}

#[test]
fn a_refused_radiance_write_keeps_the_previous_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("keep.hdr");
    write_image_hdr(&path, &Image::filled(12, 4, [1.0f32, 2.0, 3.0])).unwrap();
    let before = fs::read(&path).unwrap();

    // RGBE cannot store negatives or NaN; the encoder writes the whole
    // temporary file before it knows, so this exercises the discard path.
    let mut bad = Image::filled(12, 4, [0.5f32; 3]);
    bad.pixels[3 * 12 + 5] = [f32::NAN, -1.0, 0.5];
    bad.pixels[3 * 12 + 9] = [0.5, -2.0, 0.5];
    let message = write_image_hdr(&path, &bad).unwrap_err().to_string();
    assert!(
        message.starts_with(&path.display().to_string()),
        "{message}"
    );
    assert!(
        message.contains("3 components") && message.contains("(5, 3)"),
        "{message}"
    );
    assert_eq!(fs::read(&path).unwrap(), before);
    assert_eq!(only_entries(dir.path()), vec!["keep.hdr"]);
}

#[test]
fn inconsistent_or_empty_images_are_refused_before_any_file_is_made() {
    let dir = tempfile::tempdir().unwrap();
    let short = Image {
        width: 4,
        height: 4,
        pixels: vec![[0.0f32; 3]; 15],
    };
    let empty: HdrImage = Image {
        width: 0,
        height: 3,
        pixels: vec![],
    };
    for name in ["a.exr", "a.pfm", "a.hdr"] {
        assert!(matches!(
            write_image_hdr(&dir.path().join(name), &short),
            Err(HdrIoError::BadImage { .. })
        ));
        assert!(matches!(
            write_image_hdr(&dir.path().join(name), &empty),
            Err(HdrIoError::BadImage { .. })
        ));
    }
    let short8 = Image {
        width: 2,
        height: 2,
        pixels: vec![[0u8; 3]; 3],
    };
    assert!(matches!(
        encode_png8(&short8),
        Err(HdrIoError::BadImage { .. })
    ));
    assert!(only_entries(dir.path()).is_empty());
}
