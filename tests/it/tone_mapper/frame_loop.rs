//! The tone mapper in a real frame loop: a swap chain hands out a new
//! texture each frame, an application makes a new view of it each frame
//! (docs/embedding.md's snippet), and several cameras are recorded into
//! one submission with other settings each. Counted with the mapper's own
//! [`ToneMapper::created`]: once warm, a frame creates no texture, buffer
//! or pipeline.

use super::*;
use tonegate::gpu::Created;
use tonegate::operators::Value;
use tonegate::{ToneMapper, ToneMapperSettings};

/// How an application hands the mapper its targets.
#[derive(Clone, Copy, Debug)]
enum Targets {
    /// Three textures and their views, made once.
    ViewsKept,
    /// Three textures, a new view of one each frame.
    NewView,
    /// A new texture and a new view each frame: what a swap chain's
    /// `get_current_texture` amounts to for a cache keyed by identity.
    NewTexture,
}

fn agx(target: wgpu::TextureFormat, path: OutputPath, exposure: f64) -> ToneMapperSettings {
    ToneMapperSettings {
        operator: Operator::named("agx", &[("exposure", Value::Number(exposure))]).unwrap(),
        target,
        path,
        ..Default::default()
    }
}

/// 200 frames in the docs' loop: per frame a new exposure
/// (`set_exposure`), a target, `record`, `submit`. Returns what frames 2…200
/// created and the last target with the exposure it was mapped at.
fn run_loop(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    input: &wgpu::TextureView,
    size: (u32, u32),
    (target, path): (wgpu::TextureFormat, OutputPath),
    targets: Targets,
) -> (Created, wgpu::Texture, f64) {
    let usage = usage_for(path);
    let ring: Vec<wgpu::Texture> = (0..3)
        .map(|_| texture(device, size, 1, target, usage))
        .collect();
    let kept: Vec<wgpu::TextureView> = ring.iter().map(view).collect();
    let exposure = |n: u32| 0.5 + 0.01 * f64::from(n % 50);
    let mut mapper = ToneMapper::new(device, queue, agx(target, path, exposure(0))).unwrap();
    mapper.prepare().unwrap();
    let mut after_first = Created::default();
    let mut last = None;
    for n in 0..200u32 {
        assert!(mapper.set_exposure(exposure(n) as f32));
        let mut encoder = device.create_command_encoder(&Default::default());
        let frame = match targets {
            Targets::NewTexture => texture(device, size, 1, target, usage),
            _ => ring[n as usize % 3].clone(),
        };
        let made;
        let view = match targets {
            Targets::ViewsKept => &kept[n as usize % 3],
            _ => {
                made = frame.create_view(&Default::default());
                &made
            }
        };
        mapper.record(&mut encoder, input, view).unwrap();
        queue.submit([encoder.finish()]);
        if n == 0 {
            after_first = mapper.created();
        }
        last = Some((frame, exposure(n)));
    }
    let (frame, exposure) = last.unwrap();
    (mapper.created() - after_first, frame, exposure)
}

/// The same image into a render attachment and a storage target, with the
/// targets kept, a new view of them each frame, and a new texture each
/// frame: after the first frame, no texture, buffer or pipeline is created
/// in any of them, and a render attachment needs no bind group either (a
/// storage target not written lately costs its two: the dispatch's and
/// its extent's). The last frame is a fresh mapper's frame at its exposure, so
/// what was kept was right.
#[test]
fn a_swap_chain_loop_creates_nothing_per_frame_once_warm() {
    let (device, queue) = own_device("llvmpipe");
    let img = night_and_ramp();
    let size = (img.width, img.height);
    let input = view(&hdr_input(&device, &queue, &img));
    let mut table = Vec::new();
    for (target, path) in [
        (F::Bgra8UnormSrgb, OutputPath::RenderPass),
        (F::Rgba8Unorm, OutputPath::Compute),
    ] {
        for targets in [Targets::ViewsKept, Targets::NewView, Targets::NewTexture] {
            let (created, frame, exposure) =
                run_loop(&device, &queue, &input, size, (target, path), targets);
            table.push(format!("{target:?} {path:?} {targets:?}: {created:?}"));
            // A storage target the mapper has not written lately costs
            // two bind groups: the kept ring's second and third targets
            // once, a new view every frame.
            let per_frame_groups = match (path, targets) {
                (OutputPath::Compute, Targets::ViewsKept) => 2 * 2,
                (OutputPath::Compute, Targets::NewView | Targets::NewTexture) => 2 * 199,
                _ => 0,
            };
            assert_eq!(
                created,
                Created {
                    textures: 0,
                    buffers: 0,
                    bind_groups: per_frame_groups,
                    pipelines: 0,
                },
                "{target:?} {path:?} {targets:?}"
            );
            let got = read(&device, &queue, &frame, 0);
            let fresh_target = texture(&device, size, 1, target, usage_for(path));
            let mut fresh = ToneMapper::new(&device, &queue, agx(target, path, exposure)).unwrap();
            let mut encoder = device.create_command_encoder(&Default::default());
            fresh
                .record(&mut encoder, &input, &view(&fresh_target))
                .unwrap();
            queue.submit([encoder.finish()]);
            assert!(
                got == read(&device, &queue, &fresh_target, 0),
                "{target:?} {path:?} {targets:?}: the last frame differs from a fresh mapper's"
            );
        }
    }
    eprintln!("created over frames 2..=200:\n{}", table.join("\n"));
}

/// Two cameras through one mapper in one submission, each with its own
/// exposure and into its own target (one by a render pass, one by a
/// compute pass): each target holds the bytes its camera's settings give
/// when recorded and submitted alone. Before settings belonged to the
/// record, the first camera came out at the second one's exposure.
#[test]
fn two_cameras_in_one_submission_each_keep_their_own_settings() {
    let (device, queue) = own_device("llvmpipe");
    let img = night_and_ramp();
    let size = (img.width, img.height);
    let input = view(&hdr_input(&device, &queue, &img));
    let near = tonegate::env::BuiltinEnv::Sky.generate(size.0, size.1);
    let near = view(&hdr_input(&device, &queue, &near));
    // The path is Auto, so only the exposure changes between records: a
    // storage target is written by a compute pass, a render attachment by
    // a render pass.
    let cameras = [
        (&input, OutputPath::Compute, 0.5),
        (&near, OutputPath::RenderPass, 2.0),
        (&input, OutputPath::RenderPass, 4.0),
    ];
    let targets: Vec<wgpu::Texture> = cameras
        .iter()
        .map(|(_, path, _)| texture(&device, size, 1, F::Rgba8Unorm, usage_for(*path)))
        .collect();
    let settings = |exposure| agx(F::Rgba8Unorm, OutputPath::Auto, exposure);
    let mut mapper = ToneMapper::new(&device, &queue, settings(1.0)).unwrap();
    mapper.prepare().unwrap();
    let warm = mapper.created();
    let mut encoder = device.create_command_encoder(&Default::default());
    for ((input, _, exposure), target) in cameras.iter().zip(&targets) {
        mapper.set_settings(settings(*exposure)).unwrap();
        mapper.record(&mut encoder, *input, &view(target)).unwrap();
    }
    queue.submit([encoder.finish()]);
    assert_eq!(
        mapper.created().pipelines,
        warm.pipelines,
        "an exposure compiled"
    );
    let together: Vec<Vec<Texel>> = targets
        .iter()
        .map(|t| read(&device, &queue, t, 0))
        .collect();
    let mut alone = Vec::new();
    for ((input, _, exposure), target) in cameras.iter().zip(&targets) {
        let mut m = ToneMapper::new(&device, &queue, settings(*exposure)).unwrap();
        let mut encoder = device.create_command_encoder(&Default::default());
        m.record(&mut encoder, *input, &view(target)).unwrap();
        queue.submit([encoder.finish()]);
        alone.push(read(&device, &queue, target, 0));
    }
    for (i, (t, a)) in together.iter().zip(&alone).enumerate() {
        assert!(t == a, "camera {i} differs from its single record");
    }
    // The exposures differ, so the cameras of the same input do too.
    assert!(together[0] != together[2]);
}

/// A second mapper for another camera (its own adaptation state) shares
/// the first one's compiled pipelines: preparing it compiles nothing.
#[test]
fn a_mapper_sharing_pipelines_compiles_nothing_the_first_has() {
    let (device, queue) = own_device("llvmpipe");
    let settings = agx(F::Bgra8UnormSrgb, OutputPath::Auto, 1.0);
    let mut first = ToneMapper::new(&device, &queue, settings.clone()).unwrap();
    first.prepare().unwrap();
    let compiled = first.compiled_pipelines();
    assert!(compiled >= 2, "{compiled}");
    let mut second = first
        .sharing_pipelines(agx(F::Bgra8UnormSrgb, OutputPath::Auto, 3.0))
        .unwrap();
    second.prepare().unwrap();
    assert_eq!(second.created().pipelines, 0, "{:?}", second.created());
    assert_eq!(second.compiled_pipelines(), compiled);
    // A mapper of its own compiles them again.
    let mut own = ToneMapper::new(&device, &queue, settings).unwrap();
    own.prepare().unwrap();
    assert_eq!(own.created().pipelines as usize, compiled);
}

/// One record by `mapper` of `input` (of `size`) into a new target of
/// (format, usage), submitted and read back.
fn mapped(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    mapper: &mut ToneMapper,
    (input, size): (&wgpu::Texture, (u32, u32)),
    (format, usage): (wgpu::TextureFormat, wgpu::TextureUsages),
) -> Vec<Texel> {
    let output = texture(device, size, 1, format, usage);
    let mut encoder = device.create_command_encoder(&Default::default());
    mapper
        .record(&mut encoder, &view(input), &view(&output))
        .unwrap();
    queue.submit([encoder.finish()]);
    read(device, queue, &output, 0)
}

/// The default settings map into a swap chain's format: a render
/// attachment with no storage binding, written by the fullscreen triangle,
/// with the bytes the compute path writes into `Rgba8Unorm` in RGBA order.
#[test]
fn the_default_settings_write_a_swap_chains_format() {
    let (device, queue) = own_device("llvmpipe");
    let settings = ToneMapperSettings::default();
    assert_eq!(settings.target, F::Bgra8UnormSrgb);
    let img = night_and_ramp();
    let input = hdr_input(&device, &queue, &img);
    let size = (img.width, img.height);
    let frame = |settings: ToneMapperSettings, usage| {
        let target = (settings.target, usage);
        let mut mapper = ToneMapper::new(&device, &queue, settings).unwrap();
        mapped(&device, &queue, &mut mapper, (&input, size), target)
    };
    let swap = frame(settings.clone(), U::RENDER_ATTACHMENT | U::COPY_SRC);
    let storage = ToneMapperSettings {
        target: F::Rgba8Unorm,
        path: OutputPath::Compute,
        ..settings
    };
    let rgba = frame(storage, U::STORAGE_BINDING | U::COPY_SRC);
    assert!(
        swap == rgba,
        "the default target's codes differ from Rgba8Unorm's"
    );
}

/// `set_exposure` maps as `set_settings` with that exposure does, bit for
/// bit (AgX's word as it is, three.js's ACES fit's over 0.6), and refuses
/// nothing: an operator without an exposure says so and keeps mapping as
/// before, a NaN leaves the exposure, an absurd one is held to the range.
#[test]
fn set_exposure_maps_as_the_exposure_parameter_does() {
    let (device, queue) = own_device("llvmpipe");
    let img = night_and_ramp();
    let input = hdr_input(&device, &queue, &img);
    let size = (img.width, img.height);
    let usage = U::STORAGE_BINDING | U::COPY_SRC;
    let frame = |mapper: &mut ToneMapper| {
        mapped(
            &device,
            &queue,
            mapper,
            (&input, size),
            (F::Rgba8Unorm, usage),
        )
    };
    let settings = |name: &str, exposure: f64| ToneMapperSettings {
        operator: Operator::named(name, &[("exposure", Value::Number(exposure))]).unwrap(),
        target: F::Rgba8Unorm,
        ..Default::default()
    };
    for name in ["agx", "aces-hill"] {
        let mut fast = ToneMapper::new(&device, &queue, settings(name, 1.0)).unwrap();
        for e in [0.5f32, 2.0, 3.7] {
            assert!(fast.set_exposure(e));
            let mut slow = ToneMapper::new(&device, &queue, settings(name, f64::from(e))).unwrap();
            assert!(frame(&mut fast) == frame(&mut slow), "{name} at {e}");
        }
        let before = fast.exposure();
        assert!(fast.set_exposure(f32::NAN));
        assert_eq!(
            fast.exposure(),
            before,
            "{name}: a NaN changed the exposure"
        );
        assert!(fast.set_exposure(f32::INFINITY));
        let mut top = ToneMapper::new(&device, &queue, settings(name, 1e6)).unwrap();
        assert!(
            frame(&mut fast) == frame(&mut top),
            "{name}: +inf is not held to 1e6"
        );
    }
    let reinhard = ToneMapperSettings {
        target: F::Rgba8Unorm,
        ..Default::default()
    };
    let mut plain = ToneMapper::new(&device, &queue, reinhard.clone()).unwrap();
    let as_set = frame(&mut plain);
    assert!(!plain.set_exposure(4.0));
    assert_eq!(plain.exposure(), None);
    assert!(
        frame(&mut plain) == as_set,
        "an operator without an exposure changed"
    );
}
