#!/usr/bin/env bash
# Installs dependencies, builds, and runs the built-in example end to end.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build build -j"$(nproc)" --target indicial
out=$(mktemp -d)
build/tools/indicial example --out "$out/example"
