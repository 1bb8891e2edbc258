//! Writes the seed corpora under fuzz/corpus/: real files of every format
//! the targets read, small so the fuzzer's mutations stay fast. The built-in
//! environments in every EXR compression the `exr` crate writes (scan lines
//! and tiles, f16, f32 and u32, RGB, luminance, two parts), in Radiance and
//! PFM, PNGs, and the repository's scene and suite files and test data.
//!
//! cargo run --manifest-path fuzz/Cargo.toml --bin make_seeds

use exr::prelude::*;
use std::path::{Path, PathBuf};
use tonegate::env::BuiltinEnv;
use tonegate::image::HdrImage;

const W: usize = 24;
const H: usize = 12;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn put(target: &str, name: &str, bytes: &[u8]) {
    let dir = repo().join("fuzz/corpus").join(target);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join(name), bytes).unwrap();
}

fn envs() -> Vec<(&'static str, HdrImage)> {
    ["sky", "interior", "night", "grid"]
        .into_iter()
        .map(|n| {
            let env = BuiltinEnv::from_name(n).unwrap();
            (n, env.generate(W as u32, H as u32))
        })
        .collect()
}

fn exr_file(img: &HdrImage, compression: Compression, tiles: bool, kind: u8) -> Option<Vec<u8>> {
    let px = |i: usize, c: usize| img.pixels[i][c];
    let n = W * H;
    let channel = |name: &str, c: usize| -> AnyChannel<FlatSamples> {
        let samples = match kind {
            0 => FlatSamples::F16((0..n).map(|i| f16::from_f32(px(i, c))).collect()),
            1 => FlatSamples::F32((0..n).map(|i| px(i, c)).collect()),
            _ => FlatSamples::U32((0..n).map(|i| (px(i, c) * 100.0) as u32).collect()),
        };
        AnyChannel::new(name, samples)
    };
    let channels = if kind == 3 {
        smallvec::smallvec![channel("Y", 1)]
    } else {
        smallvec::smallvec![channel("R", 0), channel("G", 1), channel("B", 2)]
    };
    let blocks = if tiles {
        Blocks::Tiles(Vec2(8, 8))
    } else {
        Blocks::ScanLines
    };
    let encoding = Encoding {
        compression,
        blocks,
        line_order: LineOrder::Increasing,
    };
    let layer = Layer::new(
        (W, H),
        LayerAttributes::named("rgb"),
        encoding,
        AnyChannels::sort(channels),
    );
    let mut out = std::io::Cursor::new(Vec::new());
    Image::from_layer(layer)
        .write()
        .to_buffered(&mut out)
        .ok()?;
    Some(out.into_inner())
}

fn two_parts(img: &HdrImage) -> Vec<u8> {
    let layer = |name: &str, compression| {
        let samples = |c: usize| FlatSamples::F32(img.pixels.iter().map(|p| p[c]).collect());
        Layer::new(
            (W, H),
            LayerAttributes::named(name),
            Encoding {
                compression,
                blocks: Blocks::ScanLines,
                line_order: LineOrder::Increasing,
            },
            AnyChannels::sort(smallvec::smallvec![
                AnyChannel::new("R", samples(0)),
                AnyChannel::new("G", samples(1)),
                AnyChannel::new("B", samples(2)),
            ]),
        )
    };
    let mut out = std::io::Cursor::new(Vec::new());
    Image::from_layers(
        ImageAttributes::new(IntegerBounds::from_dimensions((W, H))),
        smallvec::smallvec![
            layer("first", Compression::ZIP16),
            layer("second", Compression::RLE)
        ],
    )
    .write()
    .to_buffered(&mut out)
    .unwrap();
    out.into_inner()
}

fn ours(img: &HdrImage, ext: &str) -> Vec<u8> {
    let dir = std::env::temp_dir().join(format!("tonegate-seeds-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("seed.{ext}"));
    tonegate::io::write_image_hdr(&path, img).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    bytes
}

fn main() {
    let compressions = [
        ("none", Compression::Uncompressed),
        ("rle", Compression::RLE),
        ("zip1", Compression::ZIP1),
        ("zip16", Compression::ZIP16),
        ("piz", Compression::PIZ),
        ("pxr24", Compression::PXR24),
        ("b44", Compression::B44),
        ("b44a", Compression::B44A),
    ];
    let envs = envs();
    for (n, img) in &envs {
        put("exr", &format!("{n}-ours-zip16.exr"), &ours(img, "exr"));
        put("radiance", &format!("{n}.hdr"), &ours(img, "hdr"));
        put("pfm", &format!("{n}.pfm"), &ours(img, "pfm"));
        let resolved = tonegate::toning::ToneSettings::default().resolve().unwrap();
        let (_, ldr) = tonegate::reference::render_flat(img, &resolved.pipeline()).unwrap();
        put(
            "png",
            &format!("{n}.png"),
            &tonegate::io::encode_png8(&ldr.frame.into_rgb8().unwrap()).unwrap(),
        );
    }
    let (_, sky) = &envs[0];
    for (name, compression) in compressions {
        for (kind, kind_name) in [(0, "f16"), (1, "f32"), (2, "u32"), (3, "y")] {
            for tiles in [false, true] {
                let layout = if tiles { "tiles" } else { "lines" };
                match exr_file(sky, compression, tiles, kind) {
                    Some(b) => put("exr", &format!("sky-{name}-{kind_name}-{layout}.exr"), &b),
                    None => eprintln!("exr does not write {name} {kind_name} {layout}"),
                }
            }
        }
    }
    put("exr", "two-parts.exr", &two_parts(sky));
    for e in std::fs::read_dir(repo().join("tests/data")).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "exr") {
            put(
                "exr",
                p.file_name().unwrap().to_str().unwrap(),
                &std::fs::read(&p).unwrap(),
            );
        }
    }
    // The structured target's plain file (see its unit test), and noise.
    put("exr_structured", "plain", &[1, 1, 1, 1, 0, 1, 1, 3, 1, 1]);
    put(
        "exr_structured",
        "tiled",
        &[1, 0, 1, 1, 3, 1, 1, 7, 1, 9, 1, 3, 1, 3],
    );
    put(
        "exr_structured",
        "multipart",
        &[0, 2, 1, 1, 1, 4, 1, 1, 5, 1, 5],
    );
    for e in std::fs::read_dir(repo().join("golden/scenes")).unwrap() {
        let p = e.unwrap().path();
        put(
            "scene_toml",
            p.file_name().unwrap().to_str().unwrap(),
            &std::fs::read(&p).unwrap(),
        );
    }
    put(
        "suite_toml",
        "suite.toml",
        &std::fs::read(repo().join("golden/suite.toml")).unwrap(),
    );
    put(
        "suite_toml",
        "policy.toml",
        b"scenes = [\"scenes/grid-static.toml\"]\nstress = false\n[performance]\nwindow = 5\nmin_runs = 2\nmads = 3.0\nmin_relative = 0.2\nfail_on_regression = true\n",
    );
    for (i, q) in [
        "gpu=false&operator=reinhard-global&key=0.18&white_fraction=0.8",
        "operator=seed001&key=auto&bloom=0.5&bloom_pass=threshold&bloom_threshold=1.5",
        "operator=reinhard02&white=40&log_average=0.2&colour=xyy&gamma=2.2",
        "preset=reinhard02&key=0.3&format=json&sanitize=true",
        "brightness=1.2&contrast=0.9&saturation=1.1&bloom_downsample=4&bloom_radius=8&bloom_sigma=2",
        "gpu=true\noperator=reinhard-auto-key\nbloom=0.25",
    ]
    .iter()
    .enumerate()
    {
        put("tonemap_params", &format!("q{i}"), q.as_bytes());
    }
    let sample = &ours(sky, "hdr");
    let mut form = format!(
        "--fuzzboundary\r\nContent-Disposition: form-data; name=\"operator\"\r\n\r\nseed001\r\n\
         --fuzzboundary\r\nContent-Disposition: form-data; name=\"file\"; filename=\"sky.hdr\"\r\n\
         Content-Type: application/octet-stream\r\n\r\n"
    )
    .into_bytes();
    form.extend(sample);
    form.extend(b"\r\n--fuzzboundary--\r\n");
    put("multipart", "form-with-file", &form);
    put(
        "multipart",
        "fields-only",
        b"--fuzzboundary\r\nContent-Disposition: form-data; name=\"key\"\r\n\r\nauto\r\n--fuzzboundary--\r\n",
    );
    for (i, j) in [
        "",
        "{}",
        "{\"renderer\": \"cpu\", \"spp\": 4}",
        "{\"renderer\": \"gpu\"}",
        "{\"spp\": 300}",
    ]
    .iter()
    .enumerate()
    {
        put("runs_json", &format!("j{i}"), j.as_bytes());
    }
}
