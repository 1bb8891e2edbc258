//! `tonegate adapters`: every adapter on every backend this build has, with
//! what decides how tonegate runs there (limits, features, subnormals).

use super::adapters::{enumerate, extra_vulkan_drivers, BackendChoice};
use crate::gpu::GpuContext;
use serde::Serialize;

/// One adapter as `tonegate adapters` lists it.
#[derive(Clone, Debug, Serialize)]
pub struct AdapterListing {
    pub name: String,
    pub backend: String,
    pub device_type: String,
    pub driver: String,
    pub driver_info: String,
    pub limits: ListedLimits,
    /// Of the optional features tonegate uses: `subgroups` (the subgroup
    /// reduction tree), `shader-f16`, `timestamp-query` (GPU stage times;
    /// wall-clock otherwise), `float32-filterable` (`--env-filter hardware`).
    pub features: Vec<&'static str>,
    /// Measured by the probe shader on a device opened for it; `None` with
    /// `error` when no device could be opened.
    pub flushes_subnormals: Option<bool>,
    /// The probe's reading of the compiler's divisions
    /// ([`crate::gpu::AdapterReport::division`]).
    pub division: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

/// The limits that bound what tonegate can render on an adapter.
#[derive(Clone, Debug, Serialize)]
pub struct ListedLimits {
    /// The largest frame side (and environment-map side).
    pub max_texture_dimension_2d: u32,
    /// With `max_buffer_size`, the largest frame (`GpuContext::check_frame`).
    pub max_storage_buffer_binding_size: u64,
    pub max_buffer_size: u64,
    /// The shared-memory tree reduction's workgroup.
    pub max_compute_invocations_per_workgroup: u32,
    pub max_compute_workgroup_storage_size: u32,
}

/// The adapters on `backend` (`Any`: every backend; `Default`: what a GPU
/// command chooses among, Vulkan where it has an adapter), with the extra Vulkan
/// drivers added (`adapters::EXTRA_VULKAN_DRIVERS`); each is opened to probe
/// it.
pub fn list(backend: BackendChoice) -> Vec<AdapterListing> {
    let wanted = [
        (wgpu::Features::SUBGROUP, "subgroups"),
        (wgpu::Features::SHADER_F16, "shader-f16"),
        (wgpu::Features::TIMESTAMP_QUERY, "timestamp-query"),
        (wgpu::Features::FLOAT32_FILTERABLE, "float32-filterable"),
    ];
    enumerate(backend, true)
        .iter()
        .map(|a| {
            let info = a.get_info();
            let l = a.limits();
            let features = wanted
                .iter()
                .filter(|(f, _)| a.features().contains(*f))
                .map(|(_, name)| *name)
                .collect();
            let probed = GpuContext::open(a, "listed".into());
            AdapterListing {
                name: info.name,
                backend: format!("{:?}", info.backend),
                device_type: format!("{:?}", info.device_type),
                driver: info.driver,
                driver_info: info.driver_info,
                limits: ListedLimits {
                    max_texture_dimension_2d: l.max_texture_dimension_2d,
                    max_storage_buffer_binding_size: l.max_storage_buffer_binding_size,
                    max_buffer_size: l.max_buffer_size,
                    max_compute_invocations_per_workgroup: l.max_compute_invocations_per_workgroup,
                    max_compute_workgroup_storage_size: l.max_compute_workgroup_storage_size,
                },
                features,
                flushes_subnormals: probed
                    .as_ref()
                    .ok()
                    .and_then(|c| c.adapter.flushes_subnormals),
                division: probed
                    .as_ref()
                    .ok()
                    .and_then(|c| c.adapter.division.clone()),
                error: probed.err().map(|e| e.to_string()),
            }
        })
        .collect()
}

/// Where tonegate looked for Vulkan drivers beyond the loader's folders,
/// and which it found: the listing's footnote.
pub fn extra_drivers_found() -> Vec<String> {
    extra_vulkan_drivers()
        .iter()
        .map(|p| p.display().to_string())
        .collect()
}
