#!/usr/bin/env bash
# IceT (Sandia's sort-last image compositing library, version 2.2), the optional compositing backend
# of `mpirun -np N penumbra render --compositor icet` (docs/distributed.md).
#
# Debian 12 ships IceT only inside ParaView: its libraries in the package `paraview`, its headers in
# `paraview-dev`. Installing those pulls in 240 packages (1.3 GB: Qt, VTK, Python modules) for two
# libraries of 170 kB that need only libc, libm and Open MPI's libmpi. So this script downloads the two
# Debian packages with apt-get and unpacks IceT's headers and its core and MPI libraries alone into
# PENUMBRA_ICET_ROOT (default /opt/penumbra/icet), where CMake looks for them. Nothing is installed
# into the system. Without network access or the packages it says so and leaves penumbra without IceT
# (the direct-send compositor needs nothing). Safe to run again; needs root (or sudo) for /opt.
set -euo pipefail
dest="${PENUMBRA_ICET_ROOT:-/opt/penumbra/icet}"
if [ -f "$dest/include/IceTMPI.h" ] && ls "$dest"/lib/libvtkIceTMPI*.so >/dev/null 2>&1; then exit 0; fi
sudo_cmd=""
[ "$(id -u)" -ne 0 ] && sudo_cmd="sudo"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
chmod 755 "$work"  # apt-get download fetches as the _apt user
cd "$work"
if ! apt-get download -q paraview paraview-dev >download.log 2>&1; then
  echo "fetch-icet: apt-get download paraview paraview-dev failed; penumbra builds without IceT:" >&2
  tail -3 download.log >&2
  exit 0
fi
for deb in paraview_*.deb paraview-dev_*.deb; do dpkg-deb -x "$deb" unpacked; done
headers="$(echo unpacked/usr/include/paraview-*/vtkicet/src/include)"
$sudo_cmd mkdir -p "$dest/include" "$dest/lib"
$sudo_cmd cp "$headers/IceT.h" "$headers/IceTConfig.h" "$headers/IceTMPI.h" "$dest/include/"
$sudo_cmd cp -P unpacked/usr/lib/*/libvtkIceTCore-pv*.so* unpacked/usr/lib/*/libvtkIceTMPI-pv*.so* "$dest/lib/"
$sudo_cmd cp unpacked/usr/share/doc/paraview/copyright "$dest/copyright"
echo "fetch-icet: IceT $(sed -n 's/#define ICET_VERSION *"\(.*\)"/\1/p' "$dest/include/IceTConfig.h") unpacked into $dest (from $(ls paraview_*.deb))"
