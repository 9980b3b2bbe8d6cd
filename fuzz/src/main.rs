//! `cdrf-fuzz`: the fuzz loop and the replay of one saved input (see the library docs).
//!
//! ```text
//! cdrf-fuzz fuzz TARGET --seconds S --seed N --work DIR --regressions DIR [--max-len BYTES]
//!                       [--input-timeout SECONDS]
//! cdrf-fuzz replay TARGET FILE
//! cdrf-fuzz targets
//! ```
//! `fuzz` mutates the target's seeds for S seconds, runs each input under `catch_unwind` and
//! saves every input that panicked as `REGRESSIONS/TARGET/panic-HASH.EXT`. An input that runs
//! past `--input-timeout` makes it exit with code 3; an abort or the memory limit kills it. In
//! both cases the input is still in `WORK/` for `scripts/fuzz.sh` to keep. `WORK/iterations`
//! holds the count so far. `replay` exits 0 when the parser returned, 101 when it panicked,
//! 4 when the input made it use more than 512 MB resident.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use cdrf_fuzz::{Mutator, Target, content_hash, run, seeds};

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.first().map(String::as_str) {
        Some("fuzz") => fuzz(&args[1..]),
        Some("replay") => replay(&args[1..]),
        Some("targets") => {
            for target in Target::ALL {
                println!("{target}");
            }
            Ok(ExitCode::SUCCESS)
        }
        _ => Err("usage: cdrf-fuzz fuzz|replay|targets ... (see the crate docs)".to_owned()),
    };
    result.unwrap_or_else(|message| {
        eprintln!("error: {message}");
        ExitCode::from(2)
    })
}

fn target_arg(name: Option<&String>) -> Result<Target, String> {
    let name = name.ok_or("missing TARGET")?;
    Target::from_name(name).ok_or_else(|| {
        let names: Vec<_> = Target::ALL.iter().map(|t| t.name()).collect();
        format!("unknown target {name:?}: one of {}", names.join(", "))
    })
}

fn replay(args: &[String]) -> Result<ExitCode, String> {
    let target = target_arg(args.first())?;
    let file = args.get(1).ok_or("missing FILE")?;
    let input = std::fs::read(file).map_err(|e| format!("{file}: {e}"))?;
    let work = tempfile::tempdir().map_err(|e| e.to_string())?;
    // A panic propagates: the default hook prints it and the process exits 101.
    match run(target, &input, work.path()) {
        Ok(()) => println!("{file}: {target} returned Ok"),
        Err(message) => println!("{file}: {target} returned an error: {message}"),
    }
    // Memory the input made us touch: an error after reading 1 GB of /dev/zero is no pass.
    if let Some(peak_mb) = peak_resident_mb()
        && peak_mb > MAX_REPLAY_RESIDENT_MB
    {
        eprintln!(
            "{file}: {target} peaked at {peak_mb} MB resident (limit {MAX_REPLAY_RESIDENT_MB} MB)"
        );
        return Ok(ExitCode::from(4));
    }
    Ok(ExitCode::SUCCESS)
}

/// Peak resident memory a replayed input may cause; regression inputs are small files.
const MAX_REPLAY_RESIDENT_MB: u64 = 512;

/// This process's peak resident set (`VmHWM`), where `/proc` has it (Linux).
fn peak_resident_mb() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024)
}

struct FuzzArgs {
    target: Target,
    seconds: f64,
    seed: u64,
    work: PathBuf,
    regressions: PathBuf,
    max_len: usize,
    input_timeout: f64,
}

fn parse_fuzz_args(args: &[String]) -> Result<FuzzArgs, String> {
    let target = target_arg(args.first())?;
    let mut parsed = FuzzArgs {
        target,
        seconds: 10.0,
        seed: 1,
        work: PathBuf::from("target/fuzz-work").join(target.name()),
        regressions: PathBuf::from("fuzz/regressions"),
        max_len: 1 << 20,
        input_timeout: 10.0,
    };
    let mut rest = args[1..].iter();
    while let Some(flag) = rest.next() {
        let value = rest.next().ok_or_else(|| format!("{flag} needs a value"))?;
        let number = |v: &str| v.parse::<f64>().map_err(|e| format!("{flag} {v}: {e}"));
        match flag.as_str() {
            "--seconds" => parsed.seconds = number(value)?,
            "--seed" => parsed.seed = value.parse().map_err(|e| format!("--seed: {e}"))?,
            "--work" => parsed.work = PathBuf::from(value),
            "--regressions" => parsed.regressions = PathBuf::from(value),
            "--max-len" => parsed.max_len = value.parse().map_err(|e| format!("--max-len: {e}"))?,
            "--input-timeout" => parsed.input_timeout = number(value)?,
            _ => return Err(format!("unknown flag {flag}")),
        }
    }
    Ok(parsed)
}

fn fuzz(args: &[String]) -> Result<ExitCode, String> {
    let args = parse_fuzz_args(args)?;
    let target = args.target;
    std::fs::create_dir_all(&args.work).map_err(|e| format!("{}: {e}", args.work.display()))?;
    let saved_dir = args.regressions.join(target.name());
    let seed_inputs: Vec<Vec<u8>> = seeds(target).into_iter().map(|(_, bytes)| bytes).collect();
    let mut mutator = Mutator::new(target, args.seed, args.max_len);

    // Panics are expected here: record the message instead of printing every one.
    let last_panic = Arc::new(Mutex::new(String::new()));
    {
        let last_panic = Arc::clone(&last_panic);
        std::panic::set_hook(Box::new(move |info| {
            let location = info
                .location()
                .map(|l| format!("{}:{}", l.file(), l.line()))
                .unwrap_or_default();
            let payload = info
                .payload()
                .downcast_ref::<&str>()
                .map(|s| (*s).to_owned())
                .or_else(|| info.payload().downcast_ref::<String>().cloned())
                .unwrap_or_default();
            if let Ok(mut last) = last_panic.lock() {
                *last = format!("{location}: {payload}");
            }
        }));
    }

    // Watchdog: an input that runs too long ends the process (exit 3), its file left in WORK.
    let started = Instant::now();
    let input_started_ms = Arc::new(AtomicU64::new(0));
    {
        let input_started_ms = Arc::clone(&input_started_ms);
        let limit_ms = (args.input_timeout * 1000.0) as u64;
        let work = args.work.clone();
        std::thread::spawn(move || {
            loop {
                std::thread::sleep(Duration::from_millis(100));
                let now = started.elapsed().as_millis() as u64;
                let begun = input_started_ms.load(Ordering::Relaxed);
                if now.saturating_sub(begun) > limit_ms {
                    eprintln!(
                        "{target}: one input ran past {limit_ms} ms (kept in {})",
                        work.display()
                    );
                    std::process::exit(3);
                }
            }
        });
    }

    let deadline = Duration::from_secs_f64(args.seconds);
    let (mut iterations, mut errors, mut oks, mut panics) = (0_u64, 0_u64, 0_u64, 0_u64);
    let mut new_crashes = Vec::new();
    while started.elapsed() < deadline {
        let input = mutator.mutate(&seed_inputs);
        input_started_ms.store(started.elapsed().as_millis() as u64, Ordering::Relaxed);
        let outcome = std::panic::catch_unwind(|| run(target, &input, &args.work));
        iterations += 1;
        match outcome {
            Ok(Ok(())) => oks += 1,
            Ok(Err(_)) => errors += 1,
            Err(_) => {
                panics += 1;
                let message = last_panic.lock().map(|m| m.clone()).unwrap_or_default();
                if let Some(path) = save_crash(&saved_dir, &args.work, target, &input, &message)? {
                    new_crashes.push(path.display().to_string());
                }
            }
        }
        if iterations % 64 == 0 {
            write_count(&args.work, iterations);
        }
    }
    write_count(&args.work, iterations);
    println!(
        "{target}: {iterations} inputs in {:.0} s ({oks} Ok, {errors} Err, {panics} panics); new crashers: {}",
        started.elapsed().as_secs_f64(),
        if new_crashes.is_empty() {
            "none".to_owned()
        } else {
            new_crashes.join(", ")
        }
    );
    Ok(ExitCode::SUCCESS)
}

fn write_count(work: &Path, iterations: u64) {
    // Best effort: the count is a report, not a result.
    let _ = std::fs::write(work.join("iterations"), iterations.to_string());
}

/// Saves a panicking input once per distinct panic location (remembered in `work`); returns
/// its path if new.
fn save_crash(
    dir: &Path,
    work: &Path,
    target: Target,
    input: &[u8],
    message: &str,
) -> Result<Option<PathBuf>, String> {
    let location = message.split(": ").next().unwrap_or("");
    let known = work.join(format!("panic-at-{}", content_hash(location.as_bytes())));
    if known.exists() {
        return Ok(None);
    }
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let extension = match target {
        Target::Manifest | Target::Scene | Target::Gaussian => "toml",
        Target::LutExr | Target::ReferenceExr => "exr",
        Target::Photo => "img",
        Target::CameraRaw => "dng",
        Target::Obj => "obj",
        Target::Gltf if input.starts_with(b"glTF") => "glb",
        Target::Gltf => "gltf",
    };
    let path = dir.join(format!("panic-{}.{extension}", content_hash(input)));
    std::fs::write(&path, input).map_err(|e| format!("{}: {e}", path.display()))?;
    std::fs::write(&known, format!("{message}\n")).map_err(|e| e.to_string())?;
    eprintln!("{target}: new panic {message} -> {}", path.display());
    Ok(Some(path))
}
