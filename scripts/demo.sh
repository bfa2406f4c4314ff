#!/usr/bin/env bash
# Installs the dependencies, builds, and renders the built-in demo into ./penumbra-demo/.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
cmake --preset release
cmake --build --preset release --target penumbra
./build/release/penumbra demo -o penumbra-demo "$@"
