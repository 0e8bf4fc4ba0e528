#!/usr/bin/env bash
# Installs dependencies, builds everything and runs every test through ctest.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build build -j"$(nproc)"
ctest --test-dir build --output-on-failure -j"$(nproc)"
# The Python package as a user installs it (README "Python"): a venv over Debian's interpreter,
# pip from the source tree offline; INDICIAL_BUILD_DIR=build reuses the module ctest built.
# Then the pytest suite again, importing the installed package (ctest's python_pytest imports
# build/python).
/usr/bin/python3 -m venv --system-site-packages build/venv
INDICIAL_BUILD_DIR="$PWD/build" build/venv/bin/pip install --quiet --no-build-isolation --no-index ./python
(cd build && INDICIAL_CLI="$PWD/tools/indicial" venv/bin/python -m pytest -q -p no:cacheprovider ../python/tests)
