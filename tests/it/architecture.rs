//! ARCHITECTURE.md's claims about imports, checked against the source: its
//! layer table lists every top-level module, a module imports (`crate::m`)
//! only from its own layer or those below, the top-level modules form no
//! cycle, and inside a folder the files (`super::m`, `crate::folder::m`)
//! form no cycle either. The layer table is read from ARCHITECTURE.md
//! itself, so the document and this test cannot drift apart.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Module → layer, from the rows `| N | `a`, `b` | ... |` of the table.
fn layers() -> BTreeMap<String, u32> {
    let text = std::fs::read_to_string(repo().join("ARCHITECTURE.md")).unwrap();
    let mut layers = BTreeMap::new();
    for line in text.lines() {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        if cells.len() < 4 {
            continue;
        }
        // The binary's own modules sit above every layer of the library.
        let layer = match cells[1] {
            "bin" => u32::MAX,
            n => match n.parse::<u32>() {
                Ok(layer) => layer,
                Err(_) => continue,
            },
        };
        for name in cells[2].split(',') {
            let name = name.trim().trim_matches('`');
            if !name.is_empty() {
                layers.insert(name.to_owned(), layer);
            }
        }
    }
    layers
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

/// The source without comments (a line's text from `//` on is dropped
/// unless the `//` sits inside a string literal).
fn code_of(path: &Path) -> String {
    let text = std::fs::read_to_string(path).unwrap();
    let mut code = String::new();
    for line in text.lines() {
        let mut in_string = false;
        let mut prev = ' ';
        let mut cut = line.len();
        for (i, c) in line.char_indices() {
            if c == '"' && prev != '\\' {
                in_string = !in_string;
            }
            if !in_string && c == '/' && prev == '/' {
                cut = i - 1;
                break;
            }
            prev = c;
        }
        code.push_str(&line[..cut]);
        code.push('\n');
    }
    code
}

/// Every `prefix::name` and `prefix::{a, b::c}` in `code`: the first path
/// segment after `prefix::`.
fn references(code: &str, prefix: &str) -> BTreeSet<String> {
    let mut found = BTreeSet::new();
    let pat = format!("{prefix}::");
    let mut rest = code;
    while let Some(i) = rest.find(&pat) {
        let before = rest[..i].chars().next_back();
        rest = &rest[i + pat.len()..];
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == ':') {
            continue;
        }
        if let Some(group) = rest.strip_prefix('{') {
            let end = group.find('}').unwrap_or(group.len());
            for item in group[..end].split(',') {
                let name: String = item
                    .trim()
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                if !name.is_empty() {
                    found.insert(name);
                }
            }
        } else {
            let name: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            if !name.is_empty() {
                found.insert(name);
            }
        }
    }
    found
}

/// A cycle in `graph`, if there is one, as the path around it.
fn cycle(graph: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        node: &str,
        graph: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        path: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        match state.get(node) {
            Some(2) => return None,
            Some(1) => {
                let start = path.iter().position(|n| n == node).unwrap_or(0);
                let mut c = path[start..].to_vec();
                c.push(node.to_owned());
                return Some(c);
            }
            _ => {}
        }
        state.insert(node.to_owned(), 1);
        path.push(node.to_owned());
        for next in graph.get(node).into_iter().flatten() {
            if let Some(c) = visit(next, graph, state, path) {
                return Some(c);
            }
        }
        path.pop();
        state.insert(node.to_owned(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for node in graph.keys() {
        if let Some(c) = visit(node, graph, &mut state, &mut Vec::new()) {
            return Some(c);
        }
    }
    None
}

/// The names a module file re-exports (`pub use error::{Error, Result};`,
/// `pub use wiring::GpuInput;`), each with the child module it comes from.
fn exports(file: &Path) -> BTreeMap<String, String> {
    let code = code_of(file);
    let mut names = BTreeMap::new();
    for stmt in code.split(';') {
        let Some(path) = stmt.trim().strip_prefix("pub use ") else {
            continue;
        };
        let Some((module, items)) = path.split_once("::") else {
            continue;
        };
        for item in items.trim_matches(|c| c == '{' || c == '}').split(',') {
            // `a::b::Name` and `Name as Other` export their last name.
            let item = item.split(" as ").last().unwrap_or("").trim();
            let name = item.rsplit("::").next().unwrap_or("").trim();
            if !name.is_empty() {
                names.insert(name.to_owned(), module.trim().to_owned());
            }
        }
    }
    names
}

/// The top-level module a file of src/ belongs to.
fn module_of(src: &Path, file: &Path) -> Option<String> {
    let rel = file.strip_prefix(src).ok()?;
    let first = rel.components().next()?.as_os_str().to_str()?;
    let name = first.strip_suffix(".rs").unwrap_or(first);
    (!matches!(name, "lib" | "main")).then(|| name.to_owned())
}

#[test]
fn modules_import_only_from_their_layer_or_below_and_form_no_cycle() {
    let layers = layers();
    assert!(
        layers.len() > 20,
        "ARCHITECTURE.md's layer table was not found ({} rows)",
        layers.len()
    );
    let exports = exports(&repo().join("src/lib.rs"));
    assert_eq!(
        exports.get("Error").map(String::as_str),
        Some("error"),
        "lib.rs's re-exports were not read"
    );
    let src = repo().join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let mut problems = Vec::new();
    for file in &files {
        let Some(module) = module_of(&src, file) else {
            continue;
        };
        let Some(&own) = layers.get(&module) else {
            problems.push(format!("{module} is not in ARCHITECTURE.md's layer table"));
            continue;
        };
        for used in references(&code_of(file), "crate") {
            let used = exports.get(&used).cloned().unwrap_or(used);
            if used == module || !layers.contains_key(&used) {
                // Itself, or a macro or other item of the crate root.
                continue;
            }
            let theirs = layers[&used];
            if theirs > own {
                problems.push(format!(
                    "{} (layer {own}) imports {used} (layer {theirs})",
                    file.strip_prefix(repo()).unwrap().display()
                ));
            }
            graph.entry(module.clone()).or_default().insert(used);
        }
    }
    if let Some(c) = cycle(&graph) {
        problems.push(format!("modules import each other: {}", c.join(" -> ")));
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// Every folder under `dir`, at any depth.
fn folders(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.push(p.clone());
            folders(&p, out);
        }
    }
}

/// The files of each folder of `src/`, nested ones included
/// (`src/operators/aces2`), import one another without a cycle.
#[test]
fn the_files_of_a_folder_form_no_cycle() {
    let src = repo().join("src");
    let mut problems = Vec::new();
    let mut dirs = Vec::new();
    folders(&src, &mut dirs);
    assert!(
        dirs.iter().any(|d| d.ends_with("operators/aces2")),
        "nested folders are read"
    );
    for dir in dirs {
        // The module path below the crate: `operators::aces2`.
        let folder = dir
            .strip_prefix(&src)
            .unwrap()
            .components()
            .map(|c| c.as_os_str().to_str().unwrap().to_owned())
            .collect::<Vec<_>>()
            .join("::");
        let siblings: BTreeSet<String> = std::fs::read_dir(&dir)
            .unwrap()
            .filter_map(|e| {
                let p = e.unwrap().path();
                let stem = p.file_stem()?.to_str()?.to_owned();
                (p.extension().is_some_and(|e| e == "rs") && stem != "mod").then_some(stem)
            })
            .collect();
        // A name the folder's mod.rs re-exports stands for its module.
        let reexported = match dir.join("mod.rs").exists() {
            true => exports(&dir.join("mod.rs")),
            false => BTreeMap::new(),
        };
        let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for file in &siblings {
            let code = code_of(&dir.join(format!("{file}.rs")));
            let used = references(&code, "super")
                .into_iter()
                .chain(references(&code, &format!("crate::{folder}")));
            for used in used {
                let used = reexported.get(&used).cloned().unwrap_or(used);
                if siblings.contains(&used) && used != *file {
                    graph.entry(file.clone()).or_default().insert(used);
                }
            }
        }
        if let Some(c) = cycle(&graph) {
            problems.push(format!(
                "src/{}: {}",
                folder.replace("::", "/"),
                c.join(" -> ")
            ));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// The checks above can fail: a cycle is found, a grouped import is read as
/// the modules it names, and a re-export as the module it comes from.
#[test]
fn the_import_reader_finds_cycles_and_grouped_imports() {
    let graph: BTreeMap<String, BTreeSet<String>> =
        [("a", vec!["b"]), ("b", vec!["c"]), ("c", vec!["a"])]
            .into_iter()
            .map(|(k, v)| (k.to_owned(), v.into_iter().map(str::to_owned).collect()))
            .collect();
    assert_eq!(cycle(&graph).unwrap(), ["a", "b", "c", "a"]);
    let found = references(
        "use crate::{gpu::X, io};\nlet y = crate::metrics::f(); tonegate::plan::x",
        "crate",
    );
    assert_eq!(
        found.into_iter().collect::<Vec<_>>(),
        ["gpu", "io", "metrics"]
    );
    let gpu = exports(&repo().join("src/gpu/mod.rs"));
    assert_eq!(gpu.get("GpuRenderer").map(String::as_str), Some("renderer"));
    assert_eq!(gpu.get("GpuInput").map(String::as_str), Some("input"));
}

/// No module outside `src/operators/` names a built-in operator in a
/// string (its tests aside): the names other modules need are the
/// registry's constants (`operators::REINHARD_GLOBAL`), so adding or
/// renaming an operator touches `operators/` only. A file's tests start at
/// its `#[cfg(test)]`; `tests.rs` and `*_tests.rs` files are tests whole.
#[test]
fn only_the_operators_module_names_an_operator() {
    let src = repo().join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    // Names, not the old aliases: `seed001` is also the bright pass's old
    // spelling.
    let names: Vec<String> = tonegate::operators::builtin()
        .iter()
        .map(|op| format!("\"{}\"", op.name()))
        .collect();
    let mut found = Vec::new();
    for file in files {
        let rel = file
            .strip_prefix(&src)
            .unwrap()
            .to_string_lossy()
            .into_owned();
        let stem = file.file_stem().unwrap().to_string_lossy().into_owned();
        if rel.starts_with("operators/") || stem == "tests" || stem.ends_with("_tests") {
            continue;
        }
        let code = code_of(&file);
        let code = code.split("#[cfg(test)]").next().unwrap_or_default();
        for n in &names {
            if code.contains(n.as_str()) {
                found.push(format!("src/{rel}: {n}"));
            }
        }
    }
    assert!(found.is_empty(), "{}", found.join("\n"));
}
