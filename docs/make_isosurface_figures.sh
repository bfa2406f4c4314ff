#!/usr/bin/env bash
# Regenerates the isosurface pictures of docs/techniques/point_isosurface.md from the built tool
# (build/release/penumbra).
set -euo pipefail
cd "$(dirname "$0")/.."
B=${PENUMBRA:-build/release/penumbra}
out=docs/images
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$out"

# Points without shadows | points with light-pass shadows | ray-cast isosurface with exact shadow rays
# (cranium bone, 512²)
S=scenes/cranium-bone.json
$B render $S -o "$tmp/none.png" --set shadows.technique=none
mkdir -p "$tmp/tight" "$tmp/volume"
$B render $S -o "$tmp/light_pass.png" --buffers "$tmp/tight"
$B render $S -o "$tmp/reference.png" --set isosurfaces.0.method=raycast --set shadows.technique=ray_traced
$B montage "$out/iso_cranium.png" "$tmp/none.png" "$tmp/light_pass.png" "$tmp/reference.png"

# Paper Fig. 2: the shadowed points and the eye pass's final 1-bit visibility mask (black: covered)
$B montage "$out/iso_visibility.png" "$tmp/light_pass.png" "$tmp/tight/eye_visibility.png"

# Paper Fig. 6: the view from the light, frustum of the whole volume vs fitted to the eye points (§4.3):
# holes punched by the eye points, and the points the light pass extracted there
$B render $S -o "$tmp/volume.png" --set shadows.light_frustum=volume --buffers "$tmp/volume"
$B montage "$out/iso_light_view.png" "$tmp/volume/light0_holes.png" "$tmp/volume/light0_points.png" \
  "$tmp/tight/light0_holes.png" "$tmp/tight/light0_points.png"

# The chest CT's bone: points with light-pass shadows | reference
C=scenes/chest-bone.json
$B render $C -o "$tmp/chest.png"
$B render $C -o "$tmp/chest_ref.png" --set isosurfaces.0.method=raycast --set shadows.technique=ray_traced
$B montage "$out/iso_chest.png" "$tmp/chest.png" "$tmp/chest_ref.png"
