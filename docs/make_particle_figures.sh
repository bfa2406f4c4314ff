#!/usr/bin/env bash
# Regenerates the particle pictures of docs/techniques/issm.md from the built tool (build/release/penumbra).
set -euo pipefail
cd "$(dirname "$0")/.."
B=build/release/penumbra
out=docs/images
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$out"

# Paper Fig. 6: local lighting | ISSM | ISSM + particle AO | ray-traced shadows + ray-traced AO (1AON)
A=scenes/1aon.json
W=(--width 480 --height 400 --set camera.zoom=1.45)
$B render $A -o "$tmp/ll.png" "${W[@]}" --set shadows.technique=none --set ambient.technique=none
$B render $A -o "$tmp/issm.png" "${W[@]}" --set ambient.technique=none
$B render $A -o "$tmp/issm_ao.png" "${W[@]}"
$B render $A -o "$tmp/rt.png" "${W[@]}" --set shadows.technique=ray_traced --set ambient.technique=ray_traced_ao
$B montage "$out/issm_1aon.png" "$tmp/ll.png" "$tmp/issm.png" "$tmp/issm_ao.png" "$tmp/rt.png"

# Hard vs soft (§3.2) on spheres over a floor: hard | soft (s, b on a 256² map; t raised to cover s) | area light traced
F=scenes/spheres-floor.json
G=(--width 420 --height 320 --set ambient.technique=none)
$B render $F -o "$tmp/hard.png" "${G[@]}"
$B render $F -o "$tmp/soft.png" "${G[@]}" --set shadows.resolution=256 \
  --set shadows.soft_radius=0.04 --set shadows.soft_distance=0.6
$B render $F -o "$tmp/area.png" "${G[@]}" --set shadows.technique=ray_traced --set shadows.light_angle=2 --set shadows.area_rays=64
$B montage "$out/issm_hard_soft.png" "$tmp/hard.png" "$tmp/soft.png" "$tmp/area.png"

# Paper Fig. 3: t = 0 vs t = 1 on a coarse 256² map, and t = 0's difference from the shadow rays (x4)
$B render $F -o "$tmp/t0.png" "${G[@]}" --set shadows.resolution=256 --set shadows.rings=0
$B render $F -o "$tmp/t1.png" "${G[@]}" --set shadows.resolution=256 --set shadows.rings=1
$B render $F -o "$tmp/hard_rt.png" "${G[@]}" --set shadows.technique=ray_traced
$B compare "$tmp/t0.png" "$tmp/hard_rt.png" --diff "$tmp/t0_diff.png" --scale 0.25 > /dev/null
$B montage "$out/issm_rings.png" "$tmp/t0.png" "$tmp/t1.png" "$tmp/hard_rt.png" "$tmp/t0_diff.png"

# Paper Fig. 7: the 3J6R capsid (60 copies, 1.03 M atoms): AO alone | ISSM + AO
C=scenes/3j6r.json
K=(--width 640 --height 400 --set camera.zoom=1.6)
$B render $C -o "$tmp/capsid_ao.png" "${K[@]}" --set shadows.technique=none
$B render $C -o "$tmp/capsid_issm_ao.png" "${K[@]}"
$B montage "$out/issm_capsid.png" "$tmp/capsid_ao.png" "$tmp/capsid_issm_ao.png"

# Beyond the paper: a point light and a spot light at once, ISSM | ray traced
L='lights=[{"type": "point", "position": [1.2, 1.6, 0.4], "intensity": 0.6}, {"type": "spot", "position": [-1.0, 1.8, 1.2], "angle_deg": 30, "intensity": 0.7}]'
$B render $F -o "$tmp/persp.png" "${G[@]}" --set "$L"
$B render $F -o "$tmp/persp_rt.png" "${G[@]}" --set "$L" --set shadows.technique=ray_traced
$B montage "$out/issm_point_spot.png" "$tmp/persp.png" "$tmp/persp_rt.png"
# Colour by a per-atom scalar: 1AON by B-factor (Cool to Warm) | by atom index (grayscale), ISSM + AO
$B render $A -o "$tmp/bfactor.png" "${W[@]}" --set particles.0.color_by=scalar
$B render $A -o "$tmp/index.png" "${W[@]}" --set particles.0.color_by=scalar --set particles.0.scalar=index \
  --set 'particles.0.color_map={"preset": "grayscale"}'
$B montage "$out/particles_scalar.png" "$tmp/bfactor.png" "$tmp/index.png"
echo "particle figures written to $out"
