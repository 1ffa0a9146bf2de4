#!/usr/bin/env bash
# Configures and builds digilap (Release, -O3) in ./build. Extra arguments go to cmake.
set -euo pipefail
cd "$(dirname "$0")/.."
"./scripts/setup.sh"
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DDIGILAP_PYTHON=ON "$@" > build.log 2>&1 || { cat build.log; exit 1; }
cmake --build build -j"$(nproc)" >> build.log 2>&1 || { tail -50 build.log; exit 1; }
