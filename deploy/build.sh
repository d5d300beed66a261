#!/usr/bin/env bash
# Installs missing Debian packages, then configures and builds coins (Release) into build/.
# Usage: deploy/build.sh [extra cmake -D options]
set -euo pipefail
cd "$(dirname "$0")/.."
./deploy/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release "$@" > /dev/null
cmake --build build --parallel "$(nproc)"
