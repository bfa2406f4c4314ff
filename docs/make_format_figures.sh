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
