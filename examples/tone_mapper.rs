//! tonegate's tone mapper inside an application's own frame: the
//! application opens its device, renders an HDR image with a compute
//! shader of its own into an `Rgba16Float` texture, and records tonegate's
//! `ToneMapper` into the same command encoder, writing an 8-bit texture it
//! then copies out; one submit for all of it.
//!
//! ```text
//! cargo run --example tone_mapper [OUT.png] [OPERATOR]
//! ```
//!
//! OPERATOR is any of `tonegate operators` (default `agx`); without OUT.png
//! it only prints what it did.

use tonegate::operators::Operator;
use tonegate::scene::Encoding;
use tonegate::{ToneMapper, ToneMapperSettings};

const WIDTH: u32 = 640;
const HEIGHT: u32 = 360;

/// The application's own renderer: a sky that brightens toward a sun
/// 10⁴ times brighter than its shadows, in linear scene units.
const SCENE: &str = r#"
@group(0) @binding(0) var frame: texture_storage_2d<rgba16float, write>;

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
    textureStore(frame, vec2<i32>(id.xy), vec4<f32>(c, 1.0));
}
"#;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let out = args.first().map(std::path::PathBuf::from);
    let operator = Operator::named(args.get(1).map_or("agx", String::as_str), &[])?;

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
    let ldr = texture(
        wgpu::TextureFormat::Rgba8Unorm,
        wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::COPY_SRC,
    );

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
    let scene_bindings = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("application.scene"),
        layout: &scene.get_bind_group_layout(0),
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: wgpu::BindingResource::TextureView(&hdr.create_view(&Default::default())),
        }],
    });

    let mut mapper = ToneMapper::new(
        &device,
        &queue,
        ToneMapperSettings {
            operator,
            encoding: Encoding::Srgb,
            ..Default::default()
        },
    )?;
    // Every pipeline now, so the first frame does not compile any.
    mapper.prepare();

    // One frame: the application's pass, tonegate's, the copy out.
    let row = (WIDTH * 4).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("application.readback"),
        size: (row * HEIGHT) as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&scene);
        pass.set_bind_group(0, &scene_bindings, &[]);
        pass.dispatch_workgroups(WIDTH.div_ceil(8), HEIGHT.div_ceil(8), 1);
    }
    mapper.record(
        &mut encoder,
        &hdr.create_view(&Default::default()),
        &ldr.create_view(&Default::default()),
    )?;
    encoder.copy_texture_to_buffer(
        ldr.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &readback,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(row),
                rows_per_image: None,
            },
        },
        ldr.size(),
    );
    queue.submit([encoder.finish()]);
    readback
        .slice(..)
        .map_async(wgpu::MapMode::Read, |r| r.expect("readback maps"));
    device.poll(wgpu::PollType::wait_indefinitely())?;

    let mapped = readback.slice(..).get_mapped_range()?;
    let mut rgba = Vec::with_capacity((WIDTH * HEIGHT * 4) as usize);
    for y in 0..HEIGHT {
        rgba.extend_from_slice(&mapped[(y * row) as usize..][..(WIDTH * 4) as usize]);
    }
    let mean = rgba.iter().map(|&b| b as f64).sum::<f64>() / rgba.len() as f64;
    println!(
        "tone-mapped {WIDTH}x{HEIGHT} with {} on the application's device: mean byte {mean:.1}",
        mapper.settings().operator.name()
    );
    // A frame that is all one value means the passes did not run.
    let (lo, hi) = rgba
        .iter()
        .fold((255u8, 0u8), |(lo, hi), &b| (lo.min(b), hi.max(b)));
    if lo == hi {
        return Err(format!("every byte is {lo}: the frame was not rendered").into());
    }
    if let Some(path) = out {
        image::save_buffer(&path, &rgba, WIDTH, HEIGHT, image::ExtendedColorType::Rgba8)?;
        println!("wrote {}", path.display());
    }
    Ok(())
}
