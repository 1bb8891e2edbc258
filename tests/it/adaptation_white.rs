//! `reinhard-global`'s white point under eye adaptation (lavapipe): it is
//! 0.8 × the frame's largest luminance, so one bright pixel (10⁶ in a sky
//! whose sun is 1.2·10⁵) used to swing the whole frame darker for the
//! frame it was in. With `adapt_white` the white point follows the largest
//! luminance at the adaptation's speed: the pixel's frame moves by what
//! one frame of `stops_up` allows, and its bytes are the f64 pipeline's
//! with the reference's adapted statistics.

use crate::adaptation_scenes::{adapting_mapper, sky, DT};
use crate::tone_mapper::{hdr_input, own_device, read, texture, view, Texel};
use tonegate::operators::Operator;
use tonegate::reference::adaptation::{adapt, Adapted, Metered};
use tonegate::reference::histogram::histogram;
use tonegate::reference::{encode, luminance_stats, tonemap};
use tonegate::scene::{Adaptation, Encoding};

fn mean_code(texels: &[Texel]) -> f64 {
    let sum: u64 = texels
        .iter()
        .map(|t| match t {
            Texel::Codes(c) => c.iter().map(|&v| u64::from(v)).sum::<u64>(),
            Texel::Half(_) => unreachable!(),
        })
        .sum();
    sum as f64 / (3 * texels.len()) as f64
}

#[test]
fn one_bright_pixel_moves_reinhard_globals_white_by_one_frame_of_speed() {
    let (device, queue) = own_device("llvmpipe");
    let calm = sky();
    let mut spike = calm.clone();
    spike.pixels[(40 + calm.width * 30) as usize] = [1e6; 3];
    let images = [&calm, &spike];
    let inputs: Vec<wgpu::Texture> = images
        .iter()
        .map(|i| hdr_input(&device, &queue, i))
        .collect();
    let views: Vec<wgpu::TextureView> = inputs.iter().map(view).collect();
    let output = texture(
        &device,
        (calm.width, calm.height),
        1,
        wgpu::TextureFormat::Rgba8Unorm,
        wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::COPY_SRC,
    );
    let out = view(&output);
    let op = Operator::named("reinhard-global", &[]).unwrap();
    assert!(op.needs().max);
    let lum = op.luminance();
    let frames: Vec<usize> = (0..40).map(|n| usize::from(n == 30)).collect();
    let mut swing = Vec::new();
    for adapt_white in [true, false] {
        let a = Adaptation {
            adapt_white,
            ..Adaptation::default()
        };
        let mut mapper = adapting_mapper(&device, &queue, &op, a);
        let mut cpu: Option<Adapted> = None;
        let mut means = Vec::new();
        for (n, &k) in frames.iter().enumerate() {
            let mut encoder = device.create_command_encoder(&Default::default());
            mapper.record(&mut encoder, &views[k], &out).unwrap();
            queue.submit([encoder.finish()]);
            let linear = images[k].to_linear();
            let stats =
                luminance_stats::luminance_stats(&linear, op.needs(), lum.weights, lum.delta);
            let h = histogram(&linear, lum.weights, &a);
            let measured =
                Metered::histogram(&h, &a, op.needs()).with_white(&stats, &a, op.needs());
            let next = adapt(measured, cpu.as_ref(), &a, DT);
            cpu = Some(next);
            if !(29..=31).contains(&n) {
                continue;
            }
            let got = read(&device, &queue, &output, 0);
            means.push(mean_code(&got));
            // The f64 pipeline with the reference's adapted statistics:
            // within one code, where a value lies on a rounding boundary.
            let tone = op.resolve(&next.statistics(&stats)).unwrap();
            let want = encode::encode(&tonemap::tonemap(&linear, &tone), Encoding::Srgb);
            let mut off = 0;
            for (g, w) in got.iter().zip(&want.pixels) {
                let Texel::Codes(g) = g else { unreachable!() };
                for c in 0..3 {
                    let d = (i32::from(g[c]) - i32::from(w[c])).abs();
                    assert!(
                        d <= 1,
                        "adapt_white {adapt_white} frame {n}: a code {d} off"
                    );
                    off += usize::from(d == 1);
                }
            }
            assert!(off * 100 <= got.len() * 3, "frame {n}: {off} codes one off");
        }
        println!(
            "white: adapt_white {adapt_white}: mean code {:.2} before the pixel, {:.2} on its frame, {:.2} after",
            means[0], means[1], means[2]
        );
        swing.push((means[1] - means[0]).abs());
    }
    // Adapted: the white moves by at most one frame of stops_up (0.2
    // stops); each frame's own: it jumps by log2(1e6 / 1.2e5) = 3 stops.
    assert!(swing[0] < 2.0, "{swing:?}");
    assert!(swing[1] > 10.0 * swing[0].max(0.5), "{swing:?}");
}
