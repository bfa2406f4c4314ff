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
echo "figures written to $out"
