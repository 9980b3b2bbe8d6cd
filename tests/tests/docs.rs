//! README.md and docs/*.md say only what exists: every command names a real package, binary,
//! example, bench, test or script, every flag it passes is one that binary's `--help` lists,
//! every `data/` path in it exists, and every relative link (with its `#anchor`) points at a
//! file (and heading) that exists — in ARCHITECTURE.md and docs/research/*.md too. And
//! docs/scene-file.md documents exactly the keys the scene parser accepts, and its example
//! loads.
//!
//! The binaries' help comes from the built executables next to this test's (`target/debug/`):
//! `cargo test --workspace` builds them first (cdrf-fit and cdrf-viewer have integration
//! tests). Run alone, build them first: `cargo build -p cdrf-fit -p cdrf-viewer --bins`. A missing
//! or out-of-date binary fails the test rather than passing it.
//!
//! What a command is: a line of a ```sh block, a line of a ```text block or an inline `code`
//! span that starts with `cargo `, `scripts/`, `./target/` or the name of one of the workspace's
//! binaries. In ```sh blocks the whole command line must also parse: the test runs
//! `BINARY ARGS… --help` and expects success (clap rejects an unknown flag or subcommand before
//! it reaches `--help`). Synopses (```text lines and inline spans such as `cdrf-fit DIR --out
//! OUTDIR [--quiet]`) only have their flags and lower-case `a|b` values looked up in the help.
//! Commands of other programs (`apt-get`, `xvfb-run`) are not checked.

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::SystemTime;

fn root() -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    root.canonicalize().unwrap_or(root)
}

/// The Markdown files in `dir`, sorted.
fn markdown_in(dir: &Path) -> Vec<PathBuf> {
    let mut found: Vec<PathBuf> = fs::read_dir(dir)
        .unwrap_or_else(|error| panic!("{}: {error}", dir.display()))
        .map(|entry| entry.unwrap().path())
        .filter(|path| path.extension().is_some_and(|ext| ext == "md"))
        .collect();
    found.sort();
    found
}

/// README.md and every Markdown file in docs/: the user's documents, whose commands are checked.
fn documents() -> Vec<PathBuf> {
    let mut docs = vec![root().join("README.md")];
    docs.extend(markdown_in(&root().join("docs")));
    docs
}

/// The user's documents, ARCHITECTURE.md and the research notes: whose links are checked.
fn linked_documents() -> Vec<PathBuf> {
    let mut docs = documents();
    docs.push(root().join("ARCHITECTURE.md"));
    docs.extend(markdown_in(&root().join("docs/research")));
    docs
}

/// A workspace package: its folder and the binaries it declares.
struct Package {
    dir: PathBuf,
    binaries: Vec<String>,
}

/// The packages by name, read from `crates/*/Cargo.toml`, `tests/Cargo.toml` and the Bevy
/// plugin's own workspace (`integrations/cdrf-bevy`).
fn packages() -> BTreeMap<String, Package> {
    let mut dirs: Vec<PathBuf> = fs::read_dir(root().join("crates"))
        .unwrap()
        .map(|entry| entry.unwrap().path())
        .collect();
    dirs.push(root().join("tests"));
    dirs.push(root().join("integrations/cdrf-bevy"));
    let mut packages = BTreeMap::new();
    for dir in dirs {
        let Ok(manifest) = fs::read_to_string(dir.join("Cargo.toml")) else {
            continue;
        };
        let (mut section, mut name, mut binaries) = (String::new(), None, Vec::new());
        for line in manifest.lines().map(str::trim) {
            if line.starts_with('[') {
                section = line.to_string();
            } else if let Some(value) = line.strip_prefix("name = ") {
                let value = value.trim_matches('"').to_string();
                match section.as_str() {
                    "[package]" => name = Some(value),
                    "[[bin]]" => binaries.push(value),
                    _ => {}
                }
            }
        }
        let name = name.expect("a [package] name");
        if dir.join("src/main.rs").exists() && !binaries.contains(&name) {
            binaries.push(name.clone());
        }
        packages.insert(name, Package { dir, binaries });
    }
    packages
}

/// One command found in a document, with where it was found.
struct Found {
    place: String,
    words: Vec<String>,
    /// From a ```sh block: meant to be run as written.
    runnable: bool,
}

/// Splits a command line into words, honouring "double" and 'single' quotes.
fn split_words(line: &str) -> Vec<String> {
    let (mut words, mut word, mut quote) = (Vec::new(), String::new(), None);
    for c in line.chars() {
        match (quote, c) {
            (None, '"' | '\'') => quote = Some(c),
            (Some(q), _) if c == q => quote = None,
            (None, c) if c.is_whitespace() => {
                if !word.is_empty() {
                    words.push(std::mem::take(&mut word));
                }
            }
            _ => word.push(c),
        }
    }
    if !word.is_empty() {
        words.push(word);
    }
    words
}

fn is_command(words: &[String], binaries: &[String]) -> bool {
    words.first().is_some_and(|first| {
        first == "cargo"
            || first.starts_with("scripts/")
            || first.starts_with("./scripts/")
            || first.starts_with("./target/")
            || binaries.contains(first)
    })
}

/// Every command of one Markdown document.
fn commands(path: &Path, binaries: &[String]) -> Vec<Found> {
    let text = fs::read_to_string(path).unwrap();
    let name = path
        .strip_prefix(root())
        .unwrap_or(path)
        .display()
        .to_string();
    let mut found = Vec::new();
    let mut fence: Option<String> = None;
    let mut pending = String::new();
    // Prose is read a paragraph at a time, so that an inline span may wrap across lines.
    let mut paragraph = String::new();
    let mut paragraph_start = 0;
    let inline = |paragraph: &mut String, start: usize, found: &mut Vec<Found>| {
        for (n, span) in paragraph.split('`').enumerate() {
            let words = split_words(span);
            if n % 2 == 1 && is_command(&words, binaries) {
                found.push(Found {
                    place: format!("{name}:{start}"),
                    words,
                    runnable: false,
                });
            }
        }
        paragraph.clear();
    };
    for (index, line) in text.lines().enumerate() {
        if let Some(info) = line.trim_start().strip_prefix("```") {
            inline(&mut paragraph, paragraph_start, &mut found);
            fence = match fence {
                Some(_) => None,
                None => Some(info.trim().to_string()),
            };
            continue;
        }
        match fence.as_deref() {
            Some(lang @ ("sh" | "text")) => {
                // Join continuation lines; drop comments.
                let line = line.split(" #").next().unwrap_or("");
                if let Some(head) = line.trim_end().strip_suffix('\\') {
                    pending.push_str(head);
                    pending.push(' ');
                    continue;
                }
                let whole = std::mem::take(&mut pending) + line;
                let words = split_words(&whole);
                if is_command(&words, binaries) {
                    found.push(Found {
                        place: format!("{name}:{}", index + 1),
                        words,
                        runnable: lang == "sh",
                    });
                }
            }
            Some(_) => {}
            None if line.trim().is_empty() => inline(&mut paragraph, paragraph_start, &mut found),
            None => {
                if paragraph.is_empty() {
                    paragraph_start = index + 1;
                }
                paragraph.push_str(line);
                paragraph.push('\n');
            }
        }
    }
    inline(&mut paragraph, paragraph_start, &mut found);
    found
}

/// The built binary `name` next to this test's executable, checked to be newer than its
/// package's sources.
fn binary(name: &str, package: &Package) -> Result<PathBuf, String> {
    let exe = std::env::current_exe().unwrap();
    let profile_dir = exe.parent().and_then(Path::parent).unwrap();
    let path = profile_dir.join(format!("{name}{}", std::env::consts::EXE_SUFFIX));
    let built = fs::metadata(&path)
        .and_then(|m| m.modified())
        .map_err(|_| {
            format!(
                "{} is not built: run `cargo build --bins` (or the whole `cargo test --workspace`) first",
                path.display()
            )
        })?;
    let newest = newest_source(&package.dir.join("src"));
    if newest > built {
        return Err(format!(
            "{} is older than the sources of {}: run `cargo build --bins` first",
            path.display(),
            package.dir.display()
        ));
    }
    Ok(path)
}

fn newest_source(dir: &Path) -> SystemTime {
    let mut newest = SystemTime::UNIX_EPOCH;
    for entry in fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        let time = if path.is_dir() {
            newest_source(&path)
        } else {
            fs::metadata(&path).and_then(|m| m.modified()).unwrap()
        };
        newest = newest.max(time);
    }
    newest
}

/// `binary ARGS… --help`: its output, or why it failed.
fn help(binary: &Path, args: &[String]) -> Result<String, String> {
    let output = Command::new(binary)
        .args(args)
        .arg("--help")
        .current_dir(root())
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&output.stdout).into_owned();
    if output.status.success() {
        Ok(text)
    } else {
        Err(String::from_utf8_lossy(&output.stderr).trim().to_string())
    }
}

/// The subcommands a clap help lists under "Commands:".
fn subcommands(help: &str) -> Vec<String> {
    help.lines()
        .skip_while(|line| !line.starts_with("Commands:"))
        .skip(1)
        .take_while(|line| !line.trim().is_empty())
        .filter_map(|line| line.split_whitespace().next().map(str::to_string))
        .collect()
}

/// Whether `help` lists the flag `flag` (`--name` or `-x`) as a whole word.
fn lists_flag(help: &str, flag: &str) -> bool {
    help.match_indices(flag).any(|(at, _)| {
        let before = help[..at].chars().next_back();
        let after = help[at + flag.len()..].chars().next();
        !before.is_some_and(|c| c.is_alphanumeric() || c == '-')
            && !after.is_some_and(|c| c.is_alphanumeric() || c == '-' || c == '_')
    })
}

/// Checks the arguments `args` of the binary `name` of `package`; the problems found.
fn check_arguments(name: &str, package: &Package, args: &[String], runnable: bool) -> Vec<String> {
    let path = match binary(name, package) {
        Ok(path) => path,
        Err(why) => return vec![why],
    };
    let top = match help(&path, &[]) {
        Ok(text) => text,
        Err(why) => return vec![format!("`{name} --help` failed: {why}")],
    };
    let mut problems = Vec::new();
    let words: Vec<String> = args
        .iter()
        .map(|w| w.trim_matches(['[', ']']).to_string())
        .collect();
    let (sub_help, rest) = match words.first() {
        Some(first) if subcommands(&top).contains(first) => match help(&path, &words[..1]) {
            Ok(text) => (text, &words[1..]),
            Err(why) => return vec![format!("`{name} {first} --help` failed: {why}")],
        },
        _ => (top, &words[..]),
    };
    for (i, word) in rest.iter().enumerate() {
        if word.starts_with('-') && word.len() > 1 {
            let flag = word.split('=').next().unwrap();
            if !lists_flag(&sub_help, flag) {
                problems.push(format!("`{name}` has no flag {flag} (not in its --help)"));
            }
            // Lower-case alternatives `a|b|c` after a flag are its possible values.
            if let Some(value) = rest.get(i + 1)
                && value.contains('|')
                && value
                    .chars()
                    .all(|c| c.is_ascii_lowercase() || "-|".contains(c))
            {
                for choice in value.split('|') {
                    if !lists_flag(&sub_help, choice) {
                        problems.push(format!(
                            "`{name} {flag}` has no value {choice} (not in its --help)"
                        ));
                    }
                }
            }
        } else if word.starts_with("data/") && !root().join(word).exists() {
            problems.push(format!("{word} does not exist"));
        }
    }
    if runnable && let Err(why) = help(&path, args) {
        problems.push(format!(
            "`{name} {} --help` does not parse: {why}",
            args.join(" ")
        ));
    }
    problems
}

#[cfg(unix)]
fn is_executable(meta: &fs::Metadata) -> bool {
    use std::os::unix::fs::PermissionsExt;
    meta.permissions().mode() & 0o111 != 0
}

#[cfg(not(unix))]
fn is_executable(meta: &fs::Metadata) -> bool {
    meta.is_file()
}

/// Cargo's own flags the documents may use.
const CARGO_FLAGS: &[&str] = &[
    "--release",
    // The Bevy plugin's workspace: Bevy declares a newer rustc than the nightly has.
    "--ignore-rust-version",
    "-p",
    "--package",
    "--bin",
    "--bins",
    "--example",
    "--bench",
    "--test",
    "--workspace",
    "--no-deps",
    "--open",
    "--locked",
];

/// Checks one command; the problems found.
fn check(found: &Found, packages: &BTreeMap<String, Package>) -> Vec<String> {
    let words = &found.words;
    let first = words[0].as_str();
    if first.starts_with("scripts/") || first.starts_with("./scripts/") {
        let path = root().join(first.trim_start_matches("./"));
        return match fs::metadata(&path) {
            Ok(meta) if is_executable(&meta) => Vec::new(),
            Ok(_) => vec![format!("{first} is not executable")],
            Err(_) => vec![format!("{first} does not exist")],
        };
    }
    if let Some(rest) = first.strip_prefix("./target/") {
        let name = rest.rsplit('/').next().unwrap();
        return match packages
            .values()
            .find(|p| p.binaries.iter().any(|b| b == name))
        {
            Some(package) => check_arguments(name, package, &words[1..], found.runnable),
            None => vec![format!("no workspace package builds a binary {name}")],
        };
    }
    if first != "cargo" {
        let package = packages
            .values()
            .find(|p| p.binaries.iter().any(|b| b == first))
            .unwrap();
        return check_arguments(first, package, &words[1..], false);
    }

    // cargo SUBCOMMAND [cargo flags] [-- ARGS]
    let split = words.iter().position(|w| w == "--").unwrap_or(words.len());
    let (cargo, args) = (&words[..split], words.get(split + 1..).unwrap_or(&[]));
    let value_of = |flag: &str| {
        cargo
            .iter()
            .position(|w| w == flag)
            .and_then(|i| cargo.get(i + 1))
            .map(String::as_str)
    };
    let mut problems = Vec::new();
    for word in cargo.iter().skip(2) {
        if word.starts_with('-') && !CARGO_FLAGS.contains(&word.as_str()) {
            problems.push(format!("cargo flag {word} is not one this test knows"));
        }
    }
    let package_name = value_of("-p").or(value_of("--package"));
    let package = match package_name {
        Some(name) => match packages.get(name) {
            Some(package) => Some(package),
            None => return vec![format!("no workspace package {name}")],
        },
        None => None,
    };
    let in_dir =
        |sub: &str, name: &str| package.map(|p| p.dir.join(sub).join(format!("{name}.rs")));
    let target_file = |sub: &str, name: &str, problems: &mut Vec<String>| match in_dir(sub, name) {
        Some(path) if path.exists() => {}
        Some(path) => problems.push(format!("{} does not exist", path.display())),
        None => problems.push(format!("`{}` needs -p PACKAGE", words.join(" "))),
    };
    match words.get(1).map(String::as_str) {
        Some("run") => {
            if let Some(example) = value_of("--example") {
                target_file("examples", example, &mut problems);
            } else {
                let (Some(package), Some(package_name)) = (package, package_name) else {
                    return vec![format!("`{}` needs -p PACKAGE", words.join(" "))];
                };
                let name = value_of("--bin").unwrap_or(package_name);
                if !package.binaries.iter().any(|b| b == name) {
                    problems.push(format!(
                        "{} declares no binary {name}",
                        package.dir.display()
                    ));
                } else {
                    problems.extend(check_arguments(name, package, args, found.runnable));
                }
            }
        }
        Some("bench") => match value_of("--bench") {
            Some(bench) => {
                target_file("benches", bench, &mut problems);
                // The benches parse their own arguments: each flag must appear in the source.
                if let Some(source) =
                    in_dir("benches", bench).and_then(|p| fs::read_to_string(p).ok())
                {
                    for flag in args.iter().filter(|w| w.starts_with("--")) {
                        if !source.contains(&format!("\"{flag}\"")) {
                            problems.push(format!("bench {bench} does not parse {flag}"));
                        }
                    }
                }
            }
            None => problems.push(format!("`{}` names no --bench", words.join(" "))),
        },
        Some("test") => {
            if let Some(test) = value_of("--test") {
                target_file("tests", test, &mut problems);
            }
        }
        Some("doc" | "build") => {}
        other => problems.push(format!(
            "cargo subcommand {other:?} is not one this test knows"
        )),
    }
    problems
}

#[test]
fn every_documented_command_exists_and_parses() {
    let packages = packages();
    let binaries: Vec<String> = packages.values().flat_map(|p| p.binaries.clone()).collect();
    let mut problems = Vec::new();
    let mut checked = 0;
    for doc in documents() {
        for found in commands(&doc, &binaries) {
            checked += 1;
            for problem in check(&found, &packages) {
                problems.push(format!(
                    "{}: `{}`: {problem}",
                    found.place,
                    found.words.join(" ")
                ));
            }
        }
    }
    println!("checked {checked} commands in README.md and docs/*.md");
    assert!(
        checked >= 10,
        "found only {checked} commands: is the extraction broken?"
    );
    assert!(
        problems.is_empty(),
        "{} problems:\n{}",
        problems.len(),
        problems.join("\n")
    );
}

/// GitHub's anchor of a heading: lower case, punctuation dropped, spaces → hyphens.
fn anchor(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

fn anchors(markdown: &str) -> Vec<String> {
    let mut in_fence = false;
    markdown
        .lines()
        .filter(|line| {
            if line.trim_start().starts_with("```") {
                in_fence = !in_fence;
            }
            !in_fence && line.starts_with('#')
        })
        .map(|line| anchor(line.trim_start_matches('#')))
        .collect()
}

#[test]
fn every_relative_link_points_at_an_existing_file_and_heading() {
    let mut problems = Vec::new();
    let mut checked = 0;
    for doc in linked_documents() {
        let text = fs::read_to_string(&doc).unwrap();
        let name = doc.strip_prefix(root()).unwrap().display().to_string();
        for (at, _) in text.match_indices("](") {
            let target = text[at + 2..].split(')').next().unwrap();
            let target = target.split_whitespace().next().unwrap_or("");
            if target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            checked += 1;
            let (file, fragment) = target.split_once('#').unwrap_or((target, ""));
            let path = if file.is_empty() {
                doc.clone()
            } else {
                doc.parent().unwrap().join(file)
            };
            if !path.exists() {
                problems.push(format!(
                    "{name}: link {target}: {} does not exist",
                    path.display()
                ));
            } else if !fragment.is_empty() {
                let markdown = fs::read_to_string(&path).unwrap_or_default();
                if !anchors(&markdown).iter().any(|a| a == fragment) {
                    problems.push(format!(
                        "{name}: link {target}: no heading #{fragment} in {file}"
                    ));
                }
            }
        }
    }
    println!("checked {checked} relative links in README.md, ARCHITECTURE.md and docs/");
    assert!(
        checked >= 10,
        "found only {checked} links: is the extraction broken?"
    );
    assert!(
        problems.is_empty(),
        "{} broken links:\n{}",
        problems.len(),
        problems.join("\n")
    );
}

/// The keys docs/scene-file.md documents, as `[table] key`: the first cell's `code` spans of
/// each table row, under a heading that names the table (`` ## `[mesh]` ``).
fn documented_scene_keys(markdown: &str) -> Vec<String> {
    let mut table = None;
    let mut keys = Vec::new();
    let mut in_fence = false;
    for line in markdown.lines() {
        if line.trim_start().starts_with("```") {
            in_fence = !in_fence;
        }
        if in_fence {
            continue;
        }
        if let Some(heading) = line.strip_prefix("## ") {
            table = heading
                .trim()
                .strip_prefix('`')
                .and_then(|h| h.strip_suffix('`'))
                .filter(|h| h.starts_with('['))
                .map(str::to_owned);
        } else if let (Some(table), Some(row)) = (&table, line.strip_prefix('|')) {
            let first = row.split('|').next().unwrap_or("");
            for (n, span) in first.split('`').enumerate() {
                if n % 2 == 1 {
                    keys.push(format!("{table} {span}"));
                }
            }
        }
    }
    keys
}

#[test]
fn scene_file_doc_lists_every_key_the_parser_accepts() {
    let path = root().join("docs/scene-file.md");
    let text = fs::read_to_string(&path).unwrap();
    let mut documented = documented_scene_keys(&text);
    documented.sort();
    documented.dedup();
    let accepted: Vec<String> = cdrf_core::scene::KEYS
        .iter()
        .map(|k| k.to_string())
        .collect();
    let missing: Vec<&String> = accepted
        .iter()
        .filter(|k| !documented.contains(k))
        .collect();
    let unknown: Vec<&String> = documented
        .iter()
        .filter(|k| !accepted.contains(k))
        .collect();
    println!("docs/scene-file.md documents {} keys", documented.len());
    assert!(
        missing.is_empty() && unknown.is_empty(),
        "docs/scene-file.md: keys the parser accepts but the document lacks: {missing:?}; \
         keys it documents that the parser does not accept: {unknown:?}"
    );
}

#[test]
fn scene_file_doc_example_loads() {
    let path = root().join("docs/scene-file.md");
    let text = fs::read_to_string(&path).unwrap();
    let example = text
        .split("```toml\n")
        .nth(1)
        .and_then(|rest| rest.split("```").next())
        .expect("docs/scene-file.md has a ```toml example");
    // As if saved in data/scenes/, as the document says.
    let scenes = root().join("data/scenes");
    let scene = cdrf_core::Scene::from_toml_str(example, &scenes, &path)
        .unwrap_or_else(|error| panic!("the example does not parse: {error}"));
    scene
        .load_assets()
        .unwrap_or_else(|error| panic!("the example's files do not load: {error}"));
    assert!(scene.non_local.subsurface && scene.specular.is_some());
    assert!(scene.environment.is_some());
}
