//! Replays every input that ever crashed a parser (`fuzz/regressions/TARGET/*`): each must make
//! its target return (`Ok` or `Err`), not panic, abort, run out of a 4 GB address space, touch
//! more than 512 MB, or run past 60 s. Each runs in a child process (`cdrf-fuzz replay`), so an
//! abort fails this test instead of killing it.
//!
//! Inputs listed in `fuzz/regressions/KNOWN_FAILING.txt` (fix pending) are skipped, and the test
//! prints each one it skipped; `CDRF_FUZZ_RUN_KNOWN_FAILING=1` runs them too.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use cdrf_fuzz::Target;

const ADDRESS_SPACE_KB: u64 = 4 * 1024 * 1024;
const TIME_LIMIT: Duration = Duration::from_secs(60);

fn regressions_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("regressions")
}

/// `TARGET/FILE` → the reason, from KNOWN_FAILING.txt.
fn known_failing() -> Vec<(String, String)> {
    let path = regressions_dir().join("KNOWN_FAILING.txt");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(|l| {
            let (name, why) = l.split_once(char::is_whitespace).unwrap_or((l, ""));
            (name.to_owned(), why.trim().to_owned())
        })
        .collect()
}

/// Runs one input; `Err` says how it failed.
fn replay(target: Target, file: &Path) -> Result<(), String> {
    let mut child = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "ulimit -v {ADDRESS_SPACE_KB} && exec \"$0\" \"$@\""
        ))
        .arg(env!("CARGO_BIN_EXE_cdrf-fuzz"))
        .args(["replay", target.name()])
        .arg(file)
        .env("RUST_BACKTRACE", "0")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot start cdrf-fuzz: {e}"))?;
    let started = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().map_err(|e| e.to_string())? {
            break status;
        }
        if started.elapsed() > TIME_LIMIT {
            let _ = child.kill();
            let _ = child.wait();
            return Err(format!(
                "still running after {} s (killed)",
                TIME_LIMIT.as_secs()
            ));
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    if status.success() {
        return Ok(());
    }
    let mut stderr = String::new();
    if let Some(mut pipe) = child.stderr.take() {
        use std::io::Read;
        let _ = pipe.read_to_string(&mut stderr);
    }
    let last_lines: Vec<&str> = stderr.lines().rev().take(3).collect();
    Err(format!(
        "{status} ({})",
        last_lines.into_iter().rev().collect::<Vec<_>>().join(" | ")
    ))
}

#[test]
fn every_saved_crasher_now_returns() {
    let root = regressions_dir();
    let known = known_failing();
    let run_known = std::env::var_os("CDRF_FUZZ_RUN_KNOWN_FAILING").is_some_and(|v| v == "1");
    for (name, _) in &known {
        assert!(
            root.join(name).is_file(),
            "KNOWN_FAILING.txt names {name}, which is not a file under {}",
            root.display()
        );
    }
    let (mut passed, mut skipped, mut failures) = (0, Vec::new(), Vec::new());
    for target in Target::ALL {
        let dir = root.join(target.name());
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        let mut files: Vec<PathBuf> = entries
            .map(|e| e.expect("a directory entry").path())
            .collect();
        files.sort();
        for file in files {
            let file_name = file
                .file_name()
                .expect("a file name")
                .to_string_lossy()
                .into_owned();
            if file_name.starts_with('.') || !file.is_file() {
                continue;
            }
            let name = format!("{}/{file_name}", target.name());
            if let Some((_, why)) = known.iter().find(|(k, _)| *k == name)
                && !run_known
            {
                skipped.push(format!("{name} ({why})"));
                continue;
            }
            match replay(target, &file) {
                Ok(()) => passed += 1,
                Err(how) => failures.push(format!("{name}: {how}")),
            }
        }
    }
    println!("fuzz regressions: {passed} replayed cleanly");
    if !skipped.is_empty() {
        println!(
            "fuzz regressions: SKIPPED {} known-failing inputs (fix pending; not passing):",
            skipped.len()
        );
        for s in &skipped {
            println!("  skipped {s}");
        }
    }
    assert!(
        failures.is_empty(),
        "{} saved crasher(s) still crash:\n  {}",
        failures.len(),
        failures.join("\n  ")
    );
}
