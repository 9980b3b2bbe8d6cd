#!/usr/bin/env bash
# Regenerates the viewer screenshots in docs/images/ (used by README.md) with the offscreen
# `cdrf-viewer screenshot` command: no display needed, software Vulkan is enough.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
cargo build --release -p cdrf-viewer
for view in side-by-side split difference curvature; do
  ./target/release/cdrf-viewer screenshot --view "$view" --size 1280x720 \
    --out "docs/images/viewer_${view//-/_}.png"
done
