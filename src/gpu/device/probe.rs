//! The subnormal probe: whether an adapter flushes f32 subnormals to zero,
//! measured, not guessed from its name. Vulkan lets an implementation flush
//! them (SwiftShader does; llvmpipe does not), and the one documented
//! exception to the statistics bound (docs/stress.md) applies only where
//! this probe found flushing. The same dispatch shows whether the compiler
//! rewrote a division in a way that leaves f32's range
//! (docs/stress.md#range-safe-arithmetic).

use crate::gpu::HdrFormat;
use wgpu::util::DeviceExt;

/// f32's smallest normal, 2^-126.
const SMALLEST_NORMAL: u32 = 0x0080_0000;
/// 2^-133, a subnormal.
const SUBNORMAL: u32 = 0x0001_0000;

/// 2^-100, 2^-70, 2^100 and 2^127, as bits.
const A: u32 = 0x0d80_0000;
const B: u32 = 0x1c80_0000;
const P: u32 = 0x7180_0000;
const Q: u32 = 0x7f00_0000;

/// What the probe measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Probed {
    /// A subnormal result or operand became zero.
    pub flushes_subnormals: bool,
    /// How the compiler evaluated the two divisions, where that could be
    /// seen: "as written", or the rewrites found.
    pub division: &'static str,
}

/// Runs `shaders/subnormal_probe.wgsl` once.
pub(crate) fn run(device: &wgpu::Device, queue: &wgpu::Queue) -> Result<Probed, String> {
    let read = probe(device, queue)?;
    Ok(Probed {
        flushes_subnormals: verdict(read),
        division: division(read),
    })
}

/// What the probe's first words say: flushing where the subnormal result
/// (expected 2^-127) or the subnormal operand (expected 2^-133) read zero.
fn verdict(read: [u32; 8]) -> bool {
    read[0] == 0 || read[1] == 0
}

/// (a/b)/b as written is 2^40 (0x5380_0000); a/(b·b) with b·b flushed is
/// not finite. p/q as written is 2^-27 (0x3200_0000); p·(1/q) with 1/q
/// flushed is 0. Anything else is reported as it read.
fn division(read: [u32; 8]) -> &'static str {
    let reassociated = !f32::from_bits(read[4]).is_finite();
    let reciprocal = f32::from_bits(read[5]) == 0.0;
    match (reassociated, reciprocal) {
        (false, false) => "as written",
        (true, false) => "(a/b)/c as a/(b*c)",
        (false, true) => "a/b as a*(1/b)",
        (true, true) => "(a/b)/c as a/(b*c), a/b as a*(1/b)",
    }
}

fn probe(device: &wgpu::Device, queue: &wgpu::Queue) -> Result<[u32; 8], String> {
    // An adapter that cannot compile or run the probe must not be reported
    // as flushing: its buffer would read back zeros. Every error of the
    // probe's own work is caught here and refuses the adapter instead.
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let read = probe_unscoped(device, queue);
    if let Some(e) = pollster::block_on(scope.pop()) {
        return Err(format!("the probe shader could not run: {e}"));
    }
    read
}

fn probe_unscoped(device: &wgpu::Device, queue: &wgpu::Queue) -> Result<[u32; 8], String> {
    let source = crate::gpu::shaders::compose("subnormal_probe", HdrFormat::Rgba32Float, false);
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
    let words = [
        SMALLEST_NORMAL,
        SUBNORMAL,
        1f32.to_bits(),
        0.5f32.to_bits(),
        A,
        B,
        P,
        Q,
    ];
    let storage = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("tonegate.subnormal_probe"),
        contents: bytemuck::cast_slice(&words),
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
    });
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("tonegate.subnormal_probe.read"),
        size: 32,
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
    encoder.copy_buffer_to_buffer(&storage, 0, &staging, 0, 32);
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
    let mut out = [0u32; 8];
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
        let read = |a: u32, b: u32, c: u32| [a, b, c, 0, 0x5380_0000, 0x3200_0000, 0, 0];
        // llvmpipe: 2^-127 and 2^-133 kept, and 2^-133 > 0.
        assert!(!verdict(read(SMALLEST_NORMAL / 2, SUBNORMAL, 1)));
        // Results flushed, operands kept (the comparison may still see them).
        assert!(verdict(read(0, SUBNORMAL, 1)));
        // Operands flushed.
        assert!(verdict(read(SMALLEST_NORMAL / 2, 0, 0)));
    }

    #[test]
    fn the_constants_are_the_powers_of_two_they_name() {
        assert_eq!(f32::from_bits(A), 2f32.powi(-100));
        assert_eq!(f32::from_bits(B), 2f32.powi(-70));
        assert_eq!(f32::from_bits(P), 2f32.powi(100));
        assert_eq!(f32::from_bits(Q), 2f32.powi(127));
        // What each division gives as written.
        let (a, b, p, q) = (
            f32::from_bits(A),
            f32::from_bits(B),
            f32::from_bits(P),
            f32::from_bits(Q),
        );
        assert_eq!(((a / b) / b).to_bits(), 0x5380_0000);
        assert_eq!((p / q).to_bits(), 0x3200_0000);
    }

    #[test]
    fn the_division_reading_names_each_rewrite() {
        let read = |x: f32, y: f32| [0, 0, 0, 0, x.to_bits(), y.to_bits(), 0, 0];
        assert_eq!(division(read(2f32.powi(40), 2f32.powi(-27))), "as written");
        assert_eq!(
            division(read(f32::INFINITY, 2f32.powi(-27))),
            "(a/b)/c as a/(b*c)"
        );
        assert_eq!(
            division(read(f32::NAN, 2f32.powi(-27))),
            "(a/b)/c as a/(b*c)"
        );
        assert_eq!(division(read(2f32.powi(40), 0.0)), "a/b as a*(1/b)");
        assert_eq!(
            division(read(f32::INFINITY, 0.0)),
            "(a/b)/c as a/(b*c), a/b as a*(1/b)"
        );
    }
}
