#!/usr/bin/env bash
# Regenerates the pictures of docs/volume-formats.md from the built tool (build/release/penumbra): each
# staged file of ../shared/data opened directly (the automatic scene: transfer function, floor, light).
set -euo pipefail
cd "$(dirname "$0")/.."
B=build/release/penumbra
D=../shared/data
out=docs/images
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$out"
W=(--width 360 --height 300)
$B render "$D/dicom_pancreas_ct" -o "$tmp/dicom.png" "${W[@]}" --set camera.zoom=2.2
$B render "$D/arabidopsis_embryo.tif" -o "$tmp/embryo.png" "${W[@]}"
$B render "$D/nucleus_conf_wf.tif" -o "$tmp/confocal.png" "${W[@]}" --set camera.zoom=1.6
$B render "$D/nucleus_conf_wf.tif" --channel 1 -o "$tmp/widefield.png" "${W[@]}" --set camera.zoom=1.6
$B render "$D/headsq_vtkdefault.vti" -o "$tmp/vti.png" "${W[@]}"
$B montage "$out/formats_dicom_tiff_vti.png" "$tmp/dicom.png" "$tmp/embryo.png" "$tmp/vti.png"
$B montage "$out/formats_confocal_widefield.png" "$tmp/confocal.png" "$tmp/widefield.png"
# OpenVDB: no staged file, so pyopenvdb (python3-openvdb) writes one with two grids: a cloud of soft
# balls (fog volume) and a level-set sphere.
/usr/bin/python3 - "$tmp/cloud.vdb" <<'PY'
import random, sys
import pyopenvdb as vdb
fog = vdb.FloatGrid(0.0)
fog.name = "density"
acc = fog.getAccessor()
rng = random.Random(5)
for _ in range(40):
    c = [rng.gauss(0, 22) for _ in range(3)]
    r = rng.uniform(5, 12)
    n = int(r) + 1
    for i in range(-n, n + 1):
        for j in range(-n, n + 1):
            for k in range(-n, n + 1):
                d = (i * i + j * j + k * k) ** 0.5
                if d < r:
                    p = (int(c[0]) + i, int(c[1]) + j, int(c[2]) + k)
                    acc.setValueOn(p, max(acc.getValue(p), 1.0 - d / r))
sphere = vdb.createLevelSetSphere(radius=30.0, center=(0, 0, 0), voxelSize=1.0, halfWidth=3.0)
sphere.name = "surface"
vdb.write(sys.argv[1], grids=[fog, sphere])
PY
$B render "$tmp/cloud.vdb" -o "$tmp/cloud.png" "${W[@]}" --set camera.zoom=1.8 --accumulate 8
$B render "$tmp/cloud.vdb" --grid surface -o "$tmp/surface.png" "${W[@]}"
$B montage "$out/formats_vdb.png" "$tmp/cloud.png" "$tmp/surface.png"
