//! tonegate's tone mapper in an application's own frame loop: the
//! application opens its device, renders an HDR image with a compute
//! shader of its own into an `Rgba16Float` texture each frame, and records
//! tonegate's `ToneMapper` into the same command encoder, into the next of
//! a ring of three `Bgra8UnormSrgb` render targets (what a swap chain
//! hands out). The scene goes from a dim room into daylight and back; eye
//! adaptation follows it over a second or so instead of at once, and the
//! player's exposure compensation changes every frame. Nothing is compiled
//! after `prepare`.
//!
//! ```text
//! cargo run --example tone_mapper [OUT.png] [OPERATOR]
//! ```
//!
//! OPERATOR is any of `tonegate operators` (default `agx`); OUT.png gets
//! the last frame. Every tenth frame is read back and printed.

use tonegate::operators::{Operator, Value};
use tonegate::scene::Adaptation;
use tonegate::{ToneMapper, ToneMapperSettings};

const WIDTH: u32 = 640;
const HEIGHT: u32 = 360;
const FRAMES: u32 = 150;
const TARGET: wgpu::TextureFormat = wgpu::TextureFormat::Bgra8UnormSrgb;

/// The application's own renderer: a sky that brightens toward a sun
/// 10⁴ times brighter than its shadows, in linear scene units, times the
/// frame's light.
const SCENE: &str = r#"
@group(0) @binding(0) var frame: texture_storage_2d<rgba16float, write>;
@group(0) @binding(1) var<uniform> light: vec4<f32>;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(frame);
    if (id.x >= size.x || id.y >= size.y) {
        return;
    }
    let uv = (vec2<f32>(id.xy) + 0.5) / vec2<f32>(size);
    let sky = mix(vec3<f32>(0.9, 1.0, 1.2), vec3<f32>(0.15, 0.3, 0.8), uv.y);
    let d = distance(uv * vec2<f32>(16.0 / 9.0, 1.0), vec2<f32>(1.2, 0.3));
    let sun = vec3<f32>(1.0, 0.9, 0.7) * 2000.0 * exp(-d * d * 900.0);
    let ground = vec3<f32>(0.02, 0.015, 0.01) * (1.0 + 0.5 * sin(uv.x * 60.0));
    let c = select(sky + sun, ground, uv.y > 0.7);
    textureStore(frame, vec2<i32>(id.xy), vec4<f32>(c * light.x, 1.0));
}
"#;

/// The scene's light: a dim room, daylight from frame 30, the room again
/// from frame 100.
fn light(n: u32) -> f32 {
    if (30..100).contains(&n) {
        1.0
    } else {
        0.02
    }
}

/// The player's exposure compensation, moving every frame: ±½ stop.
fn exposure(n: u32) -> f64 {
    (0.5 * (n as f64 / 12.0).sin()).exp2()
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let out = args.first().map(std::path::PathBuf::from);
    let name = args.get(1).map_or("agx", String::as_str).to_owned();
    let operator = |n: u32| Operator::named(&name, &[("exposure", Value::Number(exposure(n)))]);

    // The application's device: nothing of tonegate's.
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle());
    let adapter = pollster::block_on(instance.request_adapter(&Default::default()))?;
    let (device, queue) =
        pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor::default()))?;
    println!("device: {}", adapter.get_info().name);

    let texture = |format, usage| {
        device.create_texture(&wgpu::TextureDescriptor {
            label: Some("application"),
            size: wgpu::Extent3d {
                width: WIDTH,
                height: HEIGHT,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage,
            view_formats: &[],
        })
    };
    let hdr = texture(
        wgpu::TextureFormat::Rgba16Float,
        wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::TEXTURE_BINDING,
    );
    let hdr_view = hdr.create_view(&Default::default());
    // The swap chain: three render targets, used in turn.
    let ring: Vec<wgpu::Texture> = (0..3)
        .map(|_| {
            texture(
                TARGET,
                wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            )
        })
        .collect();
    let ring_views: Vec<wgpu::TextureView> = ring
        .iter()
        .map(|t| t.create_view(&Default::default()))
        .collect();

    let scene = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("application.scene"),
        layout: None,
        module: &device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("application.scene"),
            source: wgpu::ShaderSource::Wgsl(SCENE.into()),
        }),
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let light_buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("application.light"),
        size: 16,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let scene_bindings = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("application.scene"),
        layout: &scene.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(&hdr_view),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: light_buffer.as_entire_binding(),
            },
        ],
    });

    let settings = |n: u32| -> Result<ToneMapperSettings, Box<dyn std::error::Error>> {
        Ok(ToneMapperSettings {
            operator: operator(n)?,
            target: TARGET,
            adaptation: Some(Adaptation::default()),
            ..Default::default()
        })
    };
    let mut mapper = ToneMapper::new(&device, &queue, settings(0)?)?;
    mapper.set_frame_seconds(1.0 / 60.0)?;
    // Every pipeline now, so that no frame compiles one.
    mapper.prepare()?;
    let prepared = mapper.compiled_pipelines();
    println!("pipelines compiled by prepare: {prepared}");

    let row = (WIDTH * 4).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("application.readback"),
        size: (row * HEIGHT) as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut last = Vec::new();
    for n in 0..FRAMES {
        queue.write_buffer(
            &light_buffer,
            0,
            bytemuck::bytes_of(&[light(n), 0.0, 0.0, 0.0]),
        );
        // A uniform write: the exposure is in the operator's uniform.
        mapper.set_settings(settings(n)?)?;
        let target = &ring[n as usize % 3];
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&scene);
            pass.set_bind_group(0, &scene_bindings, &[]);
            pass.dispatch_workgroups(WIDTH.div_ceil(8), HEIGHT.div_ceil(8), 1);
        }
        mapper.record(&mut encoder, &hdr_view, &ring_views[n as usize % 3])?;
        let shown = n % 10 == 9 || n + 1 == FRAMES;
        if shown {
            encoder.copy_texture_to_buffer(
                target.as_image_copy(),
                wgpu::TexelCopyBufferInfo {
                    buffer: &readback,
                    layout: wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(row),
                        rows_per_image: None,
                    },
                },
                target.size(),
            );
        }
        queue.submit([encoder.finish()]);
        if !shown {
            continue;
        }
        readback
            .slice(..)
            .map_async(wgpu::MapMode::Read, |r| r.expect("readback maps"));
        device.poll(wgpu::PollType::wait_indefinitely())?;
        let mut rgba = Vec::with_capacity((WIDTH * HEIGHT * 4) as usize);
        {
            let mapped = readback.slice(..).get_mapped_range()?;
            for y in 0..HEIGHT {
                for px in mapped[(y * row) as usize..][..(WIDTH * 4) as usize].chunks_exact(4) {
                    rgba.extend_from_slice(&[px[2], px[1], px[0], px[3]]);
                }
            }
        }
        readback.unmap();
        let mean = rgba.iter().map(|&b| b as f64).sum::<f64>() / rgba.len() as f64;
        let adapted = mapper.read_adapted_luminance()?.unwrap_or(f64::NAN);
        println!(
            "frame {n:3}: light {:5.2}, exposure {:5.3}, adapted luminance {adapted:8.5}, mean byte {mean:5.1}",
            light(n),
            exposure(n),
        );
        // A frame that is all one value means the passes did not run.
        let (lo, hi) = rgba
            .iter()
            .fold((255u8, 0u8), |(lo, hi), &b| (lo.min(b), hi.max(b)));
        if lo == hi {
            return Err(format!("frame {n}: every byte is {lo}: not rendered").into());
        }
        last = rgba;
    }
    let compiled = mapper.compiled_pipelines() - prepared;
    println!(
        "{FRAMES} frames with {} into a ring of three {TARGET:?} targets; pipelines compiled after prepare: {compiled}",
        mapper.settings().operator.name()
    );
    if compiled != 0 {
        return Err("a frame compiled a pipeline".into());
    }
    if let Some(path) = out {
        image::save_buffer(&path, &last, WIDTH, HEIGHT, image::ExtendedColorType::Rgba8)?;
        println!("wrote {}", path.display());
    }
    Ok(())
}
