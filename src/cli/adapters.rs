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
