//! The library's floors, checked: every module stands on a floor and names
//! only modules of lower floors (or its own), and no two source files import
//! each other, directly or round a loop. `docs/architecture.md` draws them.
//!
//! A module is named by a path `crate::…` in code (comments and the test
//! modules that close a file, after `#[cfg(test)]`, are not read: a test may
//! simulate a session or run a verb to check a lower floor). A file's imports
//! are the source files its `crate::…` and `super::…` paths resolve to; a
//! `mod.rs` declaring its children is not an import of them.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Each module's floor, from the ground up; a path belongs to the longest
/// entry it starts with.
const FLOORS: &[(&str, u32)] = &[
    // Stopping a long computation between its steps: under everything that
    // computes, the session's passes over the rows too.
    ("cancel", 0),
    // What a calibration is made from, and how reports are written: they
    // know nothing else of armcal.
    ("session", 1),
    ("report", 1),
    // Files in and out, into the session's types.
    ("io", 2),
    // Using a calibration: predict, compensate, export, stream, serve.
    ("apply", 3),
    // The calibration's ground: dense matrices, threads, gravity.
    ("calibration::dense", 4),
    ("calibration::parallel", 4),
    ("calibration::gravity", 4),
    // The simulator (true robots with gravity's compliance).
    ("calibration::simulate", 5),
    // The least-squares fit.
    ("calibration::fit", 6),
    // How good a fit is: folds, deleted residuals, statistics, acceptance.
    ("calibration::validation", 7),
    // The verbs' science, on the fit and its validation.
    ("calibration::identify", 8),
    ("calibration::check", 8),
    ("calibration::plan", 8),
    ("calibration::diagnose", 9),
    ("calibration::reproduce", 9),
    ("calibration::holdout", 10),
    ("calibration::sweep", 10),
    ("calibration::demo", 11),
    // Each verb's request and run, for the command line and Python.
    ("commands", 12),
];

/// The floor entry `path` (a module path without `crate::`) belongs to.
fn floor_of(path: &str) -> Option<(&'static str, u32)> {
    FLOORS
        .iter()
        .filter(|(m, _)| path == *m || path.starts_with(&format!("{m}::")))
        .max_by_key(|(m, _)| m.len())
        .copied()
}

/// The library's source files (`src/…` without the binary's own: `main.rs`,
/// `cli.rs`, `verbs.rs`, `terminal.rs`, `args.rs`; and without the files of
/// tests) and their module paths.
fn sources() -> Vec<(PathBuf, Vec<String>)> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                walk(&path, out);
            } else if path.extension().is_some_and(|e| e == "rs") {
                out.push(path);
            }
        }
    }
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    walk(&src, &mut files);
    files.sort();
    files
        .into_iter()
        .filter_map(|f| {
            let rel = f.strip_prefix(&src).unwrap().with_extension("");
            let mut module: Vec<String> = rel
                .components()
                .map(|c| c.as_os_str().to_string_lossy().into_owned())
                .collect();
            if module.last().is_some_and(|m| m == "mod") {
                module.pop();
            }
            let top = module.first()?.as_str();
            let binary = ["main", "cli", "verbs", "terminal", "args", "lib"];
            // A file of tests (`tests.rs`, `constraint_tests.rs`) may reach up.
            let tests = module.last().is_some_and(|m| m.ends_with("tests"));
            (!binary.contains(&top) && !tests).then_some((f, module))
        })
        .collect()
}

/// The code of `text` a reader of the library's floors reads: up to its
/// test module (`#[cfg(test)]` over `mod NAME {`), comments left out; with
/// each line's number.
fn code(text: &str) -> impl Iterator<Item = (usize, &str)> {
    let lines: Vec<&str> = text.lines().collect();
    let end = lines
        .windows(2)
        .position(|w| {
            w[0].trim() == "#[cfg(test)]"
                && w[1].trim_start().starts_with("mod ")
                && w[1].trim_end().ends_with('{')
        })
        .unwrap_or(lines.len());
    lines
        .into_iter()
        .take(end)
        .enumerate()
        .map(|(n, l)| (n + 1, l.split("//").next().unwrap_or("")))
}

/// The module paths (`a::b::c`, without `crate::`) that `line` names, its
/// `super::` paths resolved from `module` (the file's own module path: a
/// `mod.rs` is its folder's module, whose `super` is the folder's parent).
fn named(line: &str, module: &[String]) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    let segments = |rest: &str| -> Vec<String> {
        rest.split("::")
            .map(|s| {
                s.chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect::<String>()
            })
            .take_while(|s| !s.is_empty() && s.chars().next().is_some_and(char::is_lowercase))
            .collect()
    };
    for (i, _) in line.match_indices("crate::") {
        let before = line[..i].chars().last();
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == ':') {
            continue;
        }
        out.push(segments(&line[i + "crate::".len()..]));
    }
    for (i, _) in line.match_indices("super::") {
        if line[..i].ends_with("super::")
            || line[..i]
                .chars()
                .last()
                .is_some_and(|c| c.is_alphanumeric() || c == '_')
        {
            continue;
        }
        let mut rest = &line[i + "super::".len()..];
        let mut base: Vec<String> = module.to_vec();
        base.pop();
        while let Some(r) = rest.strip_prefix("super::") {
            base.pop();
            rest = r;
        }
        base.extend(segments(rest));
        out.push(base);
    }
    out
}

/// The source file a module path resolves to: the longest prefix of it that
/// is a file (`a/b.rs` or `a/b/mod.rs`).
fn resolve(path: &[String], files: &BTreeMap<Vec<String>, PathBuf>) -> Option<PathBuf> {
    (1..=path.len())
        .rev()
        .find_map(|k| files.get(&path[..k]).cloned())
}

/// No module names a module of a higher floor, or of another module on its
/// own floor.
#[test]
fn no_import_runs_back_up() {
    let sources = sources();
    assert!(sources.len() > 100, "{}", sources.len());
    let mut refused = Vec::new();
    for (file, module) in &sources {
        let joined = module.join("::");
        let text = std::fs::read_to_string(file).unwrap();
        let Some((own, floor)) = floor_of(&joined) else {
            // A folder of floors (`calibration`) only declares its modules.
            let folder = FLOORS
                .iter()
                .any(|(m, _)| m.starts_with(&format!("{joined}::")));
            assert!(
                folder || joined == "test_support" || joined == "layers",
                "{}: no floor for {joined} in FLOORS",
                file.display()
            );
            if folder {
                for (n, line) in code(&text) {
                    assert!(
                        named(line, module).is_empty(),
                        "{}:{n}: a folder of floors names a module: {line}",
                        file.display()
                    );
                }
            }
            continue;
        };
        for (n, line) in code(&text) {
            for path in named(line, module) {
                let Some((theirs, their_floor)) = floor_of(&path.join("::")) else {
                    continue;
                };
                if theirs != own && their_floor >= floor {
                    refused.push(format!(
                        "{}:{n}: {own} (floor {floor}) names {theirs} (floor {their_floor}): {}",
                        file.display(),
                        line.trim()
                    ));
                }
            }
        }
    }
    assert!(refused.is_empty(), "{}", refused.join("\n"));
}

/// No source file imports itself round a loop of others (a circle): the
/// files' import graph, each file's `crate::` and `super::` paths resolved to
/// the files that define them, has no cycle.
#[test]
fn no_files_import_each_other() {
    let sources = sources();
    let files: BTreeMap<Vec<String>, PathBuf> = sources
        .iter()
        .map(|(f, m)| (m.clone(), f.clone()))
        .collect();
    let mut imports: BTreeMap<PathBuf, BTreeSet<PathBuf>> = BTreeMap::new();
    for (file, module) in &sources {
        let text = std::fs::read_to_string(file).unwrap();
        let targets = imports.entry(file.clone()).or_default();
        for (_, line) in code(&text) {
            for path in named(line, module) {
                let Some(target) = resolve(&path, &files) else {
                    continue;
                };
                if &target != file {
                    targets.insert(target);
                }
            }
        }
    }
    // Depth-first search for a back edge; the loop is named if found.
    #[derive(Clone, Copy, PartialEq)]
    enum Mark {
        Open,
        Done,
    }
    fn visit(
        f: &PathBuf,
        imports: &BTreeMap<PathBuf, BTreeSet<PathBuf>>,
        marks: &mut BTreeMap<PathBuf, Mark>,
        stack: &mut Vec<PathBuf>,
    ) -> Option<Vec<PathBuf>> {
        match marks.get(f) {
            Some(Mark::Done) => return None,
            Some(Mark::Open) => {
                let from = stack.iter().position(|s| s == f).unwrap();
                return Some(stack[from..].to_vec());
            }
            None => {}
        }
        marks.insert(f.clone(), Mark::Open);
        stack.push(f.clone());
        for t in imports.get(f).into_iter().flatten() {
            if let Some(circle) = visit(t, imports, marks, stack) {
                return Some(circle);
            }
        }
        stack.pop();
        marks.insert(f.clone(), Mark::Done);
        None
    }
    let mut marks = BTreeMap::new();
    for f in imports.keys() {
        let mut stack = Vec::new();
        if let Some(circle) = visit(f, &imports, &mut marks, &mut stack) {
            panic!(
                "files that import each other: {}",
                circle
                    .iter()
                    .map(|p| p.display().to_string())
                    .collect::<Vec<_>>()
                    .join(" -> ")
            );
        }
    }
}
