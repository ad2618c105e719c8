//! The house rules a reviewer would otherwise check by hand.
//!
//! **The layers.** Cargo keeps the crates of crates/ acyclic. Inside each
//! crate (and the root package's src/) the child modules of every module
//! (the crate root's top-level modules, and each module folder's files)
//! import each other without a cycle: every `crate::`, `super::` or
//! `self::` path in code (not in comments) from inside child a to child b
//! is an edge, and the graph has no strongly connected component of two
//! or more modules.
//!
//! **A method imports nothing from a sibling method.** Every file under
//! crates/estimation/src/methods belongs to a method (`X.rs` and `X/`) or
//! to the common modules (`common/`); its code (not its comments) names no
//! other method's module, as `crate::methods::NAME`, inside a
//! `crate::methods::{...}` group or as `super::NAME` from a method's root.
//! What several methods share lives in a common module; a common module
//! names no method.
//!
//! **Every number in docs/findings.md is held by a test.** A finding is a
//! bullet, a paragraph or a table of the document's sections; one that
//! states a number (any digit) names, in backticks, the test that asserts
//! it: a `#[test]` function of tests/ or src/, by its name or by a filter
//! `cargo test` matches it with (a part of its name). A bullet may also
//! lean on its section's lead paragraph, and a table on the paragraph
//! before it. The test reads the document and the test sources only.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn rust_files(folder: &Path, into: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(folder) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            rust_files(&path, into);
        } else if path.extension().is_some_and(|e| e == "rs") {
            into.push(path);
        }
    }
}

/// The source folders: the root package's src/ and each crate's.
fn source_folders() -> Vec<PathBuf> {
    let mut folders = vec![root().join("src")];
    let mut crates: Vec<PathBuf> = std::fs::read_dir(root().join("crates"))
        .unwrap()
        .flatten()
        .map(|e| e.path().join("src"))
        .filter(|p| p.is_dir())
        .collect();
    crates.sort();
    folders.extend(crates);
    folders
}

/// The names of every test function of tests/ and the sources: a `fn`
/// within three lines after `#[test]` (other attributes may stand between).
fn test_names() -> BTreeSet<String> {
    let mut files = Vec::new();
    rust_files(&root().join("tests"), &mut files);
    for folder in source_folders() {
        rust_files(&folder, &mut files);
    }
    let mut names = BTreeSet::new();
    for file in files {
        let text = std::fs::read_to_string(&file).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        for (i, line) in lines.iter().enumerate() {
            if line.trim() != "#[test]" {
                continue;
            }
            for next in lines.iter().skip(i + 1).take(3) {
                let t = next.trim();
                if let Some(rest) = t
                    .strip_prefix("fn ")
                    .or_else(|| t.strip_prefix("async fn "))
                {
                    let name: String = rest
                        .chars()
                        .take_while(|c| c.is_alphanumeric() || *c == '_')
                        .collect();
                    names.insert(name);
                    break;
                }
            }
        }
    }
    names
}

/// Whether a text names a test in backticks: a test function's full
/// name, or a `cargo test …` command whose filter (its last word that is
/// not a flag or `--nocapture`) is part of a test's name.
fn names_a_test(text: &str, tests: &BTreeSet<String>) -> bool {
    text.split('`').skip(1).step_by(2).any(|span| {
        let span = span.trim();
        if span.starts_with("cargo test") {
            let filter = span
                .split_whitespace()
                .rev()
                .find(|w| !w.starts_with('-'))
                .unwrap_or("");
            filter.len() >= 6 && tests.iter().any(|t| t.contains(filter))
        } else {
            span.split(|c: char| c.is_whitespace() || c == ',')
                .any(|w| {
                    tests.contains(w.trim_matches(|c: char| !(c.is_alphanumeric() || c == '_')))
                })
        }
    })
}

#[derive(Debug)]
struct Block {
    line: usize,
    text: String,
    bullet: bool,
    table: bool,
    lead: bool,
}

/// The document's findings, section by section (text before the first
/// `## ` is the preamble and is skipped, and so are fenced examples).
fn blocks(doc: &str) -> Vec<Vec<Block>> {
    let mut sections: Vec<Vec<Block>> = Vec::new();
    let mut current: Option<Block> = None;
    let flush = |current: &mut Option<Block>, sections: &mut Vec<Vec<Block>>| {
        if let (Some(block), Some(section)) = (current.take(), sections.last_mut()) {
            section.push(block);
        }
    };
    let mut fenced = false;
    for (i, line) in doc.lines().enumerate() {
        if line.starts_with("```") {
            fenced = !fenced;
            flush(&mut current, &mut sections);
            continue;
        }
        if fenced {
            continue;
        }
        if line.starts_with("## ") || line.starts_with("### ") {
            flush(&mut current, &mut sections);
            sections.push(Vec::new());
            continue;
        }
        if sections.is_empty() {
            continue;
        }
        let table = line.starts_with('|');
        let starts_bullet = line.starts_with("- ");
        let blank = line.trim().is_empty();
        let continues = current
            .as_ref()
            .is_some_and(|b| !blank && !starts_bullet && b.table == table && (!b.bullet || !table));
        if blank {
            flush(&mut current, &mut sections);
        } else if continues {
            let block = current.as_mut().unwrap();
            block.text.push('\n');
            block.text.push_str(line);
        } else {
            flush(&mut current, &mut sections);
            let lead = sections.last().is_some_and(|s| s.is_empty());
            current = Some(Block {
                line: i + 1,
                text: line.to_string(),
                bullet: starts_bullet,
                table,
                lead: lead && !starts_bullet && !table,
            });
        }
    }
    flush(&mut current, &mut sections);
    sections
}

/// The findings that state a number and name no test that holds it.
fn unheld(doc: &str, tests: &BTreeSet<String>) -> Vec<(usize, String)> {
    let mut missing = Vec::new();
    for section in blocks(doc) {
        let lead_holds = section
            .first()
            .is_some_and(|b| b.lead && names_a_test(&b.text, tests));
        let mut previous_holds = false;
        for block in &section {
            let holds = names_a_test(&block.text, tests);
            let numbered = block.text.chars().any(|c| c.is_ascii_digit());
            let held = holds
                || (block.bullet && lead_holds)
                || (block.table && previous_holds)
                || !numbered;
            if !held {
                let first: String = block
                    .text
                    .lines()
                    .next()
                    .unwrap_or("")
                    .chars()
                    .take(90)
                    .collect();
                missing.push((block.line, first));
            }
            if !block.table {
                previous_holds = holds || (block.bullet && lead_holds);
            }
        }
    }
    missing
}

/// Whether a reference page's text states a measurement: it says it
/// measured (`Measured:`, `**Measured**`, `measured on`) or names a worst case
/// (`worst`), and gives a number.
fn states_a_measurement(text: &str) -> bool {
    let marked = [
        "Measured:",
        "**Measured**",
        "Measured on ",
        "measured on ",
        "measured:",
        "worst ",
    ]
    .iter()
    .any(|m| text.contains(m));
    marked && text.chars().any(|c| c.is_ascii_digit())
}

/// The reference pages' measured statements that neither name a test nor
/// point to findings.md, where the measurement and its test are.
fn unreferenced_measurements(doc: &str, tests: &BTreeSet<String>) -> Vec<(usize, String)> {
    blocks(doc)
        .into_iter()
        .flatten()
        .filter(|b| states_a_measurement(&b.text))
        .filter(|b| !names_a_test(&b.text, tests) && !b.text.contains("findings.md"))
        .map(|b| {
            (
                b.line,
                b.text
                    .lines()
                    .next()
                    .unwrap_or("")
                    .chars()
                    .take(90)
                    .collect(),
            )
        })
        .collect()
}

#[test]
fn measurements_in_the_reference_point_to_their_test() {
    let tests = test_names();
    let mut listing = Vec::new();
    for page in [
        "docs/methods.md",
        "docs/conventions.md",
        "docs/files.md",
        "docs/cli.md",
        "docs/import.md",
        "docs/jsbsim.md",
        "docs/plugins.md",
        "docs/testing.md",
        "README.md",
    ] {
        let doc = std::fs::read_to_string(root().join(page)).unwrap();
        let doc = format!("## {page}\n\n{doc}");
        for (line, text) in unreferenced_measurements(&doc, &tests) {
            listing.push(format!("{page}:{}: {text}", line - 2));
        }
    }
    assert!(
        listing.is_empty(),
        "{} measured statements name no test and no finding:\n{}",
        listing.len(),
        listing.join("\n")
    );
}

#[test]
fn every_number_in_the_findings_names_the_test_that_holds_it() {
    let tests = test_names();
    assert!(
        tests.len() > 300,
        "found only {} test functions",
        tests.len()
    );
    let doc = std::fs::read_to_string(root().join("docs/findings.md")).unwrap();
    let missing = unheld(&doc, &tests);
    let listing: Vec<String> = missing
        .iter()
        .map(|(line, text)| format!("docs/findings.md:{line}: {text}"))
        .collect();
    assert!(
        missing.is_empty(),
        "{} findings state a number without naming the test that holds it:\n{}",
        missing.len(),
        listing.join("\n")
    );
}

#[test]
fn the_check_refuses_a_number_without_a_test_and_takes_one_with() {
    let tests: BTreeSet<String> = ["bounds_hold_over_seeds".to_string()].into();
    let doc = "# F\n\nintro 12\n\n## S\n\nLead without a test.\n\n- **A** 3.5σ off.\n- **B** 1.2σ (`cargo test bounds_hold`).\n\nParagraph 7 without a test.\n\n| a | 1 |\n";
    let missing = unheld(doc, &tests);
    let lines: Vec<usize> = missing.iter().map(|m| m.0).collect();
    assert_eq!(lines, vec![9, 12, 14], "{missing:?}");
    let held = "## S\n\nMeasured by `bounds_hold_over_seeds`.\n\n- 3.5σ off.\n\n| a | 1 |\n";
    assert!(unheld(held, &tests).is_empty());
}

/// The cycles of a graph: its strongly connected components of two or
/// more nodes (Tarjan's algorithm).
fn cycles(graph: &BTreeMap<String, BTreeMap<String, String>>) -> Vec<Vec<String>> {
    struct Search<'a> {
        graph: &'a BTreeMap<String, BTreeMap<String, String>>,
        index: BTreeMap<String, usize>,
        low: BTreeMap<String, usize>,
        stack: Vec<String>,
        components: Vec<Vec<String>>,
    }
    fn visit(search: &mut Search, v: &str) {
        let n = search.index.len();
        search.index.insert(v.to_string(), n);
        search.low.insert(v.to_string(), n);
        search.stack.push(v.to_string());
        let next: Vec<String> = search
            .graph
            .get(v)
            .map(|edges| edges.keys().cloned().collect())
            .unwrap_or_default();
        for w in next {
            if !search.index.contains_key(&w) {
                visit(search, &w);
                let low = search.low[v].min(search.low[&w]);
                search.low.insert(v.to_string(), low);
            } else if search.stack.contains(&w) {
                let low = search.low[v].min(search.index[&w]);
                search.low.insert(v.to_string(), low);
            }
        }
        if search.low[v] == search.index[v] {
            let mut component = Vec::new();
            while let Some(w) = search.stack.pop() {
                let done = w == v;
                component.push(w);
                if done {
                    break;
                }
            }
            if component.len() > 1 {
                component.sort();
                search.components.push(component);
            }
        }
    }
    let mut search = Search {
        graph,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        components: Vec::new(),
    };
    for v in graph.keys() {
        if !search.index.contains_key(v) {
            visit(&mut search, v);
        }
    }
    search.components
}

#[test]
fn the_cycle_check_finds_a_cycle() {
    let edge = |to: &str| (to.to_string(), "here".to_string());
    let graph: BTreeMap<String, BTreeMap<String, String>> = [
        ("a".to_string(), [edge("b")].into()),
        ("b".to_string(), [edge("c")].into()),
        ("c".to_string(), [edge("a")].into()),
        ("d".to_string(), [edge("a")].into()),
    ]
    .into();
    assert_eq!(cycles(&graph), vec![vec!["a", "b", "c"]]);
}

/// The module path of a source file below `src` (`a/b.rs` and
/// `a/b/mod.rs`: `[a, b]`; the crate root: `[]`).
fn module_path(src: &Path, file: &Path) -> Vec<String> {
    let relative = file
        .strip_prefix(src)
        .unwrap()
        .to_string_lossy()
        .to_string();
    let mut path: Vec<String> = relative.split('/').map(str::to_string).collect();
    let last = path.pop().unwrap_or_default();
    let stem = last.trim_end_matches(".rs");
    if !matches!(stem, "mod" | "lib" | "main") {
        path.push(stem.to_string());
    }
    path
}

/// The module paths a line of code names (`crate::a::b`, `super::c`,
/// `self::d`), resolved against the module `at`, each as far as its
/// lower-case segments go.
fn named_modules(code: &str, at: &[String]) -> Vec<Vec<String>> {
    let mut found = Vec::new();
    let bytes = code.as_bytes();
    for start in ["crate::", "super::", "self::"] {
        for (i, _) in code.match_indices(start) {
            if i > 0
                && (bytes[i - 1].is_ascii_alphanumeric()
                    || bytes[i - 1] == b'_'
                    || bytes[i - 1] == b':')
            {
                continue;
            }
            let rest: String = code[i..]
                .chars()
                .take_while(|c| {
                    c.is_ascii_lowercase() || c.is_ascii_digit() || *c == '_' || *c == ':'
                })
                .collect();
            let mut path: Vec<String> = match start {
                "crate::" => Vec::new(),
                _ => at.to_vec(),
            };
            for segment in rest.split("::").filter(|s| !s.is_empty()) {
                match segment {
                    "crate" | "self" => {}
                    "super" => {
                        path.pop();
                    }
                    other => path.push(other.to_string()),
                }
            }
            found.push(path);
        }
    }
    found
}

/// For every module folder of a crate (the crate root included), the
/// graph of its child modules: child a → child b where code inside a
/// names b (by `crate::`, `super::` or `self::` paths).
fn child_module_graphs(
    src: &Path,
) -> BTreeMap<Vec<String>, BTreeMap<String, BTreeMap<String, String>>> {
    let shown = src.strip_prefix(root()).unwrap_or(src).to_path_buf();
    let mut files = Vec::new();
    rust_files(src, &mut files);
    let modules: BTreeSet<Vec<String>> = files.iter().map(|f| module_path(src, f)).collect();
    let mut graphs: BTreeMap<Vec<String>, BTreeMap<String, BTreeMap<String, String>>> =
        BTreeMap::new();
    for file in &files {
        let at = module_path(src, file);
        let text = std::fs::read_to_string(file).unwrap();
        let relative = file
            .strip_prefix(src)
            .unwrap()
            .to_string_lossy()
            .to_string();
        for (n, line) in text.lines().enumerate() {
            let code = line.split("//").next().unwrap_or("");
            for target in named_modules(code, &at) {
                // The deepest common parent, and the children of it that
                // hold each end.
                let common = at.iter().zip(&target).take_while(|(a, b)| a == b).count();
                if common >= at.len() || common >= target.len() {
                    continue;
                }
                let parent = at[..common].to_vec();
                let (from, to) = (at[common].clone(), target[common].clone());
                let mut child = parent.clone();
                child.push(to.clone());
                if !modules.contains(&child) {
                    continue;
                }
                graphs
                    .entry(parent)
                    .or_default()
                    .entry(from)
                    .or_default()
                    .entry(to)
                    .or_insert_with(|| format!("{}/{relative}:{}", shown.display(), n + 1));
            }
        }
    }
    graphs
}

#[test]
fn the_modules_of_each_crate_and_module_folder_import_each_other_without_a_cycle() {
    let folders = source_folders();
    assert!(folders.len() >= 9, "{folders:?}");
    let mut found = Vec::new();
    for src in folders {
        for (parent, graph) in child_module_graphs(&src) {
            for component in cycles(&graph) {
                let edges: Vec<String> = component
                    .iter()
                    .flat_map(|a| {
                        graph[a]
                            .iter()
                            .filter(|(b, _)| component.contains(b))
                            .map(move |(b, place)| format!("{a} -> {b} ({place})"))
                    })
                    .collect();
                found.push(format!(
                    "{} in {}::{}: {}",
                    component.join(", "),
                    src.display(),
                    parent.join("::"),
                    edges.join("; ")
                ));
            }
        }
    }
    assert!(found.is_empty(), "module cycles:\n{}", found.join("\n"));
}

#[test]
fn module_paths_resolve_against_the_file() {
    let at = vec!["a".to_string(), "b".to_string()];
    assert_eq!(
        named_modules("use super::c::d; x(crate::e::f)", &at),
        vec![vec!["e", "f"], vec!["a", "c", "d"]]
    );
    assert_eq!(named_modules("super::super::g", &at), vec![vec!["g"]]);
}

/// The modules of crates/estimation/src/methods: its files `X.rs` and
/// folders `X/`, not `mod.rs`.
fn method_modules(methods: &Path) -> BTreeSet<String> {
    std::fs::read_dir(methods)
        .unwrap()
        .flatten()
        .filter_map(|entry| {
            let name = entry.file_name().to_string_lossy().to_string();
            match name.strip_suffix(".rs") {
                Some("mod") => None,
                Some(stem) => Some(stem.to_string()),
                None => entry.path().is_dir().then_some(name),
            }
        })
        .collect()
}

/// The modules of `modules` other than `own` and `common` that `text`, a
/// file of module `own` (`root`: the module's own `X.rs`, where `super::`
/// is the methods folder), names in code: `crate::methods::NAME`, the names
/// of a `crate::methods::{...}` group, `super::NAME` from a root and
/// `super::super::NAME` from a child. Each with its line.
fn sibling_imports(
    own: &str,
    root: bool,
    text: &str,
    modules: &BTreeSet<String>,
) -> Vec<(usize, String)> {
    let code: Vec<&str> = text
        .lines()
        .map(|line| line.split("//").next().unwrap_or(""))
        .collect();
    let joined = code.join("\n");
    let line_of = |offset: usize| joined[..offset].matches('\n').count() + 1;
    let word = |from: &str| -> String {
        from.chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect()
    };
    let mut found: Vec<(usize, String)> = Vec::new();
    let mut prefixes = vec!["crate::methods::"];
    prefixes.push(if root { "super::" } else { "super::super::" });
    for prefix in prefixes {
        for (i, _) in joined.match_indices(prefix) {
            if prefix == "super::" && joined[..i].ends_with("super::") {
                continue;
            }
            let rest = &joined[i + prefix.len()..];
            let names: Vec<String> = match rest.strip_prefix('{') {
                Some(group) => {
                    let group = &group[..group.find('}').unwrap_or(group.len())];
                    group.split(',').map(|item| word(item.trim())).collect()
                }
                None => vec![word(rest)],
            };
            for name in names {
                if name != own && name != "common" && modules.contains(&name) {
                    found.push((line_of(i), name));
                }
            }
        }
    }
    found
}

#[test]
fn a_method_imports_nothing_from_a_sibling_method() {
    let methods = root().join("crates/estimation/src/methods");
    let modules = method_modules(&methods);
    assert!(modules.contains("common") && modules.contains("output_error"));
    let mut files = Vec::new();
    rust_files(&methods, &mut files);
    let mut found = Vec::new();
    for file in files {
        let relative = file.strip_prefix(&methods).unwrap().to_string_lossy();
        if relative == "mod.rs" {
            continue;
        }
        let own = relative.split('/').next().unwrap().trim_end_matches(".rs");
        let root_file = !relative.contains('/');
        let text = std::fs::read_to_string(&file).unwrap();
        // A common module names no method at all.
        let own = if own == "common" { "" } else { own };
        for (line, name) in sibling_imports(own, root_file, &text, &modules) {
            found.push(format!("methods/{relative}:{line} imports method {name}"));
        }
    }
    assert!(
        found.is_empty(),
        "imports of a sibling method (move what is shared into methods/common):\n{}",
        found.join("\n")
    );
}

#[test]
fn the_sibling_check_finds_a_sibling_import() {
    let modules: BTreeSet<String> = ["common", "output_error", "filter_error", "stepwise"]
        .map(String::from)
        .into();
    let text = "//! See [`crate::methods::stepwise`].\nuse crate::methods::common::regression;\nuse crate::methods::output_error::{self, Start};\nuse crate::methods::{common::refusals, stepwise};\nuse super::filter_error; // and crate::methods::stepwise in a comment\nfn f() { crate::methods::filter_error::METHOD; }\n";
    let found = sibling_imports("filter_error", true, text, &modules);
    assert_eq!(
        found,
        vec![(3, "output_error".to_string()), (4, "stepwise".to_string())]
    );
    let child = "use super::*;\nuse super::super::output_error::Start;\n";
    let found = sibling_imports("filter_error", false, child, &modules);
    assert_eq!(found, vec![(2, "output_error".to_string())]);
    assert_eq!(
        sibling_imports("", false, "use crate::methods::stepwise;\n", &modules),
        vec![(1, "stepwise".to_string())]
    );
}
