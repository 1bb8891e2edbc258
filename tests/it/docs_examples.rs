//! The commands in README.md and docs/*.md, against the built binary. Every
//! `tonegate …` line of a ```sh block is one of two things:
//!
//! - a synopsis (it has `[…]`, `…`, `a|b` or an upper-case placeholder such
//!   as `FILE`): its subcommand must exist and every `--flag` it names must
//!   be in that subcommand's `--help`;
//! - an example: it runs, in the order of its block, in a folder of its own
//!   beside the repository's `golden/`, and must exit 0, or 1 where its
//!   comment says the gate fails. Its output is checked where it is stable.
//!
//! Commands that serve or wait for work (`serve`, `runner`, a PostgreSQL
//! address), or talk to a server (`--server`), are checked as synopses
//! only; docs/frames.md's walk-through, which serves and submits to it, is
//! run whole by `tests/it/triage_page.rs`. The README's `check --fault-gain`
//! runs on one scene (`--scene grid-static` added): the whole suite under a
//! fault is the gate tests' business, and would cost a minute here.

use crate::common;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

/// One `tonegate` line of a ```sh block.
struct Line {
    file: String,
    number: usize,
    block: usize,
    /// The words after `tonegate`, comment removed.
    words: Vec<String>,
    comment: String,
}

fn documented() -> Vec<Line> {
    let root = common::repo();
    let mut files = vec![root.join("README.md")];
    let mut docs: Vec<PathBuf> = std::fs::read_dir(root.join("docs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    docs.sort();
    files.extend(docs);
    let mut out = Vec::new();
    let mut block = 0;
    for path in files {
        let text = std::fs::read_to_string(&path).unwrap();
        let name = path.strip_prefix(&root).unwrap().display().to_string();
        let mut shell = None::<bool>;
        for (i, l) in text.lines().enumerate() {
            if let Some(lang) = l.trim_start().strip_prefix("```") {
                shell = match shell {
                    None => {
                        block += 1;
                        Some(lang.trim() == "sh")
                    }
                    Some(_) => None,
                };
                continue;
            }
            if shell != Some(true) {
                continue;
            }
            let (code, comment) = match l.find(" #") {
                Some(at) => (&l[..at], l[at + 2..].trim()),
                None => (l, ""),
            };
            let mut words = code.split_whitespace().map(str::to_owned);
            if words.next().as_deref() != Some("tonegate") {
                continue;
            }
            out.push(Line {
                file: name.clone(),
                number: i + 1,
                block,
                words: words.collect(),
                comment: comment.to_owned(),
            });
        }
    }
    out
}

fn is_placeholder(w: &str) -> bool {
    let letters: String = w.chars().filter(|c| c.is_ascii_alphabetic()).collect();
    !letters.is_empty()
        && letters.chars().all(|c| c.is_ascii_uppercase())
        && !w.starts_with('-')
        && !w.contains('.')
}

fn is_synopsis(words: &[String]) -> bool {
    words.iter().any(|w| {
        w.contains('[')
            || w.contains("...")
            || w.contains('…')
            || w.contains('|')
            || is_placeholder(w)
    }) || words
        .first()
        .is_some_and(|w| ["serve", "runner", "enqueue", "fleet"].contains(&w.as_str()))
        || words
            .iter()
            .any(|w| w.contains("postgres://") || w.contains("s3://") || w == "--server")
}

/// The subcommand path a line names (`history prune`, `golden bless`,
/// `check`), and that path's `--help`.
fn help_of(words: &[String], cache: &mut BTreeMap<Vec<String>, String>) -> (Vec<String>, String) {
    let mut path = vec![words[0].clone()];
    if let Some(second) = words.get(1) {
        if second.chars().all(|c| c.is_ascii_lowercase()) && !second.is_empty() {
            let mut two = path.clone();
            two.push(second.clone());
            if help(&two, cache).is_some() && is_subcommand(&path, second, cache) {
                path = two;
            }
        }
    }
    let text =
        help(&path, cache).unwrap_or_else(|| panic!("`tonegate {} --help` fails", path.join(" ")));
    (path, text)
}

fn is_subcommand(parent: &[String], name: &str, cache: &mut BTreeMap<Vec<String>, String>) -> bool {
    let Some(text) = help(parent, cache) else {
        return false;
    };
    // clap lists subcommands under "Commands:", one a line, name first.
    let Some((_, commands)) = text.split_once("Commands:") else {
        return false;
    };
    commands
        .lines()
        .take_while(|l| l.is_empty() || l.starts_with(' '))
        .any(|l| l.split_whitespace().next() == Some(name))
}

fn help(path: &[String], cache: &mut BTreeMap<Vec<String>, String>) -> Option<String> {
    if let Some(h) = cache.get(path) {
        return Some(h.clone());
    }
    let o = common::bare_tonegate()
        .args(path)
        .arg("--help")
        .output()
        .unwrap();
    if !o.status.success() {
        return None;
    }
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    cache.insert(path.to_vec(), text.clone());
    Some(text)
}

/// The `--flag`s a line names (`--json FILE|-` gives `--json`).
fn flags(words: &[String]) -> Vec<String> {
    words
        .iter()
        .flat_map(|w| w.split('|'))
        .map(|w| w.trim_matches(|c: char| c == '[' || c == ']' || c == ',' || c == ')' || c == '('))
        .filter(|w| w.starts_with("--") && w.len() > 2)
        .map(|w| w.split('=').next().unwrap().to_owned())
        .collect()
}

#[test]
fn every_documented_command_exists_with_every_flag_it_names() {
    let lines = documented();
    assert!(lines.len() >= 40, "{} documented lines", lines.len());
    let mut cache = BTreeMap::new();
    let mut wrong = Vec::new();
    for l in &lines {
        let (path, help) = help_of(&l.words, &mut cache);
        for flag in flags(&l.words) {
            let known = help
                .split(|c: char| !(c.is_ascii_alphanumeric() || c == '-'))
                .any(|w| w == flag);
            if !known {
                wrong.push(format!(
                    "{}:{}: `tonegate {}` has no {flag}",
                    l.file,
                    l.number,
                    path.join(" ")
                ));
            }
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

#[test]
fn every_documented_example_runs() {
    let lines: Vec<Line> = documented()
        .into_iter()
        .filter(|l| !is_synopsis(&l.words))
        .collect();
    assert!(lines.len() >= 8, "{} examples", lines.len());
    let mut folders: BTreeMap<usize, tempfile::TempDir> = BTreeMap::new();
    let mut failures = Vec::new();
    for l in &lines {
        let dir = folders.entry(l.block).or_insert_with(|| {
            let d = tempfile::tempdir().unwrap();
            std::os::unix::fs::symlink(common::repo().join("golden"), d.path().join("golden"))
                .unwrap();
            d
        });
        let mut args = l.words.clone();
        if args.first().map(String::as_str) == Some("check") {
            args.extend([
                "--scene".into(),
                "grid-static".into(),
                "--no-history".into(),
            ]);
        }
        let expected = if l.comment.contains("fails") { 1 } else { 0 };
        let o = Command::new(env!("CARGO_BIN_EXE_tonegate"))
            .args(&args)
            .current_dir(dir.path())
            .env_remove("TONEGATE_DB")
            .output()
            .unwrap();
        let what = format!("{}:{}: tonegate {}", l.file, l.number, args.join(" "));
        if o.status.code() != Some(expected) {
            failures.push(format!(
                "{what}: exit {:?}, expected {expected}: {}",
                o.status.code(),
                String::from_utf8_lossy(&o.stderr)
            ));
            continue;
        }
        if let Some(problem) = check_output(&args, dir.path(), &o.stdout) {
            failures.push(format!("{what}: {problem}"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// What an example's output must show, where it is stable: each `-o` file
/// (and `--flip-map` and the like) exists and is not empty, `operators`
/// names every built-in operator, `compare` gives a PSNR.
fn check_output(args: &[String], dir: &Path, stdout: &[u8]) -> Option<String> {
    for (i, a) in args.iter().enumerate() {
        if ["-o", "--flip-map", "--ssim-map", "--diff"].contains(&a.as_str()) {
            let file = dir.join(&args[i + 1]);
            if std::fs::metadata(&file).map_or(true, |m| m.len() == 0) {
                return Some(format!("wrote no {}", file.display()));
            }
        }
    }
    let text = String::from_utf8_lossy(stdout);
    match args.first().map(String::as_str) {
        Some("operators") => tonegate::operators::names()
            .into_iter()
            .find(|n| !text.contains(n))
            .map(|n| format!("does not list {n}")),
        Some("compare") if !text.contains("PSNR") => Some(format!("gives no PSNR: {text}")),
        _ => None,
    }
}

/// Every file of the repository the docs name in backquotes
/// (`tests/it/taa.rs`, `shaders/shared/colour.wgsl#…`) is there: a file
/// moved or split leaves no doc pointing at nothing.
#[test]
fn every_path_the_docs_name_exists() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut docs: Vec<PathBuf> = std::fs::read_dir(root.join("docs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .collect();
    docs.extend(["README.md", "ARCHITECTURE.md"].map(|f| root.join(f)));
    let tops = [
        "src/",
        "tests/",
        "shaders/",
        "examples/",
        "benches/",
        "ci/",
        "golden/",
        "docs/",
        "fuzz/",
    ];
    let mut named = 0;
    let mut missing = Vec::new();
    for doc in &docs {
        let text = std::fs::read_to_string(doc).unwrap();
        for quoted in text.split('`').skip(1).step_by(2) {
            let path = quoted.split('#').next().unwrap();
            let plain = path
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "_./-".contains(c));
            if !plain || !tops.iter().any(|t| path.starts_with(t)) {
                continue;
            }
            named += 1;
            if !root.join(path).exists() {
                missing.push(format!("{}: {path}", doc.display()));
            }
        }
    }
    assert!(named > 50, "only {named} paths found: the scan is broken");
    assert!(
        missing.is_empty(),
        "docs name files that are not there:\n{}",
        missing.join("\n")
    );
}
