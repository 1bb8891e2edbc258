//! Which adapters there are and which one to open: the backend
//! (`--backend`), Vulkan drivers that packages install outside the loader's
//! folders (SwiftShader inside Chromium), the choice among the adapters found
//! (`--adapter`), and what every result records about the one opened.

use crate::gpu::GpuError;
use serde::Serialize;
use std::path::PathBuf;
use std::sync::OnceLock;

/// Which adapter to open: on which backend, and which of its adapters.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct AdapterChoice {
    pub pick: AdapterPick,
    pub backend: BackendChoice,
}

impl AdapterChoice {
    /// `pick` on the default backend.
    pub fn new(pick: AdapterPick) -> AdapterChoice {
        AdapterChoice {
            pick,
            backend: BackendChoice::Default,
        }
    }

    /// The same pick on `backend`.
    pub fn on(self, backend: BackendChoice) -> AdapterChoice {
        AdapterChoice { backend, ..self }
    }
}

/// `--adapter`: `[BACKEND:]PICK`, e.g. `swiftshader`, `gl:llvmpipe`, `hardware`.
impl std::str::FromStr for AdapterChoice {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if let Some((backend, pick)) = s.split_once(':') {
            if let Ok(backend) = backend.parse::<BackendChoice>() {
                return Ok(AdapterChoice {
                    pick: pick.parse()?,
                    backend,
                });
            }
        }
        Ok(AdapterChoice::new(s.parse()?))
    }
}

/// Which of a backend's adapters (`--adapter`).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum AdapterPick {
    /// lavapipe/llvmpipe when present, else another software rasterizer,
    /// else the first. Chosen as the default on purpose: the built-in bounds
    /// and the CI runs were measured on it, and it gives the same results on
    /// every machine, so a gate at defaults means the same everywhere. A GPU
    /// is tested by asking for it (`hardware` or a name), and a run that
    /// passes hardware over says so.
    #[default]
    Default,
    /// The best hardware adapter: discrete, else integrated, else virtual.
    Hardware,
    /// The first adapter the drivers list.
    Any,
    /// The first whose name contains this (case-insensitive).
    Name(String),
}

impl std::str::FromStr for AdapterPick {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Ok(match s {
            "" | "default" => AdapterPick::Default,
            "hardware" => AdapterPick::Hardware,
            "any" => AdapterPick::Any,
            name => AdapterPick::Name(name.to_owned()),
        })
    }
}

/// The graphics API wgpu drives the adapter through (`--backend`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BackendChoice {
    /// Vulkan where it has an adapter (the bounds were measured there),
    /// else any backend that has one.
    #[default]
    Default,
    Vulkan,
    /// OpenGL (ES) through EGL: on Linux Mesa's, headless (surfaceless).
    Gl,
    Metal,
    Dx12,
    /// Every backend this build has.
    Any,
}

impl std::str::FromStr for BackendChoice {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Ok(match s.to_ascii_lowercase().as_str() {
            "" | "default" => BackendChoice::Default,
            "vulkan" | "vk" => BackendChoice::Vulkan,
            "gl" | "gles" | "opengl" => BackendChoice::Gl,
            "metal" => BackendChoice::Metal,
            "dx12" | "d3d12" => BackendChoice::Dx12,
            "any" => BackendChoice::Any,
            other => {
                return Err(format!(
                    "unknown backend {other:?}: vulkan, gl, metal, dx12, any or default"
                ))
            }
        })
    }
}

impl BackendChoice {
    /// The wgpu backends to enumerate, in the order they are tried.
    pub(crate) fn tries(self) -> Vec<wgpu::Backends> {
        match self {
            BackendChoice::Default => vec![wgpu::Backends::VULKAN, every_backend()],
            BackendChoice::Vulkan => vec![wgpu::Backends::VULKAN],
            BackendChoice::Gl => vec![wgpu::Backends::GL],
            BackendChoice::Metal => vec![wgpu::Backends::METAL],
            BackendChoice::Dx12 => vec![wgpu::Backends::DX12],
            BackendChoice::Any => vec![every_backend()],
        }
    }
}

/// Every native backend (not the browser's WebGPU).
fn every_backend() -> wgpu::Backends {
    wgpu::Backends::VULKAN | wgpu::Backends::GL | wgpu::Backends::METAL | wgpu::Backends::DX12
}

/// Vulkan drivers (ICD manifests) that packages install outside the folders
/// the Vulkan loader searches, so that no adapter they provide is found
/// without `VK_ICD_FILENAMES`. tonegate adds those present here with the
/// loader's `VK_ADD_DRIVER_FILES` (loader 1.3.234 and later) when an adapter
/// asked for by name is not otherwise found, and when listing adapters.
/// docs/adapters.md lists them too.
pub const EXTRA_VULKAN_DRIVERS: &[&str] = &[
    // SwiftShader as Debian's and Ubuntu's `chromium` packages ship it.
    "/usr/lib/chromium/vk_swiftshader_icd.json",
    // Ubuntu's older `chromium-browser` and Fedora's `chromium`.
    "/usr/lib/chromium-browser/vk_swiftshader_icd.json",
    "/usr/lib64/chromium-browser/vk_swiftshader_icd.json",
    // Google Chrome's .deb and .rpm.
    "/opt/google/chrome/vk_swiftshader_icd.json",
];

/// The extra drivers present on this machine.
pub fn extra_vulkan_drivers() -> Vec<PathBuf> {
    EXTRA_VULKAN_DRIVERS
        .iter()
        .map(PathBuf::from)
        .filter(|p| p.is_file())
        .collect()
}

/// Adds the extra drivers present to `VK_ADD_DRIVER_FILES`, once per
/// process; returns whether any was added. Nothing is added when the user
/// pinned the drivers (`VK_ICD_FILENAMES` or `VK_DRIVER_FILES`): they asked
/// for those and no others.
///
/// This changes the process environment, which the Vulkan loader reads when
/// an instance is created; at most once per process. Changing the
/// environment while another thread reads it is not safe in C, so a program
/// with threads calls this first, while it has one (the command line does,
/// whenever an adapter is asked for by name); `select` calls it only if
/// nobody did and the name was not found.
pub fn add_extra_vulkan_drivers() -> bool {
    *EXTRA_ADDED.get_or_init(|| {
        let pinned = ["VK_ICD_FILENAMES", "VK_DRIVER_FILES"]
            .iter()
            .any(|v| std::env::var_os(v).is_some_and(|s| !s.is_empty()));
        let extra = extra_vulkan_drivers();
        if pinned || extra.is_empty() {
            return false;
        }
        let mut files: Vec<PathBuf> = std::env::var_os("VK_ADD_DRIVER_FILES")
            .map(|v| std::env::split_paths(&v).collect())
            .unwrap_or_default();
        let before = files.len();
        for p in extra {
            if !files.contains(&p) {
                files.push(p);
            }
        }
        if files.len() == before {
            return false;
        }
        match std::env::join_paths(&files) {
            Ok(joined) => {
                std::env::set_var("VK_ADD_DRIVER_FILES", joined);
                true
            }
            Err(_) => false,
        }
    })
}

/// Whether [`add_extra_vulkan_drivers`] ran and added any.
static EXTRA_ADDED: OnceLock<bool> = OnceLock::new();

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
    /// Whether the adapter flushes f32 subnormals to zero, as measured by
    /// the probe shader when the device was opened (`gpu::probe`); `None` in
    /// reports written before the probe existed.
    #[serde(default)]
    pub flushes_subnormals: Option<bool>,
    /// How the shader compiler evaluated the probe's divisions, where a
    /// rewrite could be seen ("as written", "(a/b)/c as a/(b*c)", "a/b as
    /// a*(1/b)"; docs/stress.md#range-safe-arithmetic).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub division: Option<String>,
    /// Why this adapter: what was asked for, and what else was there.
    #[serde(default)]
    pub chosen: String,
}

/// What [`choose`] sees of an adapter.
#[derive(Clone, Debug)]
pub struct Candidate {
    pub name: String,
    pub device_type: wgpu::DeviceType,
    pub backend: wgpu::Backend,
    /// What it lacks that every stage needs ([`super::capability::lacks`]); `None` for a
    /// usable adapter.
    pub lacks: Option<String>,
}

impl Candidate {
    /// A CPU rasterizer: llvmpipe/lavapipe, SwiftShader, WARP.
    fn is_software(&self) -> bool {
        let n = self.name.to_lowercase();
        self.device_type == wgpu::DeviceType::Cpu
            || n.contains("llvmpipe")
            || n.contains("lavapipe")
            || n.contains("swiftshader")
    }

    /// The rasterizer the built-in bounds were measured on.
    fn is_llvmpipe(&self) -> bool {
        let n = self.name.to_lowercase();
        n.contains("llvmpipe") || n.contains("lavapipe")
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

    fn label(&self) -> String {
        format!("{} ({:?})", self.name, self.backend)
    }
}

/// Picks the adapter `pick` asks for among `found` (in the drivers' order)
/// and says why, naming the hardware passed over when the default picks the
/// software rasterizer.
/// An adapter that lacks what every stage needs is never picked; where the
/// pick would have been one, the error names it and what it lacks.
pub fn choose(pick: &AdapterPick, found: &[Candidate]) -> Result<(usize, String), GpuError> {
    let usable: Vec<usize> = (0..found.len())
        .filter(|&i| found[i].lacks.is_none())
        .collect();
    let among: Vec<Candidate> = usable.iter().map(|&i| found[i].clone()).collect();
    match choose_among(pick, &among) {
        Ok((i, why)) => Ok((usable[i], why)),
        Err(e) => {
            let refused = found.iter().find(|c| {
                c.lacks.is_some()
                    && choose_among(
                        pick,
                        &[Candidate {
                            lacks: None,
                            ..(*c).clone()
                        }],
                    )
                    .is_ok()
            });
            match refused {
                Some(c) => Err(GpuError::Unsupported {
                    adapter: c.label(),
                    reason: c.lacks.clone().unwrap_or_default(),
                }),
                None => Err(e),
            }
        }
    }
}

fn choose_among(pick: &AdapterPick, found: &[Candidate]) -> Result<(usize, String), GpuError> {
    if found.is_empty() {
        return Err(GpuError::NoAdapter);
    }
    let names = || {
        found
            .iter()
            .map(Candidate::label)
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
    let software = found
        .iter()
        .position(Candidate::is_llvmpipe)
        .or_else(|| found.iter().position(Candidate::is_software));
    Ok(match pick {
        AdapterPick::Default => match software {
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
        AdapterPick::Hardware => {
            let i = best_hardware.ok_or_else(|| GpuError::NoHardwareAdapter {
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
        AdapterPick::Any => (
            0,
            format!(
                "--adapter any: the first the drivers list of {} (drivers outside the loader's folders, which `tonegate adapters` lists first, join only for an adapter asked for by name)",
                names()
            ),
        ),
        AdapterPick::Name(name) => {
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

/// A wgpu instance for `backends`, with the validation layer (and debug
/// names) only where the environment asks for them (`WGPU_VALIDATION=1`,
/// see `gpu::validation`): wgpu's own default turns them on in every build with
/// debug assertions, which would make `cargo test` run under the Khronos
/// layer, 2-10× slower, wherever it happens to be installed.
pub(crate) fn instance(backends: wgpu::Backends) -> wgpu::Instance {
    let mut flags = wgpu::InstanceFlags::empty().with_env();
    if super::validation::requested() {
        // The messages reach the gate only through the logger, and wgpu
        // registers its messenger only with debug names on.
        flags |= wgpu::InstanceFlags::DEBUG;
        if let Err(e) = super::validation::install() {
            eprintln!("warning: {e}");
        }
    }
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = backends;
    desc.flags = flags;
    wgpu::Instance::new(desc)
}

/// The adapters of the first of `backend`'s tries that has any, with the
/// extra Vulkan drivers added first when `extra` asks for them.
pub(crate) fn enumerate(backend: BackendChoice, extra: bool) -> Vec<wgpu::Adapter> {
    if extra {
        add_extra_vulkan_drivers();
    }
    for backends in backend.tries() {
        let found = pollster::block_on(instance(backends).enumerate_adapters(backends));
        if !found.is_empty() {
            return found;
        }
    }
    Vec::new()
}

/// The adapter `choice` selects, and why.
pub(crate) fn select(choice: &AdapterChoice) -> Result<(wgpu::Adapter, String), GpuError> {
    let candidates = |adapters: &[wgpu::Adapter]| -> Vec<Candidate> {
        adapters
            .iter()
            .map(|a| {
                let info = a.get_info();
                Candidate {
                    name: info.name,
                    device_type: info.device_type,
                    backend: info.backend,
                    lacks: super::capability::lacks(a),
                }
            })
            .collect()
    };
    let mut adapters = enumerate(choice.backend, false);
    let mut picked = choose(&choice.pick, &candidates(&adapters));
    // A name not found may be a driver outside the loader's folders.
    let wants_vulkan = matches!(
        choice.backend,
        BackendChoice::Default | BackendChoice::Vulkan | BackendChoice::Any
    );
    if matches!(
        picked,
        Err(GpuError::AdapterNotFound { .. }
            | GpuError::NoHardwareAdapter { .. }
            | GpuError::NoAdapter)
    ) && wants_vulkan
        && add_extra_vulkan_drivers()
    {
        adapters = enumerate(choice.backend, false);
        picked = choose(&choice.pick, &candidates(&adapters));
    }
    let (i, mut why) = picked?;
    // Say where the list came from when it includes drivers tonegate added.
    if EXTRA_ADDED.get() == Some(&true) {
        why.push_str(&format!(
            " (with the Vulkan drivers added from outside the loader's folders: {})",
            extra_vulkan_drivers()
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    Ok((adapters.swap_remove(i), why))
}

#[cfg(test)]
#[path = "adapters_tests.rs"]
mod tests;
