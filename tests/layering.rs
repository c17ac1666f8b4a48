//! The module layering of `src/`, checked by reading the source (docs/architecture.md, "Module
//! order"). Every top-level module may import (`crate::<module>`) only modules listed before
//! it in [`ORDER`]: the foundation (math, mesh, material, state, compiled), then the seven
//! stages in step order (a stage may read an earlier stage's results, never a later one's),
//! then the pipeline that drives them, then io, script and cli. So no import goes up, and no
//! two modules import each other.
//!
//! It also holds the house rule on function length ([`long_functions_say_why`]).
//!
//! Comments are skipped (a doc link may point anywhere), and so is a file's trailing
//! `#[cfg(test)]` module: unit tests may build a whole `Simulation` to exercise their stage.

use std::collections::BTreeMap;
use std::path::Path;

/// The allowed order, lowest first. Written once here and shown in docs/architecture.md.
const ORDER: &[&str] = &[
    // foundation
    "math",
    "limits",
    "params",
    "mesh",
    "material",
    "state",
    "compiled",
    // the seven stages, in step order
    "elements",
    "joints",
    "fracture",
    "contact_detection",
    "contact_interaction",
    "loads",
    "integration",
    "parallel",
    // the step, on top of the stages
    "pipeline",
    // around the engine
    "io",
    "script",
    "cli",
];

/// Top-level module of a path under `src/` (`src/joints/law.rs` → `joints`).
fn module_of(src: &Path, file: &Path) -> Option<String> {
    let rel = file.strip_prefix(src).ok()?;
    let first = rel.components().next()?.as_os_str().to_str()?;
    let name = first.strip_suffix(".rs").unwrap_or(first);
    (name != "lib" && name != "main").then(|| name.to_string())
}

fn rust_files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The modules a line of code names as `crate::m` or inside `crate::{m, n::…}`.
fn imported_modules(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = line;
    while let Some(i) = rest.find("crate::") {
        rest = &rest[i + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            // Top-level names of a use group (nested braces belong to their name).
            let mut depth = 0;
            let mut name = String::new();
            let mut at_start = true;
            for c in group.chars() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => break,
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        if !name.is_empty() {
                            out.push(std::mem::take(&mut name));
                        }
                        at_start = true;
                        continue;
                    }
                    _ => {}
                }
                if depth == 0 && at_start {
                    if c.is_alphanumeric() || c == '_' {
                        name.push(c);
                    } else if !name.is_empty() {
                        out.push(std::mem::take(&mut name));
                        at_start = false;
                    }
                }
            }
            if !name.is_empty() {
                out.push(name);
            }
        } else {
            let name: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            if !name.is_empty() {
                out.push(name);
            }
        }
    }
    out
}

/// (importing module → imported module → first place), code only.
fn imports(src: &Path) -> BTreeMap<String, BTreeMap<String, String>> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    files.sort();
    let mut map: BTreeMap<String, BTreeMap<String, String>> = BTreeMap::new();
    for f in files {
        let Some(m) = module_of(src, &f) else {
            continue;
        };
        let text = std::fs::read_to_string(&f).unwrap();
        // A `use` group may span lines: join each statement's lines before reading it.
        let mut pending = String::new();
        let mut pending_line = 0;
        for (k, line) in text.lines().enumerate() {
            let code = line.split("//").next().unwrap_or("");
            if line.trim_start().starts_with("#[cfg(test)]") {
                break;
            }
            if pending.is_empty() {
                pending_line = k + 1;
            }
            pending.push_str(code);
            pending.push(' ');
            let open = pending.matches('{').count() > pending.matches('}').count();
            if pending.trim_start().starts_with("use ") && open {
                continue; // an unfinished use group
            }
            for target in imported_modules(&pending) {
                if target != m {
                    let place = format!("{}:{pending_line}", f.display());
                    map.entry(m.clone())
                        .or_default()
                        .entry(target)
                        .or_insert(place);
                }
            }
            pending.clear();
        }
    }
    map
}

#[test]
fn no_module_imports_a_module_above_it() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let rank = |m: &str| ORDER.iter().position(|o| *o == m);
    let map = imports(&src);
    let mut problems = Vec::new();
    for (m, targets) in &map {
        let Some(rm) = rank(m) else {
            problems.push(format!(
                "module '{m}' is not in the layering ORDER of tests/layering.rs (add it where it belongs, and to docs/architecture.md)"
            ));
            continue;
        };
        for (t, place) in targets {
            match rank(t) {
                None => problems.push(format!(
                    "{place}: '{m}' imports crate::{t}, which is not a known top-level module"
                )),
                Some(rt) if rt >= rm => problems.push(format!(
                    "{place}: '{m}' imports '{t}', which sits above it (order: {})",
                    ORDER.join(" < ")
                )),
                _ => {}
            }
        }
    }
    for (m, targets) in &map {
        let list: Vec<&str> = targets.keys().map(|s| s.as_str()).collect();
        println!("{m:>20} -> {}", list.join(", "));
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// Every top-level module of `src/` is in ORDER, and ORDER names no module that is gone.
#[test]
fn the_order_lists_every_module() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut found: Vec<String> = std::fs::read_dir(&src)
        .unwrap()
        .filter_map(|e| module_of(&src, &e.unwrap().path()))
        .collect();
    found.sort();
    // `m.rs` beside a folder `m/` of its submodules is one module.
    found.dedup();
    let mut listed: Vec<String> = ORDER.iter().map(|s| s.to_string()).collect();
    listed.sort();
    assert_eq!(found, listed);
}

/// The reader itself: groups, nested groups and paths are found; comments are not code.
#[test]
fn the_import_reader_finds_groups_and_paths() {
    assert_eq!(
        imported_modules("use crate::{math::{Real, Vec3}, mesh, state::Nodes};"),
        ["math", "mesh", "state"]
    );
    assert_eq!(
        imported_modules("let x = crate::joints::law::f(crate::math::ZERO);"),
        ["joints", "math"]
    );
    assert!(imported_modules("use rayon::prelude::*;").is_empty());
}

/// docs/architecture.md shows the same order.
#[test]
fn the_architecture_page_shows_the_order() {
    let doc =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/architecture.md"))
            .unwrap();
    let line = ORDER.join(" < ");
    assert!(
        doc.contains(&line),
        "docs/architecture.md must show the module order as the line\n{line}"
    );
}

/// Longest function allowed without a stated reason [lines, from `fn` to its closing brace].
const MAX_FN_LINES: usize = 120;

/// No function in `src/` is longer than [`MAX_FN_LINES`] unless its doc comment says why, in
/// a line starting `/// Kept whole:` (a hot loop that must stay one pass, say).
#[test]
fn long_functions_say_why() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    files.sort();
    let mut long = Vec::new();
    for f in files {
        let text = std::fs::read_to_string(&f).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        for (i, line) in lines.iter().enumerate() {
            let t = line.trim_start();
            let indent = &line[..line.len() - t.len()];
            let is_fn = [
                "fn ",
                "pub fn ",
                "pub(crate) fn ",
                "pub(super) fn ",
                "const fn ",
            ]
            .iter()
            .any(|p| t.starts_with(p));
            if !is_fn || t.ends_with(';') {
                continue;
            }
            let close = format!("{indent}}}");
            let Some(end) = (i..lines.len()).find(|&j| lines[j] == close) else {
                continue;
            };
            let n = end - i + 1;
            if n <= MAX_FN_LINES {
                continue;
            }
            let doc: Vec<&str> = lines[..i]
                .iter()
                .rev()
                .map(|l| l.trim_start())
                .take_while(|l| l.starts_with("///") || l.starts_with("#["))
                .collect();
            if !doc.iter().any(|l| l.starts_with("/// Kept whole:")) {
                long.push(format!("{}:{}: {n} lines: {}", f.display(), i + 1, t));
            }
        }
    }
    assert!(
        long.is_empty(),
        "functions over {MAX_FN_LINES} lines without a `/// Kept whole:` reason:\n{}",
        long.join("\n")
    );
}
