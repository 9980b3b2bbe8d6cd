#!/usr/bin/env bash
# Regenerates the viewer screenshots in docs/images/ (used by README.md): the opening view from
# the real window under xvfb, the comparisons with the offscreen `cdrf-viewer screenshot`
# command. Software Vulkan is enough.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
cargo build --release -p cdrf-viewer
# The opening view (one model, every non-local term) in a real window, whose corner shows the
# frame time of this machine's adapter (needs xvfb-run) …
xvfb-run -a -s "-screen 0 1280x800x24" ./target/release/cdrf-viewer \
  --exit-after-frames 30 --screenshot-to docs/images/viewer.png
# … and the comparisons, on the same scene.
for view in side-by-side split difference curvature; do
  ./target/release/cdrf-viewer screenshot --view "$view" --size 1280x720 \
    --out "docs/images/viewer_${view//-/_}.png"
done
