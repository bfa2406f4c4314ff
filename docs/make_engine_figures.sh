#!/usr/bin/env bash
# Regenerates the pictures of docs/engine.md from the built tool (build/release/penumbra) and prints
# each image's error against the accumulated ray_traced reference.
set -euo pipefail
cd "$(dirname "$0")/.."
B=build/release/penumbra
out=docs/images
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$out"

# cranium under cssm: the preview a light drag shows, one full sample, 16 accumulated samples, and
# ray_traced averaged over 16 samples (the same jitter average)
C=scenes/cranium.json
W=(--width 320 --height 320)
$B render $C -o "$tmp/preview.png" "${W[@]}" --preview
$B render $C -o "$tmp/one.png" "${W[@]}"
$B render $C -o "$tmp/sixteen.png" "${W[@]}" --accumulate 16
$B render $C -o "$tmp/reference.png" "${W[@]}" --set shadows.technique=ray_traced --accumulate 16
$B montage "$out/engine_cranium.png" "$tmp/preview.png" "$tmp/one.png" "$tmp/sixteen.png" "$tmp/reference.png"
for f in preview one sixteen; do
  echo "cranium $f: $($B compare "$tmp/$f.png" "$tmp/reference.png" | tr '\n' ' ')"
done
