#!/usr/bin/env bash
# Installs what indicial needs to build, test and benchmark on Debian 12 (run as root).
set -euo pipefail
if [ "$(id -u)" -ne 0 ]; then SUDO=sudo; else SUDO=; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update
$SUDO apt-get install -y --no-install-recommends \
  ca-certificates cmake ninja-build g++ pkg-config git \
  libeigen3-dev libboost-dev libtomlplusplus-dev libcli11-dev libfmt-dev nlohmann-json3-dev \
  doctest-dev libbenchmark-dev gnuplot-nox \
  clang libclang-rt-14-dev   # tools/run-fuzz.sh: clang 14 with libFuzzer and its sanitizer runtimes
