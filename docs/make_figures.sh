#!/usr/bin/env bash
# Regenerates the pictures in docs/images from the built tool (build/release/penumbra).
set -euo pipefail
cd "$(dirname "$0")/.."
B=build/release/penumbra
out=docs/images
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$out"

# Paper Fig. 3 and the synthetic scene: shadow_map | deep_shadow_map | cssm | ray_traced
$B demo -o "$tmp/demo" > "$tmp/demo.txt"
cp "$tmp/demo/test-spheres_comparison.png" "$tmp/demo/cranium_comparison.png" "$out/"
cp "$tmp/demo/cranium_none.png" "$out/cranium_no_shadows.png"

# Paper Fig. 2: CSSM resolution and offsets (256² with 21 offsets, 1024² with 7 and 13)
S=scenes/test-spheres.json
$B render $S -o "$tmp/cssm_256_21.png" --width 384 --height 384 --set shadows.resolution=256 --set shadows.offsets=21
$B render $S -o "$tmp/cssm_1024_7.png" --width 384 --height 384 --set shadows.resolution=1024 --set shadows.offsets=7
$B render $S -o "$tmp/cssm_1024_13.png" --width 384 --height 384 --set shadows.resolution=1024 --set shadows.offsets=13
$B render $S -o "$tmp/rt.png" --width 384 --height 384 --set shadows.technique=ray_traced
$B montage "$out/cssm_resolution_offsets.png" "$tmp/cssm_256_21.png" "$tmp/cssm_1024_7.png" "$tmp/cssm_1024_13.png" "$tmp/rt.png"

# Deep shadow map: 2, 3, 8 nodes per channel against the reference
for n in 2 3 8; do
  $B render $S -o "$tmp/dsm_$n.png" --width 384 --height 384 --set shadows.technique=deep_shadow_map --set shadows.nodes=$n
done
$B montage "$out/dsm_nodes.png" "$tmp/dsm_2.png" "$tmp/dsm_3.png" "$tmp/dsm_8.png" "$tmp/rt.png"

# Separate shadow transfer function (paper §4): grey shadows from coloured spheres
$B render $S -o "$tmp/shadow_tf.png" --width 384 --height 384 --set shadows.technique=cssm \
  --set 'volumes.0.shadow_transfer_function={"points": [[0, 0, 0, 0, 0], [0.15, 0, 0, 0, 0], [0.2, 0.3, 0.3, 0.3, 0.03], [1, 0.3, 0.3, 0.3, 0.5]]}'
$B render $S -o "$tmp/cssm.png" --width 384 --height 384 --set shadows.technique=cssm
$B montage "$out/shadow_transfer_function.png" "$tmp/cssm.png" "$tmp/shadow_tf.png"

# Extinction-based illumination (paper 001): docs/techniques/extinction_sat.md
C=scenes/cranium.json
X=(--width 384 --height 384 --set volumes.0.compositing=extinction)
# Ambient occlusion alone: none | sat_shells (3 shells) | sampled_ao (the reference)
$B render $C -o "$tmp/ao_none.png" "${X[@]}" --set shadows.technique=none
$B render $C -o "$tmp/ao_shells.png" "${X[@]}" --set shadows.technique=none --set ambient.technique=sat_shells
$B render $C -o "$tmp/ao_sampled.png" "${X[@]}" --set shadows.technique=none --set ambient.technique=sampled_ao
$B montage "$out/extinction_ao.png" "$tmp/ao_none.png" "$tmp/ao_shells.png" "$tmp/ao_sampled.png"
# Colour bleeding: AO of denser spheres without and with bleeding (β = 1), radius 0.15, ambient-heavy shading
BL=(--set shadows.technique=none --set ambient.technique=sat_shells --set ambient.radius=0.15
    --set volumes.0.transfer_function.opacity_scale=4 --set shading.ambient=0.8 --set shading.diffuse=0.3)
$B render $S -o "$tmp/bleed_0.png" "${X[@]}" "${BL[@]}" --set ambient.bleeding=0
$B render $S -o "$tmp/bleed_1.png" "${X[@]}" "${BL[@]}" --set ambient.bleeding=1
$B montage "$out/extinction_bleeding.png" "$tmp/bleed_0.png" "$tmp/bleed_1.png"
# Soft shadows at three cone angles (paper Fig. 10): none | 1° | 3° | 5°
for a in 1 3 5; do
  $B render $C -o "$tmp/cone_$a.png" "${X[@]}" --set shadows.technique=sat_cone --set shadows.cone_angle=$a
done
$B montage "$out/extinction_cone_angles.png" "$tmp/ao_none.png" "$tmp/cone_1.png" "$tmp/cone_3.png" "$tmp/cone_5.png"
# Lights inside the volume (paper Fig. 1): sat_cone + sat_shells | ray_traced
$B render scenes/light-inside.json -o "$tmp/inside.png" --width 384 --height 384
$B render scenes/light-inside.json -o "$tmp/inside_rt.png" --width 384 --height 384 --set shadows.technique=ray_traced --set ambient.technique=none
$B montage "$out/extinction_light_inside.png" "$tmp/inside.png" "$tmp/inside_rt.png"
# Too few cone samples (paper Fig. 12): 6 | 50 samples per unit, and their difference
$B render $S -o "$tmp/samples_6.png" "${X[@]}" --set shadows.technique=sat_cone --set shadows.cone_angle=3 --set shadows.cone_samples=6
$B render $S -o "$tmp/samples_50.png" "${X[@]}" --set shadows.technique=sat_cone --set shadows.cone_angle=3 --set shadows.cone_samples=50
$B compare "$tmp/samples_6.png" "$tmp/samples_50.png" --diff "$tmp/samples_diff.png" --scale 0.1 > /dev/null
$B montage "$out/extinction_cone_samples.png" "$tmp/samples_6.png" "$tmp/samples_50.png" "$tmp/samples_diff.png"
echo "extinction figures written to $out"
