//! `tonegate::ToneMapper` inside an application that made its own device:
//! the device, queue, textures, views and command encoder are created here
//! with wgpu alone, and what it writes is tonegate's own renderer's frame
//! for the same image on the same adapter: bit for bit in every 8-bit
//! target, within the quantisation of the two encodings in the 10-bit and
//! scRGB ones, and the same bits by the compute and the render-pass path.

mod api;
mod frame_loop;
mod taa;
mod targets;

use tonegate::gpu::{GpuConfig, GpuContext, GpuInput, GpuRenderer, OutputPath};
use tonegate::image::{Frame, HdrImage};
use tonegate::operators::Operator;
use tonegate::plan::{Input, StagePlan};
use tonegate::reference::Pipeline;
use tonegate::scene::{Bloom, Encoding, Grade};
use wgpu::TextureFormat as F;
use wgpu::TextureUsages as U;

/// An application's own device on one of the adapters here, with no
/// features asked for but `BGRA8UNORM_STORAGE` and `TIMESTAMP_QUERY` where
/// the adapter has them (an application that stores into a BGRA swap chain
/// or times its passes would ask): a plain
/// `request_device`, as an application that knows nothing of tonegate
/// would open it. `adapter`: tonegate's `--adapter` for the same one.
pub(crate) fn own_device(adapter: &str) -> (wgpu::Device, wgpu::Queue) {
    let (backend, name) = match adapter {
        "llvmpipe" => (wgpu::Backends::VULKAN, "llvmpipe"),
        "swiftshader" => {
            // Where Debian's chromium puts it, outside the loader's folders.
            tonegate::gpu::adapters::add_extra_vulkan_drivers();
            (wgpu::Backends::VULKAN, "SwiftShader")
        }
        "gl:llvmpipe" => (wgpu::Backends::GL, "llvmpipe"),
        other => panic!("no adapter {other}"),
    };
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = backend;
    let instance = wgpu::Instance::new(desc);
    let adapter = pollster::block_on(instance.enumerate_adapters(backend))
        .into_iter()
        .find(|a| a.get_info().name.contains(name))
        .unwrap_or_else(|| panic!("{adapter} is installed"));
    let features =
        adapter.features() & (wgpu::Features::BGRA8UNORM_STORAGE | wgpu::Features::TIMESTAMP_QUERY);
    pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        required_features: features,
        required_limits: wgpu::Limits::downlevel_defaults().using_resolution(adapter.limits()),
        ..Default::default()
    }))
    .expect("the adapter opens")
}

pub(crate) fn texture(
    device: &wgpu::Device,
    (w, h): (u32, u32),
    levels: u32,
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some("application"),
        size: wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
        mip_level_count: levels,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

pub(crate) fn view(t: &wgpu::Texture) -> wgpu::TextureView {
    t.create_view(&Default::default())
}

pub(crate) fn level_view(t: &wgpu::Texture, level: u32) -> wgpu::TextureView {
    t.create_view(&wgpu::TextureViewDescriptor {
        base_mip_level: level,
        mip_level_count: Some(1),
        ..Default::default()
    })
}

/// `img` in the top-left corner of level `level` of a new `Rgba32Float`
/// texture of `levels` levels whose first level is `size`.
pub(crate) fn hdr_input_in(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    img: &HdrImage,
    size: (u32, u32),
    levels: u32,
    level: u32,
) -> wgpu::Texture {
    let t = texture(
        device,
        size,
        levels,
        F::Rgba32Float,
        U::TEXTURE_BINDING | U::COPY_DST,
    );
    let texels: Vec<f32> = img
        .pixels
        .iter()
        .flat_map(|p| [p[0], p[1], p[2], 1.0])
        .collect();
    queue.write_texture(
        wgpu::TexelCopyTextureInfo {
            texture: &t,
            mip_level: level,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        bytemuck::cast_slice(&texels),
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(img.width * 16),
            rows_per_image: None,
        },
        wgpu::Extent3d {
            width: img.width,
            height: img.height,
            depth_or_array_layers: 1,
        },
    );
    t
}

pub(crate) fn hdr_input(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    img: &HdrImage,
) -> wgpu::Texture {
    hdr_input_in(device, queue, img, (img.width, img.height), 1, 0)
}

/// One pixel of a target as read back: what its format holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Texel {
    /// R, G, B codes (8-bit formats in RGB order whatever the layout).
    Codes([u16; 3]),
    /// scRGB, as the half floats stored.
    Half([half::f16; 3]),
}

/// The pixels of `t`'s level `level`, as the application reads them back.
pub(crate) fn read(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    t: &wgpu::Texture,
    level: u32,
) -> Vec<Texel> {
    let (w, h) = ((t.width() >> level).max(1), (t.height() >> level).max(1));
    let bytes = t.format().block_copy_size(None).unwrap();
    let row = (w * bytes).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("application.readback"),
        size: (row * h) as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture: t,
            mip_level: level,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(row),
                rows_per_image: None,
            },
        },
        wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
    );
    queue.submit([encoder.finish()]);
    buffer
        .slice(..)
        .map_async(wgpu::MapMode::Read, |r| r.unwrap());
    device.poll(wgpu::PollType::wait_indefinitely()).unwrap();
    let mapped = buffer.slice(..).get_mapped_range().unwrap();
    let mut out = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        let line = &mapped[(y * row) as usize..][..(w * bytes) as usize];
        for px in line.chunks_exact(bytes as usize) {
            out.push(match t.format() {
                F::Rgba8Unorm | F::Rgba8UnormSrgb => {
                    assert_eq!(px[3], 255, "alpha");
                    Texel::Codes([px[0], px[1], px[2]].map(u16::from))
                }
                F::Bgra8Unorm | F::Bgra8UnormSrgb => {
                    assert_eq!(px[3], 255, "alpha");
                    Texel::Codes([px[2], px[1], px[0]].map(u16::from))
                }
                F::Rgb10a2Unorm => {
                    let v = u32::from_le_bytes(px.try_into().unwrap());
                    assert_eq!(v >> 30, 3, "alpha");
                    Texel::Codes([v & 1023, (v >> 10) & 1023, (v >> 20) & 1023].map(|c| c as u16))
                }
                F::Rgba16Float => {
                    let h: Vec<half::f16> = px
                        .chunks_exact(2)
                        .map(|b| half::f16::from_le_bytes([b[0], b[1]]))
                        .collect();
                    assert_eq!(h[3], half::f16::ONE, "alpha");
                    Texel::Half([h[0], h[1], h[2]])
                }
                other => panic!("no target {other:?}"),
            });
        }
    }
    out
}

/// tonegate's own renderer on its own device for the same adapter: the
/// flat image's plan (statistics where the operator needs them, tonemap,
/// encode), its frame at the encoding's depth.
pub(crate) fn tonegate_frame(
    ctx: &GpuContext,
    img: &HdrImage,
    op: &Operator,
    encoding: Encoding,
) -> Frame {
    tonegate_frame_with(ctx, img, op, encoding, None, None)
}

/// [`tonegate_frame`] with a bloom and a grade in the plan.
pub(crate) fn tonegate_frame_with(
    ctx: &GpuContext,
    img: &HdrImage,
    op: &Operator,
    encoding: Encoding,
    bloom: Option<&Bloom>,
    grade: Option<&Grade>,
) -> Frame {
    let pipeline = Pipeline {
        operator: op,
        bloom,
        grade,
        encoding,
    };
    let plan = StagePlan::build(Input::Flat, op, bloom, grade);
    let r = GpuRenderer::new(
        ctx,
        plan,
        GpuInput::Flat(img),
        &pipeline,
        GpuConfig::default(),
    )
    .unwrap();
    r.render(true).unwrap().frame.unwrap()
}

pub(crate) fn night_and_ramp() -> HdrImage {
    // A size that is no multiple of a workgroup, a night map's decades and
    // a ramp over 1e-3…1e4.
    let night = tonegate::env::BuiltinEnv::Night.generate(150, 40);
    let ramp = HdrImage::ramp(150, 41, 1e-3, 1e4);
    HdrImage::from_fn(150, 81, |x, y| {
        if y < 40 {
            night.pixels[(x + 150 * y) as usize]
        } else {
            ramp.pixels[(x + 150 * (y - 40)) as usize]
        }
    })
}

/// The paths into a target of `format` on `device`.
pub(crate) fn paths(device: &wgpu::Device, format: wgpu::TextureFormat) -> Vec<OutputPath> {
    let storage = match format {
        F::Rgba8Unorm | F::Rgba16Float => true,
        F::Bgra8Unorm => device
            .features()
            .contains(wgpu::Features::BGRA8UNORM_STORAGE),
        _ => false,
    };
    if storage {
        vec![OutputPath::Compute, OutputPath::RenderPass]
    } else {
        vec![OutputPath::RenderPass]
    }
}

pub(crate) fn usage_for(path: OutputPath) -> wgpu::TextureUsages {
    match path {
        OutputPath::Compute => U::STORAGE_BINDING | U::COPY_SRC,
        _ => U::RENDER_ATTACHMENT | U::COPY_SRC,
    }
}
