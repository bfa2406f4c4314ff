#!/usr/bin/env bash
# Installs the Debian 12 packages penumbra builds against. Safe to run again; needs root (or sudo).
set -euo pipefail
packages=(build-essential cmake ninja-build g++ pkg-config
          libtbb-dev libpng-dev zlib1g-dev nlohmann-json3-dev libcli11-dev
          libteem-dev libnifti2-dev libgtest-dev libbenchmark-dev
          gemmi-dev tao-pegtl-dev libembree-dev
          libgdcm-dev libopenjp2-7-dev libtiff-dev libopenexr-dev  # DICOM series (JPEG 2000: OpenJPEG), TIFF stacks, EXR images
          libopenvdb-dev python3-openvdb  # OpenVDB grids (sparse volumes); pyopenvdb writes the test grids
          libblosc-dev libzstd-dev python3-zarr  # Zarr stores and OME-Zarr pyramids; python3-zarr writes the test stores
          libhdf5-dev python3-h5py  # HDF5 volumes; h5py writes the test files
          python3-pydicom python3-tifffile  # independent readers the loader tests compare against
          python3-nibabel  # writes NIfTI with flipped, rotated and qform-only affines, read as nibabel reads them
          python3-pip python3-venv mypy  # `pip install .` into a fresh environment, and the stubs under mypy --strict
          python3-dev pybind11-dev python3-numpy python3-pytest  # the Python package (python/)
          python3-mdanalysis jupyter-nbconvert python3-ipykernel  # trajectories, the example notebook
          python3-ipywidgets jupyter-notebook  # penumbra.Widget (ipywidgets 6), and the notebook server its browser test starts
          python3-matplotlib  # the bench's error-against-time charts (scripts/bench_charts.py)
          libopenmpi-dev openmpi-bin  # data-parallel rendering under mpirun (src/penumbra/distributed/)
          libboost-dev libjpeg62-turbo-dev  # the viewer's server (Beast) and its JPEG frames
          chromium chromium-driver python3-selenium python3-websocket  # the viewer's browser and protocol tests
          clang-14 libfuzzer-14-dev libclang-rt-14-dev)  # the libFuzzer targets (scripts/fuzz.sh)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  sudo_cmd=""
  [ "$(id -u)" -ne 0 ] && sudo_cmd="sudo"
  $sudo_cmd apt-get update -q
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -q --no-install-recommends "${missing[@]}"
fi
# IceT, the optional compositing backend under mpirun: unpacked from Debian's ParaView packages
"$(dirname "$0")/fetch-icet.sh"
