#!/usr/bin/env bash
# Installs, on Debian 12, what indicial needs. Run as root (or with sudo available).
#
#   tools/install-deps.sh              build and test: compiler, CMake, the libraries, doctest,
#                                      gnuplot (report plots), and the Python package's build and
#                                      tests (pybind11, python3-dev, numpy, pytest, venv, pip)
#   tools/install-deps.sh fuzz         plus clang 14 with libFuzzer (tools/run-fuzz.sh)
#   tools/install-deps.sh bench        plus Google Benchmark, python3 and valgrind (bench/run_all.sh)
#   tools/install-deps.sh cortex-m     plus the Arm bare-metal GCC with newlib and libstdc++, and
#                                      QEMU's Arm system emulator (tools/run-cortex-m.sh)
#   tools/install-deps.sh examples     plus matplotlib and Dask (examples/python/)
#   tools/install-deps.sh fuzz bench   both extras
#
# Nothing is installed when every package asked for is already there (no apt-get update).
set -euo pipefail
if [ "$(id -u)" -ne 0 ]; then SUDO=sudo; else SUDO=; fi
export DEBIAN_FRONTEND=noninteractive

packages=(
  ca-certificates cmake ninja-build g++ pkg-config git
  libeigen3-dev libboost-dev libtomlplusplus-dev libcli11-dev libfmt-dev nlohmann-json3-dev
  libssl-dev   # OpenSSL's libcrypto: SHA-256 of the input files (provenance)
  doctest-dev gnuplot-nox
  # The Python package (python/, README "Python"): Debian's pybind11 and interpreter, numpy,
  # pytest, and venv + pip + setuptools + wheel for the offline `pip install ./python`.
  pybind11-dev python3-dev python3-numpy python3-pytest python3-venv python3-pip python3-setuptools
  python3-wheel
  libzip-dev          # `indicial fmu` writes the FMU package (a zip) with libzip
  libxml2-dev unzip   # the FMU test's own importer: unzip the package, parse modelDescription.xml
  octave liboctave-dev  # the MEX stepper: built with mkoctfile --mex, tested under octave-cli
  libmatio-dev        # runs from MATLAB .mat files (v5 and v7.3: Debian's matio is built with HDF5)
)
for extra in "$@"; do
  case "$extra" in
    fuzz) packages+=(clang libclang-rt-14-dev) ;;  # clang 14 with libFuzzer and its sanitizer runtimes
    bench) packages+=(libbenchmark-dev python3 valgrind) ;;
    cortex-m) packages+=(gcc-arm-none-eabi libnewlib-arm-none-eabi libstdc++-arm-none-eabi-newlib
                         qemu-system-arm python3) ;;
    examples) packages+=(python3-matplotlib python3-dask python3-distributed) ;;
    *) echo "install-deps: unknown extra '$extra' (expected fuzz, bench, examples or cortex-m)" >&2; exit 2 ;;
  esac
done

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: everything needed is installed"
  exit 0
fi
$SUDO apt-get update
$SUDO apt-get install -y --no-install-recommends "${missing[@]}"
