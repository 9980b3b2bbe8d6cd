#!/usr/bin/env bash
# The whole test suite, exactly as CI runs it (.ci/run calls this script).
#
# On a fresh Debian/Ubuntu machine it first installs what is missing — Mesa's software Vulkan
# driver (lavapipe) for the GPU tests, a virtual X server (xvfb, xauth) and the X libraries winit
# loads for the viewer's windowed test, a C++ compiler for crates that build C++ — using sudo
# only when not root; as root it also puts /dev/null back where a container made it a plain
# file. Then: format check, clippy with warnings as errors, every test (unit, integration, CLI,
# doc tests), a publish dry run of the five crates, the docs build, and the Bevy plugin's own
# workspace with the nightly toolchain.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

# Some containers ship /dev/null as a regular file. Then what one process throws away there the
# next one reads back: in CI a build script's discarded compiler error became the "source" that
# cargo's target probe (`rustc -`, stdin from /dev/null) compiled, and `cargo test` failed before
# building anything. Put the device back when we may; otherwise empty the file before every cargo
# command.
if [ ! -c /dev/null ] && [ "$(id -u)" -eq 0 ]; then
  dev_null_new="/dev/.null.$$"
  if mknod -m 666 "$dev_null_new" c 1 3 2>/dev/null && : >"$dev_null_new" 2>/dev/null; then
    mv -f "$dev_null_new" /dev/null 2>/dev/null || rm -f "$dev_null_new"
  else
    rm -f "$dev_null_new"
  fi
fi
if [ ! -c /dev/null ]; then
  echo "warning: /dev/null is not a device here; emptying it before every cargo command" >&2
  cargo() {
    : >/dev/null
    command cargo "$@"
  }
fi

section() { printf '\n==> %s\n' "$*"; }

if ! command -v cargo >/dev/null 2>&1; then
  echo "error: cargo not found. Install Rust 1.95 or newer (https://rustup.rs), then run $0 again." >&2
  exit 1
fi

missing=()
ldconfig -p 2>/dev/null | grep -q 'libvulkan\.so\.1' || missing+=(libvulkan1)
compgen -G '/usr/share/vulkan/icd.d/lvp_icd*.json' >/dev/null || missing+=(mesa-vulkan-drivers)
command -v g++ >/dev/null 2>&1 || missing+=(g++)
command -v xvfb-run >/dev/null 2>&1 || missing+=(xvfb)
command -v xauth >/dev/null 2>&1 || missing+=(xauth)
# What winit opens at run time for an X11 window.
for lib in libX11.so.6:libx11-6 libX11-xcb.so.1:libx11-xcb1 libXcursor.so.1:libxcursor1 \
  libXrandr.so.2:libxrandr2 libXi.so.6:libxi6 libxkbcommon-x11.so.0:libxkbcommon-x11-0; do
  ldconfig -p 2>/dev/null | grep -q "${lib%%:*}" || missing+=("${lib##*:}")
done
if ((${#missing[@]})); then
  section "installing ${missing[*]}"
  sudo=()
  [ "$(id -u)" -eq 0 ] || sudo=(sudo)
  export DEBIAN_FRONTEND=noninteractive
  "${sudo[@]}" apt-get update -qq
  "${sudo[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

# Vulkan's loader warns "XDG_RUNTIME_DIR is invalid" without one; give it a private one.
if [ -z "${XDG_RUNTIME_DIR:-}" ] || [ ! -d "${XDG_RUNTIME_DIR}" ]; then
  XDG_RUNTIME_DIR="$(mktemp -d)"
  chmod 700 "$XDG_RUNTIME_DIR"
  export XDG_RUNTIME_DIR
fi

# CI builds once: incremental compilation data (GBs of target/debug/incremental) would never be
# reused there.
if [ -n "${CI:-}" ]; then
  export CARGO_INCREMENTAL=0
fi

# A clean run fills target/ with about 7 GB (4.7 GB measured in CI, without incremental data): the
# tests' build, clippy's, and the publish dry run's own build of the crates and their
# dependencies. When the disk runs out mid-link the linker dies with "Bus error", which says
# nothing about the cause; say it up front.
need_gb=8
[ -n "${CI:-}" ] && need_gb=6
free_kb="$(df -Pk . | awk 'NR == 2 { print $4 }')"
if [ -n "$free_kb" ] && [ "$free_kb" -lt $((need_gb * 1024 * 1024)) ]; then
  printf 'warning: only %s MB free on the disk holding %s; a clean run needs about %s GB\n' \
    "$((free_kb / 1024))" "$PWD" "$need_gb" >&2
fi

section "cargo fmt --check"
cargo fmt --all --check

section "cargo clippy -D warnings"
cargo clippy --workspace --all-targets --locked -- -D warnings

section "cargo test"
# --show-output prints the figures tests measure (curvature errors, spline overshoot, ...).
cargo test --workspace --locked -- --show-output

section "cargo publish --dry-run (the five crates package and build on their own)"
# Each crate is packaged and built from its package alone, against the others' packages (about
# 5 minutes: the dependencies are rebuilt outside this workspace's profiles). Needs crates.io's
# index, which CI reaches.
# Cargo unpacks the packages into a local registry folder under $CARGO_HOME and treats a registry
# crate as immutable: it neither unpacks a version it finds there again nor rebuilds one it built.
# Remove our crates' unpacked copies and their build fingerprints, or a second run verifies the
# first run's sources.
rm -rf "${CARGO_HOME:-$HOME/.cargo}"/registry/src/-*/cdrf-*-[0-9]* \
  "${CARGO_HOME:-$HOME/.cargo}"/registry/cache/-*/cdrf-*-[0-9]*.crate \
  target/package target/debug/.fingerprint/cdrf-*
# That build only has to succeed: without debug info and incremental data it needs half the disk.
CARGO_PROFILE_DEV_DEBUG=false CARGO_INCREMENTAL=0 \
  cargo publish --dry-run --workspace --exclude cdrf-tests --exclude cdrf-fuzz --locked --allow-dirty --quiet
for crate in cdrf-core cdrf-eval cdrf-fit cdrf-render cdrf-viewer; do
  # The built-in material tables (cdrf-core's presets/) are product, not test data.
  listing="$(cargo package -p "$crate" --list --locked --allow-dirty 2>/dev/null | grep -v '^presets/')"
  # Test data and the bundled photographs stay out of the packages.
  if grep -qE '(^|/)(tests|data)/|\.(exr|png|obj|glb)$' <<<"$listing"; then
    echo "error: the $crate package includes test data:" >&2
    grep -E '(^|/)(tests|data)/|\.(exr|png|obj|glb)$' <<<"$listing" >&2
    exit 1
  fi
done

section "cargo doc"
RUSTDOCFLAGS="-D warnings" cargo doc --workspace --no-deps --locked --quiet

# The Bevy plugin is a workspace of its own on the nightly toolchain: Bevy 0.20 declares
# rust-version 1.97.1, the nightly every machine of ours has is 1.97.0 (hence
# --ignore-rust-version). About 15 minutes on two cores from clean, 4 GB of target/.
if cargo +nightly --version >/dev/null 2>&1; then
  section "cdrf-bevy (integrations/cdrf-bevy, nightly): fmt, clippy, test"
  (
    cd integrations/cdrf-bevy
    cargo +nightly fmt --check
    cargo +nightly clippy --all-targets --locked --ignore-rust-version -- -D warnings
    cargo +nightly test --locked --ignore-rust-version -- --show-output
  )
else
  section "cdrf-bevy SKIPPED: no nightly toolchain (cargo +nightly) on this machine; 'rustup toolchain install nightly' runs it"
fi

section "all checks passed"
