#!/usr/bin/env bash
# Fuzzes every parser for SECONDS each (default 60) with the stable-toolchain harness in fuzz/:
#   scripts/fuzz.sh [SECONDS] [TARGET...]
# Each target runs as its own process under a 4 GB address-space limit (ulimit -v). A panic is
# caught in-process and its input saved as fuzz/regressions/TARGET/panic-HASH.EXT; an abort,
# the memory limit or an input running past 10 s ends the process: its input (still in the work
# folder) is saved as abort-HASH / timeout-HASH, and fuzzing resumes with the next RNG seed
# for the time left. Saved inputs are capped at 64 KB (--max-len). `cargo test -p cdrf-fuzz`
# replays every saved input (fuzz/tests/regressions.rs); list a new crasher whose fix is
# elsewhere in fuzz/regressions/KNOWN_FAILING.txt, or fix it.
set -euo pipefail
cd "$(dirname "$0")/.."

seconds="${1:-60}"
shift || true
cargo build --quiet --locked -p cdrf-fuzz
bin=target/debug/cdrf-fuzz
if [[ $# -gt 0 ]]; then targets=("$@"); else mapfile -t targets < <("$bin" targets); fi

summary=()
for target in "${targets[@]}"; do
  work="target/fuzz-work/$target"
  rm -rf "$work"
  mkdir -p "$work" "fuzz/regressions/$target"
  total=0 seed=1 crashes=()
  end=$(( $(date +%s) + seconds ))
  while (( $(date +%s) < end )); do
    left=$(( end - $(date +%s) ))
    rm -f "$work/iterations"
    set +e
    ( ulimit -v $((4 * 1024 * 1024)); RUST_BACKTRACE=0 exec "$bin" fuzz "$target" --seconds "$left" \
        --seed "$seed" --work "$work" --max-len 65536 --input-timeout 10 ) > "$work/log" 2>&1
    rc=$?
    set -e
    done_now=$(cat "$work/iterations" 2>/dev/null || echo 0)
    total=$(( total + done_now ))
    while IFS= read -r line; do
      echo "$line"
      crashes+=("${line##*-> }")
    done < <(grep -h "new panic" "$work/log" || true)
    if (( rc != 0 )); then
      kind=abort; (( rc == 3 )) && kind=timeout
      input=$(ls "$work"/input.* "$work"/cdrf-dataset.toml "$work"/scene.toml "$work"/gaussian.toml 2>/dev/null | head -1 || true)
      if [[ -n "$input" ]]; then
        ext="${input##*.}"
        hash=$(sha256sum "$input" | cut -c1-16)
        saved="fuzz/regressions/$target/$kind-$hash.$ext"
        cp "$input" "$saved"
        crashes+=("$saved")
        echo "$target: $kind (exit $rc): $(tail -n 2 "$work/log" | tr '\n' ' ') -> $saved"
      fi
    fi
    seed=$(( seed + 1 ))
  done
  summary+=("$target: $total inputs, ${#crashes[@]} new crashers ${crashes[*]:-}")
done
printf '%s\n' "" "fuzz summary (${seconds} s per target):" "${summary[@]}"
