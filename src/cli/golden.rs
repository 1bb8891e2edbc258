//! `golden bless` and `golden verify`.

use super::invalid;
use super::progress::Bar;
use clap::Subcommand;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use tonegate::error::Result;
use tonegate::scene::Scene;

#[derive(Subcommand)]
pub enum GoldenCommand {
    /// Re-render goldens with the CPU reference (all scenes, or the named ones).
    Bless {
        scenes: Vec<String>,
        #[arg(long, default_value = "golden/suite.toml")]
        suite: PathBuf,
    },
    /// Re-render and require bit-identical frames and an up-to-date manifest.
    Verify {
        scenes: Vec<String>,
        #[arg(long, default_value = "golden/suite.toml")]
        suite: PathBuf,
    },
}

pub fn golden(c: GoldenCommand) -> Result<ExitCode> {
    match c {
        GoldenCommand::Bless { scenes, suite } => bless(&suite, &scenes),
        GoldenCommand::Verify { scenes, suite } => verify(&suite, &scenes),
    }
}

/// The suite's scenes, or only the named ones (an unknown name is an error).
fn select_scenes(suite: &Path, names: &[String]) -> Result<Vec<Scene>> {
    let all = tonegate::suite::load_suite(suite)?;
    if names.is_empty() {
        return Ok(all);
    }
    names
        .iter()
        .map(|n| {
            all.iter().find(|s| &s.name == n).cloned().ok_or_else(|| {
                let known: Vec<&str> = all.iter().map(|s| s.name.as_str()).collect();
                invalid(format!(
                    "no scene {n:?} in {}; known: {}",
                    suite.display(),
                    known.join(", ")
                ))
            })
        })
        .collect()
}

fn golden_root(suite: &Path) -> PathBuf {
    suite
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."))
}

fn bless(suite: &Path, names: &[String]) -> Result<ExitCode> {
    let scenes = select_scenes(suite, names)?;
    let root = golden_root(suite);
    tonegate::golden::bless(&root, &scenes, &Bar::new())?;
    let frames: u32 = scenes.iter().map(|s| s.frames).sum();
    println!(
        "blessed {} scenes, {frames} frames into {} (beside the suite file); it holds {}",
        scenes.len(),
        root.display(),
        size_words(tonegate::golden::directory_bytes(&root))
    );
    Ok(ExitCode::SUCCESS)
}

fn verify(suite: &Path, names: &[String]) -> Result<ExitCode> {
    let scenes = select_scenes(suite, names)?;
    let root = golden_root(suite);
    let problems = tonegate::golden::verify(&root, &scenes, &Bar::new())?;
    if problems.is_empty() {
        let frames: u32 = scenes.iter().map(|s| s.frames).sum();
        println!(
            "{} scenes, {frames} frames: bit-identical to their goldens",
            scenes.len()
        );
        Ok(ExitCode::SUCCESS)
    } else {
        for p in &problems {
            println!("{p}");
        }
        Ok(ExitCode::from(1))
    }
}

/// A size in the unit that shows it: bytes, kB or MB (SI).
fn size_words(bytes: u64) -> String {
    match bytes {
        b if b < 1_000 => format!("{b} bytes"),
        b if b < 1_000_000 => format!("{:.1} kB", b as f64 / 1e3),
        b => format!("{:.1} MB", b as f64 / 1e6),
    }
}
