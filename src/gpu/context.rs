//! Headless wgpu context: adapter choice, device, error capture.

use super::GpuError;
use serde::Serialize;
use std::sync::{Arc, Mutex};

/// Which adapter to open (`--adapter`).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum AdapterChoice {
    /// lavapipe/llvmpipe when present (reproducible everywhere), else the first.
    #[default]
    Default,
    /// The first adapter the driver lists.
    Any,
    /// The first whose name contains this (case-insensitive).
    Name(String),
}

impl std::str::FromStr for AdapterChoice {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Ok(match s {
            "" | "default" => AdapterChoice::Default,
            "any" => AdapterChoice::Any,
            name => AdapterChoice::Name(name.to_owned()),
        })
    }
}

/// What every result records about the adapter.
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct AdapterReport {
    pub name: String,
    pub backend: String,
    pub device_type: String,
    pub driver: String,
    pub driver_info: String,
    /// Whether GPU timestamps could be taken.
    pub timestamps: bool,
}

/// An open device plus the errors wgpu reports asynchronously.
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub adapter: AdapterReport,
    pub limits: wgpu::Limits,
    /// Nanoseconds per timestamp tick.
    pub timestamp_period: f32,
    /// Whether Rgba32Float textures can be linearly filtered (hardware filter).
    pub float32_filterable: bool,
    errors: Arc<Mutex<Vec<GpuError>>>,
    /// Compiled pipelines by (stage, entry, format, override constants): a
    /// context that renders many images (the server's GPU worker, `check`)
    /// compiles each variant once. Bounded by [`PIPELINE_CACHE_LIMIT`].
    pub(crate) pipelines: Mutex<std::collections::HashMap<PipelineKey, wgpu::ComputePipeline>>,
}

/// Stage, entry point, format and override constants (values as f64 bits).
pub(crate) type PipelineKey = (String, String, super::HdrFormat, Vec<(String, u64)>);

/// Distinct pipeline variants a context keeps; beyond it the cache starts
/// over (override constants include image sizes, so a server seeing many
/// sizes would otherwise grow without end).
pub(crate) const PIPELINE_CACHE_LIMIT: usize = 256;

fn is_software(info: &wgpu::AdapterInfo) -> bool {
    let n = info.name.to_lowercase();
    n.contains("llvmpipe") || n.contains("lavapipe")
}

impl GpuContext {
    /// Opens the adapter `choice` selects, with timestamp queries when it has them.
    pub fn new(choice: &AdapterChoice) -> Result<GpuContext, GpuError> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = wgpu::Backends::VULKAN;
        let instance = wgpu::Instance::new(desc);
        let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN));
        if adapters.is_empty() {
            return Err(GpuError::NoAdapter);
        }
        let pick = match choice {
            AdapterChoice::Default => adapters
                .iter()
                .position(|a| is_software(&a.get_info()))
                .unwrap_or(0),
            AdapterChoice::Any => 0,
            AdapterChoice::Name(name) => {
                let wanted = name.to_lowercase();
                adapters
                    .iter()
                    .position(|a| a.get_info().name.to_lowercase().contains(&wanted))
                    .ok_or_else(|| GpuError::AdapterNotFound {
                        wanted: name.clone(),
                        available: adapters
                            .iter()
                            .map(|a| a.get_info().name)
                            .collect::<Vec<_>>()
                            .join(", "),
                    })?
            }
        };
        let adapter = &adapters[pick];
        let info = adapter.get_info();
        let wanted = wgpu::Features::TIMESTAMP_QUERY
            | wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS
            | wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES
            | wgpu::Features::FLOAT32_FILTERABLE;
        let features = adapter.features() & wanted;
        let timestamps = features.contains(wgpu::Features::TIMESTAMP_QUERY);
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("tonegate"),
            required_features: features,
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device {
            adapter: info.name.clone(),
            detail: e.to_string(),
        })?;
        let errors: Arc<Mutex<Vec<GpuError>>> = Arc::default();
        let sink = errors.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            let err = match e {
                wgpu::Error::OutOfMemory { .. } => GpuError::OutOfMemory(e.to_string()),
                other => GpuError::Validation(other.to_string()),
            };
            if let Ok(mut v) = sink.lock() {
                v.push(err);
            }
        }));
        let lost = errors.clone();
        device.set_device_lost_callback(move |reason, message| {
            if let Ok(mut v) = lost.lock() {
                v.push(GpuError::DeviceLost(format!("{reason:?}: {message}")));
            }
        });
        Ok(GpuContext {
            float32_filterable: features.contains(wgpu::Features::FLOAT32_FILTERABLE),
            timestamp_period: queue.get_timestamp_period(),
            device,
            queue,
            limits,
            adapter: AdapterReport {
                name: info.name.clone(),
                backend: format!("{:?}", info.backend),
                device_type: format!("{:?}", info.device_type),
                driver: info.driver.clone(),
                driver_info: info.driver_info.clone(),
                timestamps,
            },
            errors,
            pipelines: Mutex::new(Default::default()),
        })
    }

    /// The first error wgpu reported since the last call, if any.
    pub fn take_error(&self) -> Result<(), GpuError> {
        let mut v = self
            .errors
            .lock()
            .map_err(|_| GpuError::Validation("error sink poisoned".into()))?;
        if v.is_empty() {
            Ok(())
        } else {
            Err(v.remove(0))
        }
    }

    /// Waits for all submitted work, then reports any error it raised.
    pub fn wait(&self) -> Result<(), GpuError> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::DeviceLost(e.to_string()))?;
        self.take_error()
    }

    /// Refuses frames larger than one texture can hold.
    pub fn check_size(&self, width: u32, height: u32) -> Result<(), GpuError> {
        let limit = self.limits.max_texture_dimension_2d;
        if width > limit || height > limit {
            return Err(GpuError::TooLarge {
                width,
                height,
                limit,
            });
        }
        Ok(())
    }

    /// Reads a mapped-readable buffer's bytes.
    pub fn read_buffer(&self, buffer: &wgpu::Buffer) -> Result<Vec<u8>, GpuError> {
        let slice = buffer.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.wait()?;
        rx.recv()
            .map_err(|e| GpuError::Readback(e.to_string()))?
            .map_err(|e| GpuError::Readback(e.to_string()))?;
        let bytes = slice
            .get_mapped_range()
            .map_err(|e| GpuError::Readback(e.to_string()))?
            .to_vec();
        buffer.unmap();
        Ok(bytes)
    }
}
