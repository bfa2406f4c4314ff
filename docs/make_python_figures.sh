#!/usr/bin/env bash
# Runs the example notebook (docs/python_example.ipynb) and keeps its pictures for docs/python.md.
# usage: docs/make_python_figures.sh [BUILD_DIR]   (default build/release)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="$(cd "${1:-$root/build/release}" && pwd)"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
cd "$root/docs"
PYTHONPATH="$build/python" PENUMBRA_DATA="$root/../shared/data" PENUMBRA_FIGURES="$root/docs/images" \
  jupyter-nbconvert --to notebook --execute python_example.ipynb --output-dir "$out"
echo "wrote docs/images/python_volume.png, python_molecule.png, python_trajectory.png"
