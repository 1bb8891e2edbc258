//! Two cameras through one `ToneMapper` (lavapipe): a daylight view and
//! one 100 times darker, recorded into one encoder every frame with
//! `set_camera`, across a light change; each camera's adapted curve is
//! the one a mapper of its own gives it, bit for bit.

use crate::adaptation_scenes::{scaled, sky};
use crate::tone_mapper::{hdr_input, own_device, texture, view};
use tonegate::scene::Adaptation;
use tonegate::{ToneMapper, ToneMapperError, ToneMapperSettings};

fn settings() -> ToneMapperSettings {
    ToneMapperSettings {
        operator: tonegate::operators::Operator::named("agx", &[]).unwrap(),
        // A range that holds the dark camera unclamped (the default's
        // −6 EV would stop it 3 stops below the bright one).
        adaptation: Some(Adaptation {
            min_ev: -16.0,
            ..Adaptation::default()
        }),
        target: wgpu::TextureFormat::Rgba8Unorm,
        ..Default::default()
    }
}

#[test]
fn two_cameras_through_one_mapper_each_follow_their_own_curve() {
    let (device, queue) = own_device("llvmpipe");
    let day = sky();
    // Camera 0 sees daylight, then a light 20 times brighter from frame
    // 30; camera 1 the same, 100 times darker.
    let images = [
        scaled(&day, 1.0),
        scaled(&day, 20.0),
        scaled(&day, 0.01),
        scaled(&day, 0.2),
    ];
    let inputs: Vec<wgpu::Texture> = images
        .iter()
        .map(|i| hdr_input(&device, &queue, i))
        .collect();
    let views: Vec<wgpu::TextureView> = inputs.iter().map(view).collect();
    let outputs: Vec<wgpu::Texture> = (0..2)
        .map(|_| {
            texture(
                &device,
                (day.width, day.height),
                1,
                wgpu::TextureFormat::Rgba8Unorm,
                wgpu::TextureUsages::STORAGE_BINDING,
            )
        })
        .collect();
    let outs: Vec<wgpu::TextureView> = outputs.iter().map(view).collect();
    let input = |camera: usize, n: usize| &views[2 * camera + usize::from(n >= 30)];
    let frames = 90;
    // Both cameras through one mapper, one submission a frame.
    let mut shared = ToneMapper::new(&device, &queue, settings()).unwrap();
    let mut both = [Vec::new(), Vec::new()];
    for n in 0..frames {
        let mut encoder = device.create_command_encoder(&Default::default());
        for (camera, out) in outs.iter().enumerate() {
            shared.set_camera(camera).unwrap();
            shared.record(&mut encoder, input(camera, n), out).unwrap();
        }
        queue.submit([encoder.finish()]);
        for (camera, curve) in both.iter_mut().enumerate() {
            shared.set_camera(camera).unwrap();
            curve.push(shared.read_adapted_luminance().unwrap().unwrap());
        }
    }
    // Each camera alone.
    for (camera, curve) in both.iter().enumerate() {
        let mut alone = shared.sharing_pipelines(settings()).unwrap();
        let mut own = Vec::new();
        for n in 0..frames {
            let mut encoder = device.create_command_encoder(&Default::default());
            alone
                .record(&mut encoder, input(camera, n), &outs[camera])
                .unwrap();
            queue.submit([encoder.finish()]);
            own.push(alone.read_adapted_luminance().unwrap().unwrap());
        }
        assert_eq!(curve, &own, "camera {camera}");
        println!(
            "camera {camera}: adapted EV frame 0 {:+.4}, 29 {:+.4}, 40 {:+.4}, 89 {:+.4}",
            curve[0].log2(),
            curve[29].log2(),
            curve[40].log2(),
            curve[89].log2()
        );
    }
    // The two differ: one shared state would have given them one curve.
    let apart = both[0][29] / both[1][29];
    assert!((apart.log2() - 100f64.log2()).abs() < 0.5, "{apart}");
    // The buffer a later pass of the application's binds holds the last
    // record's camera's value (camera 1's: recorded last each frame).
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("application.adapted"),
        size: 16,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    encoder.copy_buffer_to_buffer(shared.adaptation_buffer(), 0, &staging, 0, 16);
    queue.submit([encoder.finish()]);
    staging
        .slice(..)
        .map_async(wgpu::MapMode::Read, |r| r.unwrap());
    device.poll(wgpu::PollType::wait_indefinitely()).unwrap();
    let ln: f32 = bytemuck::pod_read_unaligned(&staging.slice(..).get_mapped_range().unwrap()[..4]);
    assert_eq!(f64::from(ln).exp(), both[1][frames - 1]);
    // A reset is the current camera's; a camera past the last is refused.
    shared.set_camera(1).unwrap();
    shared.reset_adaptation();
    assert_eq!(shared.read_adapted_luminance().unwrap(), None);
    shared.set_camera(0).unwrap();
    assert!(shared.read_adapted_luminance().unwrap().is_some());
    let e = shared.set_camera(tonegate::gpu::MAX_CAMERAS).unwrap_err();
    assert!(matches!(e, ToneMapperError::Camera { .. }), "{e}");
    assert_eq!(shared.camera(), 0);
}
