//! Generates the table of WGSL sources `gpu::shaders` embeds: every
//! `.wgsl` file of `shaders/` and `shaders/shared/`, so that a new stage's
//! shader is embedded by being there (the operators' own modules are
//! embedded by their definitions).

use std::fmt::Write;
use std::path::Path;

fn main() {
    let root = std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR");
    let shaders = Path::new(&root).join("shaders");
    println!("cargo::rerun-if-changed=shaders");
    let mut table = String::from("&[\n");
    for folder in ["shared/", ""] {
        let dir = shaders.join(folder);
        let mut names: Vec<String> = std::fs::read_dir(&dir)
            .unwrap_or_else(|e| panic!("reading {}: {e}", dir.display()))
            .filter_map(|e| e.ok()?.file_name().into_string().ok())
            .filter(|name| name.ends_with(".wgsl"))
            .collect();
        names.sort();
        for name in names {
            let path = dir.join(&name);
            let _ = writeln!(
                table,
                "    ({:?}, include_str!({:?})),",
                format!("{folder}{name}"),
                path.display().to_string()
            );
        }
    }
    table.push_str("]\n");
    let out =
        Path::new(&std::env::var("OUT_DIR").expect("cargo sets OUT_DIR")).join("shader_sources.rs");
    std::fs::write(&out, table).unwrap_or_else(|e| panic!("writing {}: {e}", out.display()));
}
