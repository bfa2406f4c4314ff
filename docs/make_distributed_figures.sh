#!/usr/bin/env bash
# Regenerates the picture of docs/distributed.md from the built tool (build/release/penumbra) and
# prints the error of 2, 3 and 4 slabs against the whole-volume frame, per scene.
set -euo pipefail
cd "$(dirname "$0")/.."
B=build/release/penumbra
out=docs/images
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$out"

# chest (deep shadow map) without its floor: the whole frame | 4 slabs | their difference (red: 0.01)
$B render scenes/chest.json --set 'planes=[]' -o "$tmp/whole.pfm"
$B render scenes/chest.json --set 'planes=[]' --slabs 4 -o "$tmp/slabs.pfm"
$B compare "$tmp/slabs.pfm" "$tmp/whole.pfm" --diff "$tmp/difference.png" --scale 0.01
$B montage "$out/slabs_chest.png" "$tmp/whole.pfm" "$tmp/slabs.pfm" "$tmp/difference.png"

for scene in mri-head chest cranium; do
  $B render scenes/$scene.json --set 'planes=[]' -o "$tmp/$scene.pfm" 2> /dev/null
  for n in 2 3 4; do
    $B render scenes/$scene.json --set 'planes=[]' --slabs $n -o "$tmp/$scene-$n.pfm" 2> /dev/null
    echo "$scene, $n slabs: $($B compare "$tmp/$scene-$n.pfm" "$tmp/$scene.pfm" | tr '\n' ' ')"
  done
done
