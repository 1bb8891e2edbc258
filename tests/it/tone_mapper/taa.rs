//! TAA in the embedding: an application's jittered frames and motion
//! vectors through `ToneMapper::record_with_motion`, held stage by stage to
//! the f64 `taa` fed the same inputs, and frame by frame to the gate's own
//! TAA of the same sequence, which finds the history by the camera instead.

use super::{hdr_input, own_device, read, texture, view, Texel};
use crate::common;
use tonegate::conventions::{reproject, reprojection, rotation_matrix, taa_jitter, Camera, Mat3};
use tonegate::gpu::{
    AdapterChoice, GpuConfig, GpuContext, MotionVectors, ToneMapper, ToneMapperError,
    ToneMapperSettings,
};
use tonegate::image::{Frame, HdrImage, Image, LinearImage};
use tonegate::reference::scene_camera;
use tonegate::reference::taa::{taa, Reprojection, TaaFrame};
use tonegate::reference::taa_sobel::taa_sobel;
use tonegate::render::scene_environment;
use tonegate::scene::Taa;
use wgpu::TextureFormat as F;
use wgpu::TextureUsages as U;

/// The application's motion vectors for the sphere's turn `m`, in pixels
/// (now minus then), as f32: the camera's reprojection of each pixel
/// centre, and for a point that was not on the film a vector that leaves it.
fn motion_vectors(camera: &Camera, m: &Mat3) -> Image<[f32; 2]> {
    Image::from_fn(camera.width, camera.height, |i, j| {
        match reproject(camera, m, i, j) {
            Some((px, py)) => [(i as f64 + 0.5 - px) as f32, (j as f64 + 0.5 - py) as f32],
            None => [1e6, 1e6],
        }
    })
}

fn upload_motion(device: &wgpu::Device, queue: &wgpu::Queue, v: &Image<[f32; 2]>) -> wgpu::Texture {
    let usage = U::TEXTURE_BINDING | U::COPY_DST;
    let t = texture(device, (v.width, v.height), 1, F::Rg32Float, usage);
    write(queue, &t, &v.pixels.concat());
    t
}

/// Rewrites the whole of `t` with `texels`.
fn write(queue: &wgpu::Queue, t: &wgpu::Texture, texels: &[f32]) {
    let bytes = t.format().block_copy_size(None).unwrap();
    queue.write_texture(
        t.as_image_copy(),
        bytemuck::cast_slice(texels),
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(t.width() * bytes),
            rows_per_image: None,
        },
        t.size(),
    );
}

/// The largest |a − b| / (rel·|b| + abs) over every channel.
fn worst(a: &LinearImage, b: &LinearImage, rel: f64, abs: f64) -> f64 {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| (0..3).map(move |c| (p[c] - q[c]).abs() / (rel * q[c].abs() + abs)))
        .fold(0.0, f64::max)
}

/// The largest code difference between a target read back and a frame,
/// and how many codes differ.
fn code_gap(target: &[Texel], frame: &Frame) -> (u16, usize) {
    let Frame::Rgb8(f) = frame else {
        panic!("an 8-bit frame")
    };
    let gaps = target.iter().zip(&f.pixels).flat_map(|(t, p)| match t {
        Texel::Codes(c) => [0, 1, 2].map(|k| c[k].abs_diff(u16::from(p[k]))),
        Texel::Half(_) => panic!("an 8-bit target"),
    });
    gaps.fold((0, 0), |(most, n), g| (most.max(g), n + usize::from(g > 0)))
}

/// Each frame of a turning sphere, rendered and resolved by the gate
/// (which reprojects by the camera), and the same jittered frames with
/// motion vectors through a `ToneMapper` on an application's device: the
/// mapper's new history against the f64 `taa` fed the mapper's previous
/// history, this frame and the same vectors; and its bytes against the
/// gate's frame. A mapper given zero vectors is not the gate's frame: the
/// vectors are what find the history.
///
/// Tolerances. The history: 2e-4 relative plus 2e-4 of the frame's largest
/// value, the gate's own bound for its `taa` stage against the f64 one
/// (tests/it/taa.rs, where its origin is written: an f32 history point
/// ~1e-5 px off the f64 one, through bilinear or Catmull-Rom weights and
/// the interior map's ~1e3:1 edges); the point rebuilt from an f32 vector
/// is off by as little. Frame counts are small integers: exact. The bytes:
/// one code. Both TAA outputs are within that bound of the f64 one, 4e-4
/// apart at most, and a relative change of 4e-4 moves the sRGB encoding by
/// at most 4e-4 · 255 / 2.4 < 0.05 of a code, so a byte differs only where
/// the value sits within that of a rounding boundary, and then by one.
#[test]
fn taa_in_the_embedding_matches_the_reference_and_the_gates_frames() {
    for adapter in ["llvmpipe", "swiftshader", "gl:llvmpipe"] {
        embedded_taa_on(adapter);
    }
}

fn embedded_taa_on(adapter: &str) {
    let ctx = GpuContext::new(&adapter.parse::<AdapterChoice>().unwrap()).unwrap();
    let (device, queue) = own_device(adapter);
    // A turning sphere at 0.5° a frame (tests/it/taa.rs's), the default
    // TAA, the edge-aware one sharpened, the variance box as the thesis keys it.
    let cases = [
        ("clip", 0.0, ""),
        ("edge_aware", 0.25, ""),
        (
            "variance",
            0.0,
            "history_filter = \"bilinear\"\nfeedback = \"luminance\"",
        ),
    ];
    for (variant, sharpen, keys) in cases {
        let sc = crate::taa::scene_with(variant, sharpen, 0.5, keys);
        let env = scene_environment(&sc).unwrap();
        let gate = common::scene_renderer(&ctx, &sc, &env, GpuConfig::default());
        let camera = scene_camera(&sc);
        let table: Taa = sc.taa.clone().unwrap();
        let params = table.params();
        let settings = ToneMapperSettings {
            operator: sc.operator.clone(),
            encoding: sc.encoding,
            taa: Some(table.clone()),
            target: F::Rgba8Unorm,
            ..ToneMapperSettings::default()
        };
        let ring_settings = ToneMapperSettings {
            target: F::Bgra8UnormSrgb,
            ..settings.clone()
        };
        let mut mapper = ToneMapper::new(&device, &queue, ring_settings).unwrap();
        let mut still = ToneMapper::new(&device, &queue, settings).unwrap();
        mapper.prepare().unwrap();
        let size = (camera.width, camera.height);
        // The application's textures, made once and written each frame,
        // with a swap chain's ring of three render attachments.
        let input = texture(
            &device,
            size,
            1,
            F::Rgba32Float,
            U::TEXTURE_BINDING | U::COPY_DST,
        );
        let motion = texture(
            &device,
            size,
            1,
            F::Rg32Float,
            U::TEXTURE_BINDING | U::COPY_DST,
        );
        let ring: Vec<wgpu::Texture> = (0..3)
            .map(|_| {
                let usage = U::RENDER_ATTACHMENT | U::COPY_SRC;
                texture(&device, size, 1, F::Bgra8UnormSrgb, usage)
            })
            .collect();
        let ring_views: Vec<wgpu::TextureView> = ring.iter().map(view).collect();
        let (input_view, motion_view) = (view(&input), view(&motion));
        let out = texture(
            &device,
            size,
            1,
            F::Rgba8Unorm,
            U::STORAGE_BINDING | U::COPY_SRC,
        );
        let zero = upload_motion(
            &device,
            &queue,
            &Image::from_fn(camera.width, camera.height, |_, _| [0.0; 2]),
        );
        let (mut worst_history, mut worst_gap, mut still_gap) = (0.0f64, 0u16, 0u16);
        let (mut differing, mut total) = (0, 0);
        for n in 0..sc.frames {
            let rot = rotation_matrix(sc.rotation.axis, sc.angle(n));
            let prev = rotation_matrix(sc.rotation.axis, sc.angle(n.saturating_sub(1)));
            let m = reprojection(&prev, &rot);
            let reset = n == 0 || table.resets_at(n);
            gate.set_frame(&rot, taa_jitter(n));
            gate.set_taa_history((!reset).then_some(&m));
            let frame = gate.render(true).unwrap().frame.unwrap();
            let current = gate.read_output("sphere").unwrap().unwrap();

            // The application's side: its jittered frame and vectors.
            let vectors = motion_vectors(&camera, &m);
            let texels: Vec<f32> = current
                .pixels
                .iter()
                .flat_map(|p| [p[0] as f32, p[1] as f32, p[2] as f32, 1.0])
                .collect();
            write(&queue, &input, &texels);
            write(&queue, &motion, &vectors.pixels.concat());
            let before = mapper.read_history().unwrap();
            if reset {
                mapper.reset_history();
                still.reset_history();
            }
            let mut encoder = device.create_command_encoder(&Default::default());
            let target = n as usize % 3;
            mapper
                .record_with_motion(
                    &mut encoder,
                    &input_view,
                    MotionVectors::pixels(&motion_view),
                    &ring_views[target],
                )
                .unwrap();
            queue.submit([encoder.finish()]);
            let ours = read(&device, &queue, &ring[target], 0);
            let (gap, count) = code_gap(&ours, &frame);
            worst_gap = worst_gap.max(gap);
            differing += count;
            total += 3 * ours.len();

            // Stage by stage: the f64 TAA on the mapper's own inputs.
            let amount = (params.variant == tonegate::scene::TaaVariant::EdgeAware)
                .then(|| taa_sobel(&current));
            let f64_vectors = Image::from_fn(camera.width, camera.height, |i, j| {
                vectors.get(i, j).map(f64::from)
            });
            let cpu = taa(
                &current,
                amount.as_ref(),
                &TaaFrame {
                    history: if reset { None } else { before.as_ref() },
                    reprojection: Reprojection::Motion {
                        vectors: &f64_vectors,
                        scale: MotionVectors::pixels(&motion_view).scale(size),
                    },
                },
                &params,
            );
            let gpu = mapper.read_history().unwrap().unwrap();
            assert_eq!(
                gpu.confidence, cpu.history.confidence,
                "{variant} frame {n}: frame counts"
            );
            let scale = current
                .pixels
                .iter()
                .flatten()
                .fold(0.0f64, |a, &b| a.max(b));
            let e = worst(&gpu.colour, &cpu.history.colour, 2e-4, 2e-4 * scale);
            assert!(
                e <= 1.0,
                "{variant} frame {n}: history off by {e} of the bound"
            );
            worst_history = worst_history.max(e);

            // Zero vectors: the history of the wrong place.
            let mut encoder = device.create_command_encoder(&Default::default());
            let zero_view = view(&zero);
            still
                .record_with_motion(
                    &mut encoder,
                    &input_view,
                    MotionVectors::pixels(&zero_view),
                    &view(&out),
                )
                .unwrap();
            queue.submit([encoder.finish()]);
            still_gap = still_gap.max(code_gap(&read(&device, &queue, &out, 0), &frame).0);
        }
        eprintln!(
            "{adapter} {variant} s={sharpen}: history worst {worst_history:.3} of the bound; bytes off the gate's: {differing} of {total}, by at most {worst_gap}; zero vectors {still_gap}"
        );
        assert!(
            worst_gap <= 1,
            "{variant}: {worst_gap} codes off the gate's frame"
        );
        assert!(
            still_gap > 1,
            "{variant}: zero vectors gave the gate's frame"
        );
    }
}

/// What TAA asks of the frame and its vectors is refused by name.
#[test]
fn taa_refuses_frames_it_cannot_resolve() {
    let (device, queue) = own_device("llvmpipe");
    let settings = ToneMapperSettings {
        taa: Some(Taa::default()),
        target: F::Rgba8Unorm,
        ..ToneMapperSettings::default()
    };
    let mut mapper = ToneMapper::new(&device, &queue, settings.clone()).unwrap();
    let img = HdrImage::from_fn(8, 6, |x, y| [x as f32, y as f32, 1.0]);
    let input = hdr_input(&device, &queue, &img);
    let out = texture(&device, (8, 6), 1, F::Rgba8Unorm, U::STORAGE_BINDING);
    let good = upload_motion(&device, &queue, &Image::from_fn(8, 6, |_, _| [0.0; 2]));
    let small = upload_motion(&device, &queue, &Image::from_fn(4, 6, |_, _| [0.0; 2]));
    let wrong = texture(&device, (8, 6), 1, F::R32Float, U::TEXTURE_BINDING);
    let unbound = texture(&device, (8, 6), 1, F::Rg16Float, U::COPY_DST);
    let mut encoder = device.create_command_encoder(&Default::default());
    let (iv, ov) = (view(&input), view(&out));
    let e = mapper.record(&mut encoder, &iv, &ov).unwrap_err();
    assert!(matches!(e, ToneMapperError::NoMotionVectors), "{e}");
    assert!(e.to_string().contains("record_with_motion"), "{e}");
    let mut try_with = |motion: &wgpu::Texture| {
        let mv = view(motion);
        mapper.record_with_motion(&mut encoder, &iv, MotionVectors::pixels(&mv), &ov)
    };
    let e = try_with(&small).unwrap_err();
    assert!(
        matches!(
            e,
            ToneMapperError::MotionSize {
                motion: (4, 6),
                input: (8, 6)
            }
        ),
        "{e}"
    );
    let e = try_with(&wrong).unwrap_err();
    assert!(
        matches!(
            e,
            ToneMapperError::MotionFormat {
                format: F::R32Float
            }
        ),
        "{e}"
    );
    let e = try_with(&unbound).unwrap_err();
    assert!(
        e.to_string()
            .contains("motion vectors texture lacks TEXTURE_BINDING"),
        "{e}"
    );
    try_with(&good).unwrap();
    // TAA reads the whole first level.
    let part = {
        let mv = view(&good);
        mapper.record_with_motion(
            &mut encoder,
            tonegate::gpu::SourceView::from(&iv).with_size(4, 6),
            MotionVectors::pixels(&mv),
            tonegate::gpu::TargetView::from(&ov).at(0, 0),
        )
    };
    assert!(matches!(
        part,
        Err(ToneMapperError::TaaInput {
            level: 0,
            size: (4, 6),
            texture: (8, 6)
        })
    ));
    // Settings a scene would refuse.
    let mut bad = Taa::default();
    (bad.feedback_min, bad.feedback_max) = (bad.feedback_max, bad.feedback_min);
    let e = mapper
        .set_settings(ToneMapperSettings {
            taa: Some(bad),
            ..settings.clone()
        })
        .unwrap_err();
    assert_eq!(
        e.to_string(),
        "taa.feedback_min: 0.97 exceeds feedback_max 0.88"
    );
    // Without TAA the vectors are not needed, and not refused.
    let settings_without_taa = ToneMapperSettings {
        taa: None,
        ..settings
    };
    let mut plain = ToneMapper::new(&device, &queue, settings_without_taa).unwrap();
    plain.record(&mut encoder, &iv, &ov).unwrap();
    let mv = view(&small);
    plain
        .record_with_motion(&mut encoder, &iv, MotionVectors::pixels(&mv), &ov)
        .unwrap();
}
