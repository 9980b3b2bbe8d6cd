#!/usr/bin/env bash
# Regenerates the viewer screenshots in docs/images/ (used by README.md) with the offscreen
# `cdrf-viewer screenshot` command: no display needed, software Vulkan is enough.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
cargo build --release -p cdrf-viewer
# The opening view (one model, every non-local term) …
./target/release/cdrf-viewer screenshot --size 1280x720 --out docs/images/viewer.png
# … and the comparisons, on the same scene.
for view in side-by-side split difference curvature; do
  ./target/release/cdrf-viewer screenshot --view "$view" --size 1280x720 \
    --out "docs/images/viewer_${view//-/_}.png"
done
