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

/// The names a module file brings in from its child modules (`pub use
/// error::{Error, Result};`, `pub use run::{renderer, pool};`, `use
/// device::created;`), each with the child module it comes from.
fn exports(file: &Path) -> BTreeMap<String, String> {
    let code = code_of(file);
    let mut names = BTreeMap::new();
    for stmt in code.split(';') {
        // `use`, `pub use` or `pub(…) use` at the start of a line.
        let Some(at) = stmt.find("use ").filter(|&i| {
            let line = stmt[..i].rsplit('\n').next().unwrap_or("").trim();
            line.is_empty() || line == "pub" || (line.starts_with("pub(") && line.ends_with(')'))
        }) else {
            continue;
        };
        let stmt = &stmt[at + 4..];
        let Some((module, items)) = stmt.split_once("::") else {
            continue;
        };
        for item in items
            .trim()
            .trim_matches(|c| c == '{' || c == '}')
            .split(',')
        {
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

/// The items a module file defines itself (`pub enum GpuError`).
fn defined(file: &Path) -> BTreeSet<String> {
    let code = code_of(file);
    let words: Vec<&str> = code
        .split(|c: char| !(c.is_alphanumeric() || c == '_'))
        .filter(|w| !w.is_empty())
        .collect();
    words
        .windows(2)
        .filter(|w| {
            matches!(
                w[0],
                "struct" | "enum" | "fn" | "const" | "static" | "type" | "trait"
            )
        })
        .map(|w| w[1].to_owned())
        .collect()
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

/// The module path of a file of `src/` (`gpu/run/renderer.rs` is
/// `gpu::run::renderer`, `gpu/run/mod.rs` is `gpu::run`).
fn module_path(src: &Path, file: &Path) -> Vec<String> {
    let mut path: Vec<String> = file
        .strip_prefix(src)
        .unwrap()
        .components()
        .map(|c| c.as_os_str().to_str().unwrap().to_owned())
        .collect();
    let last = path.pop().unwrap();
    let stem = last.strip_suffix(".rs").unwrap_or(&last);
    if stem != "mod" {
        path.push(stem.to_owned());
    }
    path
}

/// The members of the folder `folder` (a module path) that `file` names:
/// `crate::folder::m`, and `super::m` (`super::super::m`, …) where that
/// lands in the folder.
fn members_named(src: &Path, file: &Path, folder: &[String]) -> BTreeSet<String> {
    let code = code_of(file);
    let mut names = BTreeSet::new();
    if !folder.is_empty() {
        names.extend(references(&code, &format!("crate::{}", folder.join("::"))));
    }
    let own = module_path(src, file);
    // `super` is the parent of the file's module.
    for up in 1..=own.len() {
        let parent = &own[..own.len() - up];
        if parent != folder {
            continue;
        }
        let prefix = vec!["super"; up].join("::");
        let found = references(&code, &prefix);
        // `super::super::x` also reads as `super::super` from `super`:
        // keep only the paths that end in the folder.
        names.extend(found.into_iter().filter(|n| n != "super"));
    }
    names
}

/// The files of each folder of `src/`, nested ones included, import one
/// another without a cycle. A folder's members are its files, its
/// `mod.rs` (for what it defines itself, `GpuError`) and its subfolders
/// (each with every file below it): `gpu/run/` is one member of `gpu/`,
/// and `gpu/run/renderer.rs` one of `gpu/run/`. A name a `mod.rs` brings
/// in from a child (`pub use run::{renderer, pool};`) stands for that
/// child.
#[test]
fn the_files_of_a_folder_form_no_cycle() {
    let src = repo().join("src");
    let mut problems = Vec::new();
    let mut dirs = Vec::new();
    folders(&src, &mut dirs);
    assert!(
        dirs.iter().any(|d| d.ends_with("operators/aces2"))
            && dirs.iter().any(|d| d.ends_with("gpu/run")),
        "nested folders are read"
    );
    let mut edges = 0;
    for dir in dirs {
        let folder = module_path(&src, &dir.join("mod.rs"));
        // Each member and the files that are its own.
        let mut members: BTreeMap<String, Vec<PathBuf>> = BTreeMap::new();
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            let Some(stem) = p.file_stem().and_then(|s| s.to_str()).map(str::to_owned) else {
                continue;
            };
            if p.is_dir() {
                let mut files = Vec::new();
                rust_files(&p, &mut files);
                members.insert(stem, files);
            } else if p.extension().is_some_and(|e| e == "rs") {
                members.entry(stem).or_default().push(p);
            }
        }
        let mod_rs = dir.join("mod.rs");
        let (brought, own_items) = match mod_rs.exists() {
            true => (exports(&mod_rs), defined(&mod_rs)),
            false => (BTreeMap::new(), BTreeSet::new()),
        };
        // A name to the member it stands for: a member, what `mod.rs`
        // brings in from one (through another name as often as it takes),
        // or an item `mod.rs` defines.
        let member_of = |name: &str| -> Option<String> {
            let mut name = name.to_owned();
            for _ in 0..4 {
                if members.contains_key(&name) && name != "mod" {
                    return Some(name);
                }
                match brought.get(&name) {
                    Some(m) => name = m.clone(),
                    None => break,
                }
            }
            (own_items.contains(&name) && members.contains_key("mod")).then(|| "mod".to_owned())
        };
        let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for (member, files) in &members {
            for file in files {
                // `mod.rs` bringing its children in is no import of its own.
                let names = match file == &mod_rs {
                    true => BTreeSet::new(),
                    false => members_named(&src, file, &folder),
                };
                for name in names {
                    if let Some(used) = member_of(&name) {
                        if used != *member {
                            graph.entry(member.clone()).or_default().insert(used);
                            edges += 1;
                        }
                    }
                }
            }
        }
        if let Some(c) = cycle(&graph) {
            problems.push(format!("src/{}: {}", folder.join("/"), c.join(" -> ")));
        }
    }
    assert!(edges > 100, "only {edges} imports were read");
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
    assert_eq!(gpu.get("renderer").map(String::as_str), Some("run"));
    assert_eq!(gpu.get("GpuInput").map(String::as_str), Some("input"));
    assert!(defined(&repo().join("src/gpu/mod.rs")).contains("GpuError"));
    // `gpu/run/renderer.rs` names its own folder's `readback` by `super`
    // and another folder's `wiring` through `crate::gpu`.
    let src = repo().join("src");
    let renderer = src.join("gpu/run/renderer.rs");
    let run = ["gpu".to_owned(), "run".to_owned()];
    assert!(members_named(&src, &renderer, &run).contains("readback"));
    assert!(members_named(&src, &renderer, &run[..1]).contains("wiring"));
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
