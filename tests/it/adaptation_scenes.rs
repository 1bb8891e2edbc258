//! Eye adaptation as a game runs it: five sequences through `ToneMapper`
//! on lavapipe at 60 frames a second with the default adaptation
//! (histogram metering, the EV clamp, stops per second) and AgX. Each
//! frame's adapted EV is held to the f64 reference (`reference::histogram`,
//! `reference::adaptation`) fed the same frames, within a bound derived
//! below, and each output frame's clipped fraction (pixels with a channel
//! at code 255) to what a game needs.

use crate::tone_mapper::{hdr_input, own_device, read, texture, view, Texel};
use tonegate::env::BuiltinEnv;
use tonegate::image::HdrImage;
use tonegate::operators::Operator;
use tonegate::reference::adaptation::{adapt, Adapted, Metered};
use tonegate::reference::histogram::{histogram, mask_weight, BINS};
use tonegate::scene::Adaptation;
use tonegate::{ToneMapper, ToneMapperSettings};

pub(crate) const DT: f64 = 1.0 / 60.0;
const W: u32 = 128;
const H: u32 = 72;
const LN2: f64 = std::f64::consts::LN_2;

/// One sequence's run: per frame, the adapted EV on the GPU and in f64,
/// the bound between them, and the clipped fraction where it was read.
pub(crate) struct Run {
    pub gpu: Vec<f64>,
    pub cpu: Vec<f64>,
    pub bound: Vec<f64>,
    pub clipped: Vec<Option<f64>>,
    /// The fraction of pixels with every channel at 0, where read.
    pub black: Vec<Option<f64>>,
}

/// A frame of a sequence: its image, uploaded as `Rgba16Float` (the
/// reference then reads its f16 values) or `Rgba32Float`.
#[derive(Clone)]
pub(crate) struct Input {
    pub image: HdrImage,
    pub half: bool,
}

pub(crate) fn sky() -> HdrImage {
    BuiltinEnv::Sky.generate(W, H)
}

pub(crate) fn scaled(img: &HdrImage, s: f32) -> HdrImage {
    HdrImage::from_fn(img.width, img.height, |x, y| {
        img.pixels[(x + img.width * y) as usize].map(|v| v * s)
    })
}

fn upload(device: &wgpu::Device, queue: &wgpu::Queue, input: &Input) -> wgpu::Texture {
    if !input.half {
        return hdr_input(device, queue, &input.image);
    }
    let t = texture(
        device,
        (input.image.width, input.image.height),
        1,
        wgpu::TextureFormat::Rgba16Float,
        wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
    );
    let texels: Vec<u16> = input
        .image
        .pixels
        .iter()
        .flat_map(|p| [p[0], p[1], p[2], 1.0].map(|c| half::f16::from_f32(c).to_bits()))
        .collect();
    queue.write_texture(
        t.as_image_copy(),
        bytemuck::cast_slice(&texels),
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(input.image.width * 8),
            rows_per_image: None,
        },
        t.size(),
    );
    t
}

/// What the reference reads of an input: its f16 values when uploaded as
/// f16 (a value past f16's range is +inf there too).
fn as_read(input: &Input) -> HdrImage {
    if !input.half {
        return input.image.clone();
    }
    HdrImage::from_fn(input.image.width, input.image.height, |x, y| {
        input.image.pixels[(x + input.image.width * y) as usize]
            .map(|c| half::f16::from_f32(c).to_f32())
    })
}

/// The bound on a frame's metered EV, GPU against f64: a pixel whose bin
/// position lies within 1e-4 of a bin edge may fall on the other side in
/// f32 (its luminance and log2 carry a few ulp, 1e-6 of a bin at most),
/// and moving one pixel's weight w one bin moves the kept mean by at most
/// 2·w·range / kept (its own bin and the cut's); plus the f32 sums of the
/// mean (64 terms, at most 64·2⁻²⁴ of the largest |EV|).
fn metering_bound(img: &HdrImage, weights: [f64; 3], a: &Adaptation) -> f64 {
    let range = a.max_ev - a.min_ev;
    let per_ev = BINS as f64 / range;
    let mut ambiguous = 0u64;
    let mut total = 0u64;
    for (i, p) in img.pixels.iter().enumerate() {
        let y = tonegate::color::luminance_with(p.map(f64::from), weights);
        if !(y.is_finite() && y > 0.0) {
            continue;
        }
        let w = mask_weight(a.mask, i as u32 % img.width, i as u32 / img.width, W, H);
        total += w;
        let at = (y.log2() - a.min_ev) * per_ev;
        if (at - at.round()).abs() < 1e-4 && (0.5..BINS as f64 - 0.5).contains(&at) {
            ambiguous += w;
        }
    }
    let kept = (a.high - a.low) * total.max(1) as f64;
    let f32_sums = 64.0 * 2f64.powi(-24) * a.min_ev.abs().max(a.max_ev.abs());
    2.0 * ambiguous as f64 * range / kept + f32_sums
}

/// A mapper of `op` with `a`, into `Rgba8Unorm`, at 60 frames a second.
pub(crate) fn adapting_mapper(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    op: &Operator,
    a: Adaptation,
) -> ToneMapper {
    let mut mapper = ToneMapper::new(
        device,
        queue,
        ToneMapperSettings {
            operator: op.clone(),
            adaptation: Some(a),
            target: wgpu::TextureFormat::Rgba8Unorm,
            ..Default::default()
        },
    )
    .unwrap();
    mapper.set_frame_seconds(DT).unwrap();
    mapper
}

/// Runs `frames` (indices into `inputs`) through one mapper with `a` and
/// `operator`, reading the output of the frames `read_at` says.
pub(crate) fn run(
    inputs: &[Input],
    frames: &[usize],
    a: Adaptation,
    operator: &str,
    read_at: impl Fn(usize) -> bool,
) -> Run {
    let (device, queue) = own_device("llvmpipe");
    let textures: Vec<wgpu::Texture> = inputs.iter().map(|i| upload(&device, &queue, i)).collect();
    let views: Vec<wgpu::TextureView> = textures.iter().map(view).collect();
    let output = texture(
        &device,
        (W, H),
        1,
        wgpu::TextureFormat::Rgba8Unorm,
        wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::COPY_SRC,
    );
    let out = view(&output);
    let op = Operator::named(operator, &[]).unwrap();
    let weights = op.luminance().weights;
    let mut mapper = adapting_mapper(&device, &queue, &op, a);
    // The reference's metering of each input, once.
    let metered: Vec<(Metered, f64)> = inputs
        .iter()
        .map(|i| {
            let img = as_read(i);
            let h = histogram(&img.to_linear(), weights, &a);
            (
                Metered::histogram(&h, &a, op.needs()),
                metering_bound(&img, weights, &a),
            )
        })
        .collect();
    let mut cpu: Option<Adapted> = None;
    let mut run = Run {
        gpu: Vec::new(),
        cpu: Vec::new(),
        bound: Vec::new(),
        clipped: Vec::new(),
        black: Vec::new(),
    };
    // |Δ adapted| ≤ max over frames of |Δ target| (the rule moves by
    // clamp(gap·n, ±s), n ≤ 1: a contraction in the adapted value and the
    // target, so a target's error is never amplified and does not add up)
    // plus each frame's f32 rounding of the step (4 ulp of the largest
    // |ln|, which does add up).
    let (mut worst_target, mut rounding) = (0f64, 0f64);
    let largest = a.min_ev.abs().max(a.max_ev.abs()) * LN2;
    for (n, &k) in frames.iter().enumerate() {
        let mut encoder = device.create_command_encoder(&Default::default());
        mapper.record(&mut encoder, &views[k], &out).unwrap();
        queue.submit([encoder.finish()]);
        let gpu = mapper.read_adapted_luminance().unwrap().unwrap();
        let next = adapt(metered[k].0, cpu.as_ref(), &a, DT);
        cpu = Some(next);
        worst_target = worst_target.max(metered[k].1 * LN2);
        rounding += 4.0 * 2f64.powi(-24) * largest;
        run.gpu.push(gpu.ln() / LN2);
        run.cpu.push(next.log_average / LN2);
        run.bound.push((worst_target + rounding) / LN2);
        let texels = read_at(n).then(|| read(&device, &queue, &output, 0));
        run.clipped.push(texels.as_deref().map(clipped));
        run.black.push(texels.as_deref().map(|t| {
            let n = t
                .iter()
                .filter(|t| matches!(t, Texel::Codes([0, 0, 0])))
                .count();
            n as f64 / t.len() as f64
        }));
    }
    run
}

/// The fraction of pixels with a channel at the top code.
pub(crate) fn clipped(texels: &[Texel]) -> f64 {
    let n = texels
        .iter()
        .filter(|t| matches!(t, Texel::Codes(c) if c.contains(&255)))
        .count();
    n as f64 / texels.len() as f64
}

/// Every frame's GPU EV within its bound of the f64 reference's; the
/// worst error as a fraction of the bound.
pub(crate) fn check_curve(name: &str, run: &Run) -> f64 {
    let mut worst = 0f64;
    for (n, ((g, c), b)) in run.gpu.iter().zip(&run.cpu).zip(&run.bound).enumerate() {
        assert!(g.is_finite(), "{name} frame {n}: adapted EV {g}");
        let e = (g - c).abs();
        assert!(
            e <= *b,
            "{name} frame {n}: GPU {g:.6} EV, f64 {c:.6} ({e:.2e} > {b:.2e})"
        );
        worst = worst.max(e / b);
    }
    worst
}

pub(crate) fn print_curve(name: &str, run: &Run, every: usize) {
    for n in (0..run.gpu.len()).step_by(every) {
        let clip = run.clipped[n].map_or(String::new(), |c| format!(" clipped {:.3}", c));
        println!(
            "{name} frame {n:4}: adapted EV gpu {:+.4} f64 {:+.4}{clip}",
            run.gpu[n], run.cpu[n]
        );
    }
}

/// Out of a tunnel into daylight, 1,000 times brighter: the two inputs,
/// and the frames, 2 s in the tunnel (input 0), then 3 s outside.
pub(crate) fn tunnel() -> ([Input; 2], Vec<usize>) {
    let day = sky();
    let inputs = [
        Input {
            image: scaled(&day, 1e-3),
            half: false,
        },
        Input {
            image: day,
            half: false,
        },
    ];
    (inputs, (0..300).map(|n| usize::from(n >= 120)).collect())
}

#[test]
fn a_tunnel_exit_clips_for_at_most_ten_frames_and_follows_its_f64_curve() {
    let (inputs, frames) = tunnel();
    let run = run(&inputs, &frames, Adaptation::default(), "agx", |n| n >= 110);
    let worst = check_curve("tunnel", &run);
    print_curve("tunnel", &run, 5);
    let over: Vec<usize> = (120..300)
        .filter(|&n| run.clipped[n].unwrap() > 0.10)
        .collect();
    println!("tunnel: worst {worst:.3} of the bound; frames > 10 % clipped: {over:?}");
    assert!(
        over.len() <= 10,
        "{} frames over 10 % clipped: {over:?}",
        over.len()
    );
    for (n, (g, c)) in run.gpu.iter().zip(&run.cpu).enumerate() {
        assert!((g - c).abs() <= 0.05, "frame {n}: {g} {c}");
    }
}

/// Ten seconds of black after daylight: the clamp keeps the adapted value
/// from falling past `min_ev`, so the first bright frame after is mostly
/// unclipped.
#[test]
fn after_ten_seconds_of_black_the_first_bright_frame_clips_at_most_five_percent() {
    let day = sky();
    let black = HdrImage::from_fn(W, H, |_, _| [0.0; 3]);
    let inputs = [
        Input {
            image: day,
            half: false,
        },
        Input {
            image: black,
            half: false,
        },
    ];
    let frames: Vec<usize> = (0..661)
        .map(|n| usize::from((60..660).contains(&n)))
        .collect();
    let a = Adaptation::default();
    let mut table = Vec::new();
    for min_ev in [a.min_ev, -8.0, -4.0] {
        let a = Adaptation { min_ev, ..a };
        let run = run(&inputs, &frames, a, "agx", |n| n == 59 || n == 660);
        check_curve("black", &run);
        assert!((run.gpu[659] - a.min_ev).abs() < 0.2, "{}", run.gpu[659]);
        table.push((
            min_ev,
            run.clipped[59].unwrap(),
            run.clipped[660].unwrap(),
            run.gpu[659],
        ));
    }
    for (min_ev, day, first, ev) in &table {
        println!(
            "black: min_ev {min_ev:+.1}: daylight {day:.4} clipped; after 10 s black adapted {ev:+.3} EV, first bright frame {first:.4} clipped"
        );
    }
    let first = table[0].2;
    assert!(first <= 0.05, "{first}");
}

/// One frame 1,000 times brighter (a muzzle flash, lightning): the
/// adapted value moves by at most one frame of `stops_up`, and then back
/// inside the transition, exponentially: a second later the gap is at
/// most the jump times (1 − `stops_down`·Δt / `transition`)⁵⁹.
#[test]
fn a_one_frame_flash_moves_the_adapted_value_by_one_frame_of_speed_at_most() {
    let room = BuiltinEnv::Interior.generate(W, H);
    let inputs = [
        Input {
            image: room.clone(),
            half: false,
        },
        Input {
            image: scaled(&room, 1e3),
            half: false,
        },
    ];
    let frames: Vec<usize> = (0..180).map(|n| usize::from(n == 60)).collect();
    let a = Adaptation::default();
    let run = run(&inputs, &frames, a, "agx", |n| (59..=62).contains(&n));
    check_curve("flash", &run);
    print_curve("flash", &run, 10);
    let settled = run.gpu[59];
    let jump = run.gpu[60] - settled;
    println!(
        "flash: settled {settled:+.4} EV, flash frame {:+.4} (+{jump:.4}), a second later {:+.4}; clipped {:?}",
        run.gpu[60],
        run.gpu[120],
        &run.clipped[59..=62]
    );
    let most = a.stops_up.get() * DT;
    assert!(jump > 0.0 && jump <= most + 1e-5, "{jump} > {most}");
    let left = jump * (1.0 - a.stops_down.get() * DT / a.transition).powi(59);
    assert!(
        (run.gpu[120] - settled).abs() <= left + 1e-5,
        "{} {left}",
        run.gpu[120]
    );
}

/// A sun (1.5 % of the frame at 10⁵) enters a dim frame: the percentile
/// filter drops it, and the adapted value moves by less than 0.1 EV; with
/// nothing dropped it moves by more.
#[test]
fn a_sun_entering_a_dim_frame_moves_the_adapted_value_less_than_a_tenth_of_a_stop() {
    let dim = scaled(&sky(), 0.05);
    let with_sun = HdrImage::from_fn(W, H, |x, y| {
        let (dx, dy) = (x as f32 - 90.0, y as f32 - 20.0);
        if dx * dx + dy * dy < 44.0 {
            [1e5; 3]
        } else {
            dim.pixels[(x + W * y) as usize]
        }
    });
    let sun_pixels = with_sun.pixels.iter().filter(|p| p[0] == 1e5).count();
    let inputs = [
        Input {
            image: dim,
            half: false,
        },
        Input {
            image: with_sun,
            half: false,
        },
    ];
    let frames: Vec<usize> = (0..150).map(|n| usize::from(n >= 30)).collect();
    let filtered = Adaptation::default();
    let unfiltered = Adaptation {
        low: 0.0,
        high: 1.0,
        ..filtered
    };
    let mut moved = Vec::new();
    for (name, a) in [("filtered", filtered), ("unfiltered", unfiltered)] {
        let run = run(&inputs, &frames, a, "agx", |_| false);
        check_curve(name, &run);
        moved.push(run.gpu[149] - run.gpu[29]);
    }
    println!(
        "sun: {sun_pixels} pixels ({:.2} %); adapted EV moved {:+.4} with 10 %…90 % kept, {:+.4} with all",
        100.0 * sun_pixels as f64 / f64::from(W * H),
        moved[0],
        moved[1]
    );
    assert!(moved[0].abs() < 0.1, "{}", moved[0]);
    assert!(moved[1] > 0.1, "{}", moved[1]);
}

/// One pixel past f16's range in an `Rgba16Float` input (+inf there): the
/// histogram skips it, the adapted value stays finite and on its f64
/// curve, and no frame after it is black.
#[test]
fn an_overflowing_half_float_pixel_blacks_out_no_frame() {
    let day = sky();
    let mut spiked = day.clone();
    spiked.pixels[(40 + W * 30) as usize] = [1e6; 3];
    let inputs = [
        Input {
            image: day,
            half: true,
        },
        Input {
            image: spiked,
            half: true,
        },
    ];
    assert!(as_read(&inputs[1]).pixels[(40 + W * 30) as usize][0].is_infinite());
    let frames: Vec<usize> = (0..60).map(|n| usize::from(n == 30)).collect();
    for operator in ["agx", "reinhard-global"] {
        let run = run(&inputs, &frames, Adaptation::default(), operator, |n| {
            n >= 29
        });
        check_curve(operator, &run);
        let lit = |n: usize| 1.0 - black(&run, n);
        println!(
            "overflow {operator}: adapted EV {:+.4} before, {:+.4} on the spike's frame, {:+.4} after",
            run.gpu[29], run.gpu[30], run.gpu[59]
        );
        for n in 30..60 {
            assert!(run.gpu[n].is_finite(), "{operator} frame {n}");
            assert!(lit(n) > 0.5, "{operator} frame {n} is {:.3} lit", lit(n));
        }
    }
}

/// The fraction of frame `n` that is black (all of it, unread).
fn black(run: &Run, n: usize) -> f64 {
    run.black[n].unwrap_or(1.0)
}
