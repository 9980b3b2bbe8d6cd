//! The crate's modules form a layered graph: no module reaches back, through `crate::`,
//! `super::` or `self::` paths, to a module that reaches it. A cycle fails with the modules
//! that form it. Test code (`#[cfg(test)]` modules) may look anywhere and is not counted;
//! comments and strings are not code.
//!
//! `cargo test -p cdrf-render --test module_graph -- --nocapture` prints the layers, lowest
//! first.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// `src/**/*.rs`, sorted.
fn source_files(dir: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("reading {}: {e}", dir.display()))
        .map(|entry| entry.expect("a directory entry").path())
        .collect();
    entries.sort();
    for path in entries {
        if path.is_dir() {
            files.extend(source_files(&path));
        } else if path.extension().is_some_and(|e| e == "rs") {
            files.push(path);
        }
    }
    files
}

/// The module a file holds: `crate` for `lib.rs`, `a::b` for `a/b.rs` (and `a/b/mod.rs`).
fn module_of(src: &Path, file: &Path) -> String {
    let relative = file.strip_prefix(src).expect("a file under src");
    let mut parts: Vec<String> = relative
        .with_extension("")
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if parts.last().is_some_and(|p| p == "mod") {
        parts.pop();
    }
    if parts == ["lib"] {
        return "crate".into();
    }
    parts.join("::")
}

/// The code of a Rust file without comments, string and character literals (each replaced by
/// a space; lifetimes stay).
fn strip(source: &str) -> String {
    let chars: Vec<char> = source.chars().collect();
    let mut out = String::with_capacity(source.len());
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        let next = chars.get(i + 1).copied();
        if c == '/' && next == Some('/') {
            while i < chars.len() && chars[i] != '\n' {
                i += 1;
            }
        } else if c == '/' && next == Some('*') {
            let mut depth = 0;
            while i < chars.len() {
                if chars[i] == '/' && chars.get(i + 1) == Some(&'*') {
                    depth += 1;
                    i += 2;
                } else if chars[i] == '*' && chars.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    i += 1;
                }
            }
            out.push(' ');
        } else if c == 'r'
            && matches!(next, Some('"' | '#'))
            && !chars
                .get(i.wrapping_sub(1))
                .is_some_and(|p| p.is_alphanumeric() || *p == '_')
        {
            // A raw string: r"…", r#"…"#, …
            let mut j = i + 1;
            let mut hashes = 0;
            while chars.get(j) == Some(&'#') {
                hashes += 1;
                j += 1;
            }
            if chars.get(j) != Some(&'"') {
                out.push(c);
                i += 1;
                continue;
            }
            j += 1;
            loop {
                if j >= chars.len() {
                    break;
                }
                if chars[j] == '"' && (0..hashes).all(|k| chars.get(j + 1 + k) == Some(&'#')) {
                    j += 1 + hashes;
                    break;
                }
                j += 1;
            }
            i = j;
            out.push(' ');
        } else if c == '"' {
            i += 1;
            while i < chars.len() && chars[i] != '"' {
                if chars[i] == '\\' {
                    i += 1;
                }
                i += 1;
            }
            i += 1;
            out.push(' ');
        } else if c == '\'' {
            // A character literal ('x', '\n', '\u{..}'), or a lifetime ('a).
            let end = if next == Some('\\') {
                (i + 2..chars.len()).find(|&j| chars[j] == '\'')
            } else if chars.get(i + 2) == Some(&'\'') {
                Some(i + 2)
            } else {
                None
            };
            match end {
                Some(end) => {
                    i = end + 1;
                    out.push(' ');
                }
                None => {
                    out.push(c);
                    i += 1;
                }
            }
        } else {
            out.push(c);
            i += 1;
        }
    }
    out
}

/// `code` without the items under `#[cfg(test)]` (a `mod … { … }` block or one item).
fn without_test_code(code: &str) -> String {
    let mut out = String::new();
    let mut rest = code;
    while let Some(at) = rest.find("#[cfg(test)]") {
        out.push_str(&rest[..at]);
        let after = &rest[at..];
        // The item ends at its block's closing brace, or at a `;` before any brace.
        let open = after.find('{');
        let semicolon = after.find(';');
        let end = match (open, semicolon) {
            (Some(open), Some(semicolon)) if semicolon < open => semicolon + 1,
            (Some(open), _) => {
                let mut depth = 0;
                let mut end = after.len();
                for (k, ch) in after[open..].char_indices() {
                    match ch {
                        '{' => depth += 1,
                        '}' => {
                            depth -= 1;
                            if depth == 0 {
                                end = open + k + 1;
                                break;
                            }
                        }
                        _ => {}
                    }
                }
                end
            }
            (None, Some(semicolon)) => semicolon + 1,
            (None, None) => after.len(),
        };
        rest = &after[end..];
    }
    out.push_str(rest);
    out
}

/// Splits a use tree or path after `crate::` (etc.) into whole paths: `a::{b::C, d}` gives
/// `a::b::C` and `a::d`. `text` starts right after the `::`.
fn expand_paths(text: &str) -> Vec<Vec<String>> {
    fn parse(chars: &[char], i: &mut usize) -> Vec<Vec<String>> {
        let skip_space = |i: &mut usize| {
            while *i < chars.len() && chars[*i].is_whitespace() {
                *i += 1;
            }
        };
        let mut prefix = Vec::new();
        loop {
            skip_space(i);
            if chars.get(*i) == Some(&'{') {
                *i += 1;
                let mut paths = Vec::new();
                loop {
                    skip_space(i);
                    match chars.get(*i) {
                        Some('}') => {
                            *i += 1;
                            break;
                        }
                        Some(',') => *i += 1,
                        None => break,
                        _ => {
                            for tail in parse(chars, i) {
                                let mut path = prefix.clone();
                                path.extend(tail);
                                paths.push(path);
                            }
                        }
                    }
                }
                return paths;
            }
            let start = *i;
            while *i < chars.len() && (chars[*i].is_alphanumeric() || chars[*i] == '_') {
                *i += 1;
            }
            if *i == start {
                return vec![prefix];
            }
            prefix.push(chars[start..*i].iter().collect());
            skip_space(i);
            if chars.get(*i) == Some(&':') && chars.get(*i + 1) == Some(&':') {
                *i += 2;
            } else {
                // `as name`, `,`, `}` or the end of the path.
                return vec![prefix];
            }
        }
    }
    let chars: Vec<char> = text.chars().collect();
    parse(&chars, &mut 0)
}

/// The modules `code` (of module `module`) refers to through `crate::`, `super::` and
/// `self::` paths, and through `use child::…` of its own child modules.
fn references(
    module: &str,
    code: &str,
    modules: &BTreeSet<String>,
) -> BTreeMap<String, BTreeSet<String>> {
    let segments: Vec<&str> = if module == "crate" {
        Vec::new()
    } else {
        module.split("::").collect()
    };
    let mut found: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let mut resolve = |base: Vec<String>, path: Vec<String>, written: String| {
        let mut full = base;
        full.extend(path);
        // The longest prefix that names a module.
        let target = (0..=full.len())
            .rev()
            .map(|n| {
                if n == 0 {
                    "crate".to_string()
                } else {
                    full[..n].join("::")
                }
            })
            .find(|candidate| modules.contains(candidate))
            .expect("the crate root is a module");
        if target != module {
            found.entry(target).or_default().insert(written);
        }
    };
    let bytes = code.as_bytes();
    for keyword in ["crate::", "super::", "self::"] {
        let mut start = 0;
        while let Some(at) = code[start..].find(keyword) {
            let at = start + at;
            start = at + keyword.len();
            if at > 0 && (bytes[at - 1].is_ascii_alphanumeric() || bytes[at - 1] == b'_') {
                continue;
            }
            let base: Vec<String> = match keyword {
                "crate::" => Vec::new(),
                "super::" => segments[..segments.len().saturating_sub(1)]
                    .iter()
                    .map(|s| s.to_string())
                    .collect(),
                _ => segments.iter().map(|s| s.to_string()).collect(),
            };
            for path in expand_paths(&code[start..]) {
                let written = format!("{keyword}{}", path.join("::"));
                resolve(base.clone(), path, written);
            }
        }
    }
    // `use child::…` (a path relative to this module, as lib.rs re-exports).
    for statement in code.split(';') {
        let statement = statement.trim_start();
        let Some(tree) = statement
            .strip_prefix("pub use ")
            .or_else(|| statement.strip_prefix("pub(crate) use "))
            .or_else(|| statement.strip_prefix("use "))
        else {
            continue;
        };
        for path in expand_paths(tree) {
            let Some(first) = path.first() else { continue };
            let mut child: Vec<String> = segments.iter().map(|s| s.to_string()).collect();
            child.push(first.clone());
            if modules.contains(&child.join("::")) {
                let written = path.join("::");
                resolve(
                    segments.iter().map(|s| s.to_string()).collect(),
                    path,
                    written,
                );
            }
        }
    }
    found
}

/// Every module's references, by module.
fn module_graph() -> BTreeMap<String, BTreeMap<String, BTreeSet<String>>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let files = source_files(&src);
    assert!(
        files.len() > 10,
        "expected the crate's sources in {}",
        src.display()
    );
    let modules: BTreeSet<String> = files.iter().map(|f| module_of(&src, f)).collect();
    files
        .iter()
        .map(|file| {
            let module = module_of(&src, file);
            let source = std::fs::read_to_string(file)
                .unwrap_or_else(|e| panic!("reading {}: {e}", file.display()));
            let code = without_test_code(&strip(&source));
            let refs = references(&module, &code, &modules);
            (module, refs)
        })
        .collect()
}

/// A cycle through `start` in `graph`, if any (depth first).
fn cycle_through(start: &str, graph: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn search(
        at: &str,
        start: &str,
        graph: &BTreeMap<String, BTreeSet<String>>,
        path: &mut Vec<String>,
        seen: &mut BTreeSet<String>,
    ) -> bool {
        for next in graph.get(at).into_iter().flatten() {
            if next == start {
                return true;
            }
            if seen.insert(next.clone()) {
                path.push(next.clone());
                if search(next, start, graph, path, seen) {
                    return true;
                }
                path.pop();
            }
        }
        false
    }
    let mut path = vec![start.to_string()];
    search(start, start, graph, &mut path, &mut BTreeSet::new()).then_some(path)
}

#[test]
fn the_modules_form_no_cycle() {
    let graph = module_graph();
    let edges: BTreeMap<String, BTreeSet<String>> = graph
        .iter()
        .map(|(module, refs)| (module.clone(), refs.keys().cloned().collect()))
        .collect();
    let mut cycles = Vec::new();
    let mut reported = BTreeSet::new();
    for module in edges.keys() {
        if reported.contains(module) {
            continue;
        }
        if let Some(cycle) = cycle_through(module, &edges) {
            let steps: Vec<String> = cycle
                .iter()
                .zip(cycle.iter().cycle().skip(1))
                .map(|(from, to)| {
                    let via: Vec<&String> = graph[from][to].iter().collect();
                    format!("{from} → {to} (via {via:?})")
                })
                .collect();
            cycles.push(steps.join("\n    "));
            reported.extend(cycle);
        }
    }
    assert!(
        cycles.is_empty(),
        "import cycles among cdrf-render's modules:\n    {}",
        cycles.join("\n\n    ")
    );

    // The layers: each module one above the highest it refers to.
    let mut layer: BTreeMap<&str, usize> = BTreeMap::new();
    while layer.len() < edges.len() {
        for (module, targets) in &edges {
            if layer.contains_key(module.as_str()) {
                continue;
            }
            if targets.iter().all(|t| layer.contains_key(t.as_str())) {
                let level = targets.iter().map(|t| layer[t.as_str()] + 1).max();
                layer.insert(module, level.unwrap_or(0));
            }
        }
    }
    let mut by_layer: BTreeMap<usize, Vec<&str>> = BTreeMap::new();
    for (module, level) in layer {
        by_layer.entry(level).or_default().push(module);
    }
    for (level, modules) in by_layer {
        println!("layer {level}: {}", modules.join(", "));
    }
}

/// One module style: `foo.rs` beside `foo/`, never `foo/mod.rs`.
#[test]
fn no_module_is_a_mod_rs() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mod_files: Vec<PathBuf> = source_files(&src)
        .into_iter()
        .filter(|f| f.file_name().is_some_and(|n| n == "mod.rs"))
        .collect();
    assert!(
        mod_files.is_empty(),
        "use foo.rs beside foo/, not foo/mod.rs: {mod_files:?}"
    );
}

/// The checker itself: paths in use trees, comments, strings and test code.
#[test]
fn the_checker_reads_use_trees_and_ignores_comments_strings_and_tests() {
    let modules: BTreeSet<String> = ["crate", "a", "b", "b::c", "d"]
        .into_iter()
        .map(String::from)
        .collect();
    let code = without_test_code(&strip(
        r#"
        //! See crate::d for more.
        use crate::{a::X, b::{c::Y, Z}};
        /* crate::d */ let s = "crate::d"; let c = '"'; fn f<'a>(x: &'a str) {}
        let q = super::d::W;
        #[cfg(test)]
        mod tests { use crate::d::V; }
        "#,
    ));
    let refs = references("b::c", &code, &modules);
    let targets: Vec<&String> = refs.keys().collect();
    // `super` of b::c is b; `super::d` is not a module of b, so b.
    assert_eq!(targets, ["a", "b"], "{refs:?}");
}
