//! docs/commands.md against the program: every flag a command's `--help`
//! lists is in that command's synopsis on the page (or in one of the two
//! families the page describes in words: the GPU options and
//! `--db-retry-s`; or, for `tonemap` and `bench`, an operator's parameter,
//! which `tonegate operators` lists), and every flag a synopsis names is
//! one its command takes.

use crate::common;
use std::collections::{BTreeMap, BTreeSet};

fn help(path: &[&str]) -> String {
    let mut args = path.to_vec();
    args.push("--help");
    let o = common::tonegate(&args);
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8(o.stdout).unwrap()
}

/// The names under `Commands:` in a help text, without `help`.
fn subcommands(text: &str) -> Vec<String> {
    text.lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|w| *w != "help")
        .map(str::to_owned)
        .collect()
}

/// The long flags under `Options:` in a help text, without `--help` and
/// `--version`.
fn help_flags(text: &str) -> BTreeSet<String> {
    text.lines()
        .skip_while(|l| !l.starts_with("Options:"))
        .skip(1)
        // An option's own line is indented by at most 6 (`  -o, --out`,
        // `      --suite`); its description's lines are indented further.
        .filter(|l| l.len() - l.trim_start().len() <= 6)
        .filter_map(|l| {
            let l = l.trim_start();
            let l = l
                .strip_prefix('-')
                .and_then(|r| r.get(3..))
                .filter(|_| !l.starts_with("--"))
                .unwrap_or(l);
            l.strip_prefix("--").map(|rest| {
                let name: String = rest
                    .chars()
                    .take_while(|c| c.is_ascii_alphanumeric() || *c == '-')
                    .collect();
                format!("--{name}")
            })
        })
        .filter(|f| f != "--help" && f != "--version")
        .collect()
}

/// Every `--flag` in `text`.
fn flags_in(text: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let mut rest = text;
    while let Some(at) = rest.find("--") {
        let name: String = rest[at + 2..]
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '-')
            .collect();
        if name.chars().next().is_some_and(|c| c.is_ascii_lowercase()) {
            out.insert(format!("--{name}"));
        }
        rest = &rest[at + 2..];
    }
    out
}

#[test]
fn every_flag_is_in_its_synopsis_and_every_synopsis_flag_is_taken() {
    let page = std::fs::read_to_string(common::repo().join("docs/commands.md")).unwrap();
    let block = page
        .split("```sh\n")
        .nth(1)
        .and_then(|b| b.split("```").next())
        .expect("the synopsis block");
    // Each synopsis: its `tonegate …` line and the indented lines after it,
    // without `#` comments.
    let mut synopses: Vec<(Vec<String>, String)> = Vec::new();
    for line in block.lines() {
        let line = line.split(" #").next().unwrap_or("");
        if let Some(rest) = line.strip_prefix("tonegate ") {
            let words = rest
                .split_whitespace()
                .take_while(|w| w.chars().all(|c| c.is_ascii_lowercase()))
                .map(str::to_owned)
                .collect();
            synopses.push((words, line.to_owned()));
        } else if line.starts_with(' ') {
            if let Some(last) = synopses.last_mut() {
                last.1.push('\n');
                last.1.push_str(line);
            }
        }
    }
    // The families the page describes in words, checked to be there.
    let gpu = [
        "--adapter",
        "--backend",
        "--hdr-format",
        "--reduction",
        "--env-filter",
        "--execution",
    ];
    let prose: String = page.split("```").step_by(2).collect();
    for f in gpu.iter().chain(&["--db-retry-s"]) {
        assert!(
            prose.contains(&format!("`{f}")),
            "the page's words name {f}"
        );
    }
    let operators = common::tonegate(&["operators", "--json"]);
    let operators: serde_json::Value = serde_json::from_slice(&operators.stdout).unwrap();
    let operator_flags: BTreeSet<String> = operators
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|o| o["params"].as_array().unwrap().iter())
        .map(|p| format!("--{}", p["name"].as_str().unwrap().replace('_', "-")))
        .collect();

    let mut wrong: BTreeMap<String, String> = BTreeMap::new();
    let mut paths: Vec<Vec<String>> = Vec::new();
    for c in subcommands(&help(&[])) {
        let subs = subcommands(&help(&[c.as_str()]));
        paths.push(vec![c.clone()]);
        paths.extend(subs.into_iter().map(|s| vec![c.clone(), s]));
    }
    for path in &paths {
        let args: Vec<&str> = path.iter().map(String::as_str).collect();
        let taken = help_flags(&help(&args));
        let subs = subcommands(&help(&args));
        let documented: BTreeSet<String> = synopses
            .iter()
            .filter(|(words, _)| {
                words.starts_with(path) && words.get(path.len()).is_none_or(|w| !subs.contains(w))
            })
            .flat_map(|(_, text)| flags_in(text))
            .collect();
        if documented.is_empty() && !subs.is_empty() {
            // A command of subcommands alone (`frames`, `golden`).
            continue;
        }
        let name = path.join(" ");
        let family = |f: &str| {
            (gpu.contains(&f) && taken.contains("--adapter"))
                || (f == "--db-retry-s" && taken.contains("--db"))
                || (matches!(name.as_str(), "tonemap" | "bench") && operator_flags.contains(f))
        };
        let missing: Vec<&String> = taken
            .iter()
            .filter(|f| !documented.contains(*f) && !family(f))
            .collect();
        let unknown: Vec<&String> = documented.iter().filter(|f| !taken.contains(*f)).collect();
        if !missing.is_empty() || !unknown.is_empty() {
            wrong.insert(
                name,
                format!(
                    "not in its synopsis: {missing:?}; in its synopsis but not taken: {unknown:?}"
                ),
            );
        }
    }
    assert!(paths.len() > 20, "{paths:?}");
    assert!(
        wrong.is_empty(),
        "docs/commands.md disagrees with --help:\n{wrong:#?}"
    );
}
