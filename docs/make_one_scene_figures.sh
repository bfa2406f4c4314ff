#!/usr/bin/env bash
# Regenerates the pictures of docs/techniques/one_scene.md (and README's first one) from the built tool (build/release/penumbra)
# and prints each technique's error against ray_traced on the mixed scenes.
set -euo pipefail
cd "$(dirname "$0")/.."
B=build/release/penumbra
out=docs/images
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$out"

# README's picture: a translucent coloured volume (test-spheres) over white spheres and a floor, exact shadows
$B render scenes/one-scene.json -o "$out/one_scene.png"

# GroEL (1AON) inside its own density map, an isosurface of the map's dense cores, the atoms, a floor
$B render scenes/groel-density.json -o "$out/one_scene_groel.png" --width 640 --height 480

# The CT with metal implants under every map technique and ray_traced
C=scenes/ct-implants.json
W=(--width 320 --height 320)
for t in shadow_map deep_shadow_map cssm ray_traced none; do
  $B render $C -o "$tmp/ct_$t.png" "${W[@]}" --set shadows.technique=$t
done
$B montage "$out/one_scene_ct_implants.png" "$tmp/ct_none.png" "$tmp/ct_shadow_map.png" "$tmp/ct_deep_shadow_map.png" \
  "$tmp/ct_cssm.png" "$tmp/ct_ray_traced.png"
for t in none shadow_map deep_shadow_map cssm; do
  echo "ct-implants $t: $($B compare "$tmp/ct_$t.png" "$tmp/ct_ray_traced.png" | tr '\n' ' ')"
done

# Coloured shadows across kinds: a translucent red slab over white spheres, an isosurface and a floor
cat > "$tmp/slab.json" <<'JSON'
{
  "volumes": [
    { "procedural": { "name": "slab", "size": 32, "thickness": 0.16 }, "origin": [-0.5, 0.1, -0.5],
      "transfer_function": { "points": [[0, 1, 0.1, 0.1, 0], [0.5, 1, 0.1, 0.1, 0], [0.5, 1, 0.1, 0.1, 0.25], [1, 1, 0.1, 0.1, 0.25]] } },
    { "procedural": { "name": "sphere", "size": 32, "radius": 0.25 }, "origin": [-0.25, -1.05, -0.5], "visible": false }
  ],
  "isosurfaces": [ { "volume": 1, "value": 0.5, "method": "raycast", "color": [0.95, 0.95, 0.95] } ],
  "particles": [ { "procedural": { "name": "random-spheres", "count": 60, "radius": 0.06, "seed": 5 } } ],
  "planes": [ { "point": [0, -0.85, 0], "normal": [0, 1, 0], "color": [0.95, 0.95, 0.95], "size": 3 } ],
  "lights": [ { "type": "directional", "direction": [-0.2, -1.0, 0.1] } ],
  "camera": { "eye": [1.4, 0.9, 2.0], "target": [0, -0.45, 0], "fov_deg": 40, "width": 480, "height": 360 },
  "shadows": { "technique": "ray_traced" },
  "background": [0.1, 0.1, 0.12]
}
JSON
$B render "$tmp/slab.json" -o "$tmp/slab_rt.png"
$B render "$tmp/slab.json" -o "$tmp/slab_cssm.png" --set shadows.technique=cssm --set shadows.resolution=1024
$B montage "$out/one_scene_red_slab.png" "$tmp/slab_rt.png" "$tmp/slab_cssm.png"
