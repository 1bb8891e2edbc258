//! The subnormal probe: whether an adapter flushes f32 subnormals to zero,
//! measured, not guessed from its name. Vulkan lets an implementation flush
//! them (SwiftShader does; llvmpipe does not), and the one documented
//! exception to the statistics bound (docs/stress.md) applies only where
//! this probe found flushing.

use super::HdrFormat;
use wgpu::util::DeviceExt;

/// f32's smallest normal, 2^-126.
const SMALLEST_NORMAL: u32 = 0x0080_0000;
/// 2^-133, a subnormal.
const SUBNORMAL: u32 = 0x0001_0000;

/// Runs `shaders/subnormal_probe.wgsl` once; true where a subnormal result
/// or operand became zero.
pub(crate) fn flushes_subnormals(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
) -> Result<bool, String> {
    let read = probe(device, queue)?;
    Ok(verdict(read))
}

/// What the probe's four words say: flushing where the subnormal result
/// (expected 2^-127) or the subnormal operand (expected 2^-133) read zero.
fn verdict(read: [u32; 4]) -> bool {
    read[0] == 0 || read[1] == 0
}

fn probe(device: &wgpu::Device, queue: &wgpu::Queue) -> Result<[u32; 4], String> {
    let source = super::shaders::compose("subnormal_probe", HdrFormat::Rgba32Float, false);
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("tonegate.subnormal_probe"),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("tonegate.subnormal_probe"),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let words = [SMALLEST_NORMAL, SUBNORMAL, 1f32.to_bits(), 0.5f32.to_bits()];
    let storage = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("tonegate.subnormal_probe"),
        contents: bytemuck::cast_slice(&words),
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
    });
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("tonegate.subnormal_probe.read"),
        size: 16,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("tonegate.subnormal_probe"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: storage.as_entire_binding(),
        }],
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups(1, 1, 1);
    }
    encoder.copy_buffer_to_buffer(&storage, 0, &staging, 0, 16);
    queue.submit([encoder.finish()]);
    let slice = staging.slice(..);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| e.to_string())?;
    rx.recv()
        .map_err(|e| e.to_string())?
        .map_err(|e| e.to_string())?;
    let bytes = slice
        .get_mapped_range()
        .map_err(|e| e.to_string())?
        .to_vec();
    staging.unmap();
    let mut out = [0u32; 4];
    for (o, b) in out.iter_mut().zip(bytes.chunks_exact(4)) {
        *o = u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
    }
    if out[2] > 1 {
        return Err(format!(
            "the probe wrote {out:?}: it did not run as written"
        ));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_verdict_reads_either_flush() {
        // llvmpipe: 2^-127 and 2^-133 kept, and 2^-133 > 0.
        assert!(!verdict([SMALLEST_NORMAL / 2, SUBNORMAL, 1, 0]));
        // Results flushed, operands kept (the comparison may still see them).
        assert!(verdict([0, SUBNORMAL, 1, 0]));
        // Operands flushed.
        assert!(verdict([SMALLEST_NORMAL / 2, 0, 0, 0]));
    }
}
