//! Headless wgpu context: the device on the adapter chosen, its error
//! capture and pipeline cache.

use super::adapters::{AdapterChoice, AdapterReport};
use super::pipelines::{PipelineCache, PipelineKey};
use crate::gpu::GpuError;
use std::sync::{Arc, Mutex};

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
    /// What this context has created on the device (`created`).
    created: Arc<super::created::Counts>,
    /// Compiled pipelines by what they are compiled from
    /// (`pipelines::PipelineKey`): a context that renders many images (the
    /// server's GPU worker, `check`) compiles each variant once, the
    /// variants used last kept. Each entry is filled outside the map's
    /// lock, so threads compile different variants at once (the stress
    /// suite's rows do).
    pipelines: Arc<Mutex<PipelineCache<wgpu::ComputePipeline>>>,
    /// Render pipelines (the `ToneMapper`'s fullscreen pass), kept and
    /// shared like `pipelines`.
    render_pipelines: Arc<Mutex<PipelineCache<wgpu::RenderPipeline>>>,
}

/// The most bytes per frame pixel any one buffer of a renderer may take:
/// what [`GpuContext::check_frame`] holds a frame to. The largest today is
/// the ping-pong reduction's first level, a 32-byte partial per 2×2 block;
/// `luminance_stats` asserts at compile time that it stays within this.
pub(crate) const MAX_BUFFER_BYTES_PER_PIXEL: u64 = 8;

/// What reports say of the adapter behind a device.
fn report(
    info: &wgpu::AdapterInfo,
    timestamps: bool,
    probed: Option<super::probe::Probed>,
    chosen: String,
) -> AdapterReport {
    AdapterReport {
        name: info.name.clone(),
        backend: format!("{:?}", info.backend),
        device_type: format!("{:?}", info.device_type),
        driver: info.driver.clone(),
        driver_info: info.driver_info.clone(),
        timestamps,
        flushes_subnormals: probed.map(|p| p.flushes_subnormals),
        division: probed.map(|p| p.division.to_owned()),
        chosen,
    }
}

impl GpuContext {
    /// Opens the adapter `choice` selects, with timestamp queries when it has them.
    pub fn new(choice: &AdapterChoice) -> Result<GpuContext, GpuError> {
        let (adapter, chosen) = super::adapters::select(choice)?;
        let ctx = GpuContext::open(&adapter, chosen)?;
        if super::validation::requested() && super::validation::layer_missing() {
            return Err(GpuError::Device {
                adapter: ctx.adapter.name,
                detail: "WGPU_VALIDATION is set, but the validation layer is not installed (Debian: apt-get install vulkan-validationlayers)".into(),
            });
        }
        Ok(ctx)
    }

    /// Opens a device on `adapter` (`chosen` says why it was picked) and
    /// measures whether it flushes subnormals.
    pub fn open(adapter: &wgpu::Adapter, chosen: String) -> Result<GpuContext, GpuError> {
        let info = adapter.get_info();
        if let Some(reason) = super::capability::lacks(adapter) {
            return Err(GpuError::Unsupported {
                adapter: info.name,
                reason,
            });
        }
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
        let probed = super::probe::run(&device, &queue).map_err(|detail| GpuError::Device {
            adapter: info.name.clone(),
            detail: format!("the subnormal probe failed: {detail}"),
        })?;
        Ok(GpuContext {
            cpu_adapter: info.device_type == wgpu::DeviceType::Cpu,
            subgroups: features.contains(wgpu::Features::SUBGROUP),
            float32_filterable: features.contains(wgpu::Features::FLOAT32_FILTERABLE),
            timestamp_period: queue.get_timestamp_period(),
            device,
            queue,
            limits,
            adapter: report(&info, timestamps, Some(probed), chosen),
            errors,
            created: Arc::default(),
            pipelines: Arc::default(),
            render_pipelines: Arc::default(),
        })
    }

    /// A context on a device someone else opened (a caller's application,
    /// through [`crate::gpu::ToneMapper`]). Nothing of the device is changed: its
    /// error and device-lost callbacks stay the caller's (so wgpu's errors
    /// reach the caller, not [`GpuContext::take_error`]), nothing is
    /// submitted to its queue, and whether it flushes subnormals is not
    /// probed.
    pub fn from_device(device: &wgpu::Device, queue: &wgpu::Queue) -> GpuContext {
        let info = device.adapter_info();
        let features = device.features();
        GpuContext {
            cpu_adapter: info.device_type == wgpu::DeviceType::Cpu,
            subgroups: features.contains(wgpu::Features::SUBGROUP),
            float32_filterable: features.contains(wgpu::Features::FLOAT32_FILTERABLE),
            timestamp_period: queue.get_timestamp_period(),
            limits: device.limits(),
            adapter: report(
                &info,
                features.contains(wgpu::Features::TIMESTAMP_QUERY),
                None,
                "the caller's device".into(),
            ),
            device: device.clone(),
            queue: queue.clone(),
            errors: Arc::default(),
            created: Arc::default(),
            pipelines: Arc::default(),
            render_pipelines: Arc::default(),
        }
    }

    /// Another context on the same device and queue that shares this one's
    /// compiled pipelines (compute and render): a second `ToneMapper` for
    /// another camera compiles nothing the first one has. Its counts of
    /// what it creates are its own.
    pub fn sharing_pipelines(&self) -> GpuContext {
        GpuContext {
            device: self.device.clone(),
            queue: self.queue.clone(),
            adapter: self.adapter.clone(),
            limits: self.limits.clone(),
            timestamp_period: self.timestamp_period,
            float32_filterable: self.float32_filterable,
            cpu_adapter: self.cpu_adapter,
            subgroups: self.subgroups,
            errors: self.errors.clone(),
            created: Arc::default(),
            pipelines: self.pipelines.clone(),
            render_pipelines: self.render_pipelines.clone(),
        }
    }

    /// What this context has created on its device so far.
    pub fn created(&self) -> crate::gpu::Created {
        self.created.read()
    }

    /// A texture, counted.
    pub fn create_texture(&self, desc: &wgpu::TextureDescriptor) -> wgpu::Texture {
        self.created.add(super::created::Kind::Texture);
        self.device.create_texture(desc)
    }

    /// A buffer, counted.
    pub fn create_buffer(&self, desc: &wgpu::BufferDescriptor) -> wgpu::Buffer {
        self.created.add(super::created::Kind::Buffer);
        self.device.create_buffer(desc)
    }

    /// A buffer holding `desc.contents` from its creation, counted.
    pub fn create_buffer_init(&self, desc: &wgpu::util::BufferInitDescriptor) -> wgpu::Buffer {
        use wgpu::util::DeviceExt;
        self.created.add(super::created::Kind::Buffer);
        self.device.create_buffer_init(desc)
    }

    /// A bind group, counted.
    pub fn create_bind_group(&self, desc: &wgpu::BindGroupDescriptor) -> wgpu::BindGroup {
        self.created.add(super::created::Kind::BindGroup);
        self.device.create_bind_group(desc)
    }

    /// The render pipeline cached under `key`, or the one `compile`
    /// makes, counted, then kept.
    pub(crate) fn cached_render_pipeline(
        &self,
        key: PipelineKey,
        compile: impl FnOnce() -> wgpu::RenderPipeline,
    ) -> wgpu::RenderPipeline {
        let slot = lock(&self.render_pipelines).slot(key);
        slot.get_or_init(|| {
            self.created.add(super::created::Kind::Pipeline);
            compile()
        })
        .clone()
    }

    /// What decides the configuration in effect on this device.
    pub fn traits(&self) -> crate::gpu::config::AdapterTraits {
        crate::gpu::config::AdapterTraits {
            cpu: self.cpu_adapter,
            subgroups: self.subgroups,
        }
    }

    /// The first error wgpu reported since the last call, if any.
    pub fn take_error(&self) -> Result<(), GpuError> {
        if let Some(e) = super::validation::take_first_error() {
            return Err(GpuError::LayerError(e));
        }
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
        if let Some(e) = super::validation::take_first_error() {
            return Err(GpuError::LayerError(e));
        }
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

    /// The compute pipeline cached under `key`, or the one `compile`
    /// makes, counted, then kept (the variants used last:
    /// `pipelines::PIPELINE_CACHE_LIMIT`).
    pub(crate) fn cached_pipeline(
        &self,
        key: PipelineKey,
        compile: impl FnOnce() -> wgpu::ComputePipeline,
    ) -> wgpu::ComputePipeline {
        let slot = lock(&self.pipelines).slot(key);
        slot.get_or_init(|| {
            self.created.add(super::created::Kind::Pipeline);
            compile()
        })
        .clone()
    }

    /// How many compiled pipelines the context keeps now, compute and
    /// render.
    pub(crate) fn cached_pipelines(&self) -> usize {
        lock(&self.pipelines).len() + lock(&self.render_pipelines).len()
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
    /// needing a buffer (at `MAX_BUFFER_BYTES_PER_PIXEL`) over the adapter's
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

    /// The largest frame `check_frame` lets through, for checking an image's
    /// header before it is decoded.
    #[cfg(feature = "reference")]
    pub fn frame_fit(&self) -> crate::io::DeviceFit {
        let bytes = self
            .limits
            .max_storage_buffer_binding_size
            .min(self.limits.max_buffer_size);
        crate::io::DeviceFit {
            max_side: self.limits.max_texture_dimension_2d,
            max_pixels: bytes / MAX_BUFFER_BYTES_PER_PIXEL,
        }
    }

    /// Reads a mapped-readable buffer's bytes.
    pub fn read_buffer(&self, buffer: &wgpu::Buffer) -> Result<Vec<u8>, GpuError> {
        self.with_mapped(buffer, <[u8]>::to_vec)
    }

    /// Maps a mapped-readable buffer once the device is done with it and
    /// hands `read` its bytes where they are mapped (no copy), then unmaps
    /// it: what a reader that only scans or sums them uses.
    pub fn with_mapped<T>(
        &self,
        buffer: &wgpu::Buffer,
        read: impl FnOnce(&[u8]) -> T,
    ) -> Result<T, GpuError> {
        let slice = buffer.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.wait()?;
        rx.recv()
            .map_err(|e| GpuError::Readback(e.to_string()))?
            .map_err(|e| GpuError::Readback(e.to_string()))?;
        let out = {
            let view = slice
                .get_mapped_range()
                .map_err(|e| GpuError::Readback(e.to_string()))?;
            read(&view)
        };
        buffer.unmap();
        Ok(out)
    }
}

/// A cache's lock, whatever a panicking holder left: an entry is a
/// pipeline or an empty slot, never half of one.
fn lock<P>(cache: &Mutex<PipelineCache<P>>) -> std::sync::MutexGuard<'_, PipelineCache<P>> {
    cache
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}
