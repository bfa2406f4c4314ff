#!/usr/bin/env bash
# Installs the dependencies, builds and runs the whole test suite. `scripts/test.sh sanitize` does the
# same under AddressSanitizer + UndefinedBehaviorSanitizer.
set -euo pipefail
cd "$(dirname "$0")/.."
preset="${1:-release}"
./scripts/install-deps.sh
cmake --preset "$preset"
cmake --build --preset "$preset"
ctest --preset "$preset"
