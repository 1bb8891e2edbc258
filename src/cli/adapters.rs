//! `tonegate adapters`: what there is to run on.

use super::BackendArg;
use clap::Args;
use std::process::ExitCode;
use tonegate::error::Result;
use tonegate::gpu::{listing, BackendChoice, GpuError};

#[derive(Args)]
pub struct AdaptersArgs {
    #[command(flatten)]
    pub backend: BackendArg,
    /// Print the list as JSON.
    #[arg(long)]
    pub json: bool,
}

/// 134217728 as "128 MiB".
fn bytes(n: u64) -> String {
    match n {
        n if n >= 1 << 30 && n % (1 << 30) == 0 => format!("{} GiB", n >> 30),
        n if n >= 1 << 20 && n % (1 << 20) == 0 => format!("{} MiB", n >> 20),
        n if n >= 1 << 10 && n % (1 << 10) == 0 => format!("{} KiB", n >> 10),
        n => format!("{n} B"),
    }
}

pub fn adapters(a: AdaptersArgs) -> Result<ExitCode> {
    let backend = a.backend.backend.unwrap_or(BackendChoice::Any);
    let list = listing::list(backend);
    let extra = listing::extra_drivers_found();
    if a.json {
        let out = serde_json::json!({ "adapters": list, "extra_vulkan_drivers": extra });
        println!("{}", serde_json::to_string_pretty(&out).unwrap_or_default());
    } else {
        println!(
            "{:<36} {:<7} {:<13} {:<18} {:>7}  {:<11} features",
            "adapter", "backend", "type", "driver", "texture", "subnormals"
        );
        for l in &list {
            let flush = match (l.flushes_subnormals, &l.error) {
                (Some(true), _) => "flushed",
                (Some(false), _) => "kept",
                (None, _) => "?",
            };
            println!(
                "{:<36} {:<7} {:<13} {:<18} {:>7}  {:<11} {}",
                l.name,
                l.backend,
                l.device_type,
                format!("{} {}", l.driver, l.driver_info)
                    .chars()
                    .take(18)
                    .collect::<String>(),
                l.limits.max_texture_dimension_2d,
                flush,
                l.features.join(", ")
            );
            let lim = &l.limits;
            println!(
                "    limits: storage buffer {}, buffer {}, workgroup {} invocations and {} shared; divisions {}",
                bytes(lim.max_storage_buffer_binding_size),
                bytes(lim.max_buffer_size),
                lim.max_compute_invocations_per_workgroup,
                bytes(lim.max_compute_workgroup_storage_size as u64),
                l.division.as_deref().unwrap_or("?"),
            );
            if let Some(e) = &l.error {
                println!("    could not open it: {e}");
            }
        }
        if !extra.is_empty() {
            println!(
                "\nVulkan drivers found outside the loader's folders (added for this list and for --adapter NAME): {}",
                extra.join(", ")
            );
        }
    }
    if list.is_empty() {
        return Err(GpuError::NoAdapter.into());
    }
    Ok(ExitCode::SUCCESS)
}
