//! Headless wgpu context: adapter choice, device, error capture.

use super::GpuError;
use serde::Serialize;
use std::sync::{Arc, Mutex};

/// Which adapter to open (`--adapter`).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum AdapterChoice {
    /// lavapipe/llvmpipe when present, else the first. Chosen as the default
    /// on purpose: the built-in bounds and the CI runs were measured on it,
    /// and it gives the same results on every machine, so a gate at defaults
    /// means the same everywhere. A GPU is tested by asking for it
    /// (`hardware` or a name), and a run that passes hardware over says so.
    #[default]
    Default,
    /// The best hardware adapter: discrete, else integrated, else virtual.
    Hardware,
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
            "hardware" => AdapterChoice::Hardware,
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
    /// Why this adapter: what was asked for, and what else was there.
    #[serde(default)]
    pub chosen: String,
}

/// What [`choose`] sees of an adapter.
#[derive(Clone, Debug)]
pub struct Candidate {
    pub name: String,
    pub device_type: wgpu::DeviceType,
}

impl Candidate {
    fn is_software(&self) -> bool {
        let n = self.name.to_lowercase();
        self.device_type == wgpu::DeviceType::Cpu
            || n.contains("llvmpipe")
            || n.contains("lavapipe")
    }

    /// Rank among hardware adapters (lower is better); `None` for software.
    fn hardware_rank(&self) -> Option<u8> {
        if self.is_software() {
            return None;
        }
        Some(match self.device_type {
            wgpu::DeviceType::DiscreteGpu => 0,
            wgpu::DeviceType::IntegratedGpu => 1,
            wgpu::DeviceType::VirtualGpu => 2,
            _ => 3,
        })
    }
}

/// Picks the adapter `choice` asks for among `found` (in the driver's
/// order) and says why, naming the hardware passed over when the default
/// picks the software rasterizer.
pub fn choose(choice: &AdapterChoice, found: &[Candidate]) -> Result<(usize, String), GpuError> {
    if found.is_empty() {
        return Err(GpuError::NoAdapter);
    }
    let names = || {
        found
            .iter()
            .map(|c| c.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let hardware: Vec<usize> = (0..found.len())
        .filter(|&i| found[i].hardware_rank().is_some())
        .collect();
    let best_hardware = hardware
        .iter()
        .copied()
        .min_by_key(|&i| found[i].hardware_rank());
    Ok(match choice {
        AdapterChoice::Default => match found.iter().position(Candidate::is_software) {
            Some(i) if hardware.is_empty() => (
                i,
                "default: the software rasterizer (reproducible; the built-in bounds were measured on it); no hardware adapter found".into(),
            ),
            Some(i) => (
                i,
                format!(
                    "default: the software rasterizer (reproducible; the built-in bounds were measured on it); hardware present but not tested: {}; use --adapter hardware or a name to test it",
                    hardware
                        .iter()
                        .map(|&h| found[h].name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ),
            None => (
                0,
                format!("default: no software rasterizer, so the first adapter listed (of {})", names()),
            ),
        },
        AdapterChoice::Hardware => {
            let i = best_hardware.ok_or_else(|| GpuError::AdapterNotFound {
                wanted: "hardware".into(),
                available: names(),
            })?;
            (
                i,
                format!(
                    "--adapter hardware: the best hardware adapter ({:?}) of {}",
                    found[i].device_type,
                    names()
                ),
            )
        }
        AdapterChoice::Any => (0, format!("--adapter any: the first listed of {}", names())),
        AdapterChoice::Name(name) => {
            let wanted = name.to_lowercase();
            let i = found
                .iter()
                .position(|c| c.name.to_lowercase().contains(&wanted))
                .ok_or_else(|| GpuError::AdapterNotFound {
                    wanted: name.clone(),
                    available: names(),
                })?;
            (
                i,
                format!("--adapter {name:?}: the first of {} whose name contains it", names()),
            )
        }
    })
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
    /// Whether the adapter is a CPU (llvmpipe, SwiftShader): `--reduction
    /// auto` picks what is fast there.
    pub cpu_adapter: bool,
    /// Whether the device has subgroup operations (wgpu's `SUBGROUP`): the
    /// reductions' subgroup tree needs them, and the shaders that have one
    /// are composed with it (`shaders::compose`).
    pub subgroups: bool,
    errors: Arc<Mutex<Vec<GpuError>>>,
    /// Compiled pipelines by (stage, entry, format, override constants): a
    /// context that renders many images (the server's GPU worker, `check`)
    /// compiles each variant once. Bounded by [`PIPELINE_CACHE_LIMIT`].
    pipelines: Mutex<std::collections::HashMap<PipelineKey, wgpu::ComputePipeline>>,
}

/// The most bytes per frame pixel any one buffer of a renderer may take:
/// what [`GpuContext::check_frame`] holds a frame to. The largest today is
/// the ping-pong reduction's first level, a 32-byte partial per 2×2 block;
/// `luminance_stats` asserts at compile time that it stays within this.
pub(crate) const MAX_BUFFER_BYTES_PER_PIXEL: u64 = 8;

/// Stage, entry point, format and override constants (values as f64 bits).
pub(crate) type PipelineKey = (String, String, super::HdrFormat, Vec<(String, u64)>);

/// Distinct pipeline variants a context keeps; beyond it the cache starts
/// over (override constants include image sizes, so a server seeing many
/// sizes would otherwise grow without end).
const PIPELINE_CACHE_LIMIT: usize = 256;

impl GpuContext {
    /// Opens the adapter `choice` selects, with timestamp queries when it has them.
    pub fn new(choice: &AdapterChoice) -> Result<GpuContext, GpuError> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = wgpu::Backends::VULKAN;
        let instance = wgpu::Instance::new(desc);
        let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN));
        let found: Vec<Candidate> = adapters
            .iter()
            .map(|a| {
                let info = a.get_info();
                Candidate {
                    name: info.name,
                    device_type: info.device_type,
                }
            })
            .collect();
        let (pick, chosen) = choose(choice, &found)?;
        let adapter = &adapters[pick];
        let info = adapter.get_info();
        let wanted = wgpu::Features::TIMESTAMP_QUERY
            | wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS
            | wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES
            | wgpu::Features::FLOAT32_FILTERABLE
            | wgpu::Features::SUBGROUP;
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
            cpu_adapter: info.device_type == wgpu::DeviceType::Cpu,
            subgroups: features.contains(wgpu::Features::SUBGROUP),
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
                chosen,
            },
            errors,
            pipelines: Mutex::new(Default::default()),
        })
    }

    /// What decides the configuration in effect on this device.
    pub fn traits(&self) -> super::config::AdapterTraits {
        super::config::AdapterTraits {
            cpu: self.cpu_adapter,
            subgroups: self.subgroups,
        }
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

    /// The first error wgpu reported since the last call, if any, with the
    /// ones after it (its consequences) forgotten.
    pub fn take_first_error(&self) -> Result<(), GpuError> {
        let mut v = self
            .errors
            .lock()
            .map_err(|_| GpuError::Validation("error sink poisoned".into()))?;
        let first = v.drain(..).next();
        first.map_or(Ok(()), Err)
    }

    /// Waits for all submitted work, then reports any error it raised.
    pub fn wait(&self) -> Result<(), GpuError> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::DeviceLost(e.to_string()))?;
        self.take_error()
    }

    /// The pipeline cached under `key`, or the one `compile` makes, then
    /// kept (the cache starts over past [`PIPELINE_CACHE_LIMIT`] variants).
    pub(crate) fn cached_pipeline(
        &self,
        key: PipelineKey,
        compile: impl FnOnce() -> wgpu::ComputePipeline,
    ) -> wgpu::ComputePipeline {
        let mut cache = self
            .pipelines
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner());
        if let Some(p) = cache.get(&key) {
            return p.clone();
        }
        let p = compile();
        if cache.len() >= PIPELINE_CACHE_LIMIT {
            cache.clear();
        }
        cache.insert(key, p.clone());
        p
    }

    /// How many compiled pipelines the context keeps now.
    #[cfg(test)]
    pub(crate) fn cached_pipelines(&self) -> usize {
        self.pipelines
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
            .len()
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

    /// Refuses frames a renderer cannot hold: larger than one texture, or
    /// needing a buffer (at [`MAX_BUFFER_BYTES_PER_PIXEL`]) over the adapter's
    /// buffer and storage-binding limits.
    pub fn check_frame(&self, width: u32, height: u32) -> Result<(), GpuError> {
        self.check_size(width, height)?;
        let bytes = width as u64 * height as u64 * MAX_BUFFER_BYTES_PER_PIXEL;
        let limit = self
            .limits
            .max_storage_buffer_binding_size
            .min(self.limits.max_buffer_size);
        if bytes > limit {
            return Err(GpuError::FrameTooLarge {
                width,
                height,
                bytes,
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

#[cfg(test)]
mod choice_tests {
    use super::*;
    use wgpu::DeviceType::{Cpu, DiscreteGpu, IntegratedGpu};

    fn found(list: &[(&str, wgpu::DeviceType)]) -> Vec<Candidate> {
        list.iter()
            .map(|&(name, device_type)| Candidate {
                name: name.into(),
                device_type,
            })
            .collect()
    }

    #[test]
    fn the_default_is_the_software_rasterizer_and_names_the_hardware_it_skips() {
        let f = found(&[
            ("Intel(R) UHD 770", IntegratedGpu),
            ("NVIDIA H100 80GB HBM3", DiscreteGpu),
            ("llvmpipe (LLVM 15.0.6, 256 bits)", Cpu),
        ]);
        let (i, why) = choose(&AdapterChoice::Default, &f).unwrap();
        assert_eq!(i, 2);
        assert!(
            why.contains("NVIDIA H100") && why.contains("Intel"),
            "{why}"
        );
        assert!(why.contains("--adapter hardware"), "{why}");

        let (i, why) = choose(&AdapterChoice::Hardware, &f).unwrap();
        assert_eq!(i, 1, "discrete before integrated: {why}");
        let (i, _) = choose(&AdapterChoice::Name("intel".into()), &f).unwrap();
        assert_eq!(i, 0);
        let (i, _) = choose(&AdapterChoice::Any, &f).unwrap();
        assert_eq!(i, 0);
    }

    #[test]
    fn only_software_or_only_hardware() {
        let soft = found(&[("llvmpipe (LLVM 15.0.6, 256 bits)", Cpu)]);
        let (i, why) = choose(&AdapterChoice::Default, &soft).unwrap();
        assert_eq!(i, 0);
        assert!(why.contains("no hardware adapter found"), "{why}");
        let e = choose(&AdapterChoice::Hardware, &soft).unwrap_err();
        assert!(e.to_string().contains("llvmpipe"), "{e}");

        let hard = found(&[("AMD Radeon", IntegratedGpu), ("NVIDIA", DiscreteGpu)]);
        let (i, why) = choose(&AdapterChoice::Default, &hard).unwrap();
        assert_eq!(i, 0);
        assert!(why.contains("no software rasterizer"), "{why}");
        assert!(matches!(
            choose(&AdapterChoice::Default, &[]),
            Err(GpuError::NoAdapter)
        ));
        let e = choose(&AdapterChoice::Name("quadro".into()), &hard).unwrap_err();
        assert!(e.to_string().contains("AMD Radeon, NVIDIA"), "{e}");
    }
}
