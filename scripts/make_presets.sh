#!/usr/bin/env bash
# Makes the materials built into cdrf-core (crates/cdrf-core/presets/): cdrf-preset simulates
# each medium's spheres (index-matched, 1,000,000 photons per sphere: three times the default,
# for the shipped tables) and fits them; the table and its Gaussian are copied in.
# Deterministic: the same code and settings give the same files. About 10 minutes on two cores.
#
#   scripts/make_presets.sh
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --locked -p cdrf-fit --bin cdrf-preset
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
for name in wax skin1 marble wholemilk; do
  ./target/release/cdrf-preset "$name" --photons 1000000 --out "$work/$name" --no-cache
  cp "$work/$name/measured.exr" "crates/cdrf-core/presets/$name.exr"
  cp "$work/$name/gaussian.toml" "crates/cdrf-core/presets/$name.gaussian.toml"
done
echo "crates/cdrf-core/presets/ updated; run the tests (cargo test -p cdrf-core presets)."
