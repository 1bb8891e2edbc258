//! Where a renderer's frame comes from: a view of the environment sphere,
//! a flat image uploaded, or a caller's texture read where it is.

use crate::conventions::Camera;
use crate::gpu::stages::ImageView;
use crate::image::HdrImage;

/// Where the frame comes from.
pub enum GpuInput<'i> {
    /// A sphere view of this environment with this camera at `spp`.
    Sphere {
        env: &'i HdrImage,
        camera: Camera,
        spp: u32,
        /// The brightest light the sequence scales the environment by
        /// (`Scene::light`; 1 without `[[light]]` steps).
        light: f32,
    },
    /// A flat HDR image.
    Flat(&'i HdrImage),
    /// A caller's texture, read where it is (`ToneMapper`): nothing is
    /// uploaded, and its range is unknown.
    View(&'i ImageView),
}

// What the gate's renderer asks of its input.
#[cfg(feature = "gpu")]
impl GpuInput<'_> {
    /// The output frame's size.
    pub(in crate::gpu) fn size(&self) -> (u32, u32) {
        match self {
            GpuInput::Sphere { camera, .. } => (camera.width, camera.height),
            GpuInput::Flat(img) => (img.width, img.height),
            GpuInput::View(v) => (v.width, v.height),
        }
    }

    /// The largest component of the input (NaN ignored): no intermediate
    /// before `tonemap` exceeds it.
    pub(in crate::gpu) fn max_component(&self) -> f32 {
        match self {
            GpuInput::Sphere { env, light, .. } => env.max_component() * light.max(1.0),
            GpuInput::Flat(img) => img.max_component(),
            // Unknown: f16 intermediates would be promoted to f32.
            GpuInput::View(_) => f32::MAX,
        }
    }
}
