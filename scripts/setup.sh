#!/usr/bin/env bash
# Installs what raywarp needs from Debian 12's archive (only what is missing), then configures
# and builds. glslang-tools is listed because glslang-dev's CMake package names its executables. zlib, blosc and Imath headers are listed because OpenVDB's CMake module needs
# them and libopenvdb-dev does not pull them in; libegl-mesa0 is Mesa's EGL driver (llvmpipe
# without a GPU), which libegl1 only recommends.
# Usage: scripts/setup.sh [BUILD_DIR] [extra cmake arguments...]
# RAYWARP_EXTRA_PACKAGES (space-separated) adds packages to the list (scripts/fuzz.sh: clang);
# RAYWARP_BUILD_TARGETS (space-separated) builds only those targets.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
shift || true
packages=(cmake g++ make pkg-config xz-utils libeigen3-dev libopenvdb-dev libboost-iostreams-dev
          libtbb-dev libassimp-dev libosmesa6-dev libgl-dev libegl-dev libegl-mesa0
          nlohmann-json3-dev libcli11-dev
          libstb-dev libgif-dev liblzma-dev libgtest-dev zlib1g-dev libblosc-dev libimath-dev
          libglfw3-dev libimgui-dev libpng-dev libopenexr-dev glslang-dev glslang-tools
          libspirv-cross-c-shared-dev
          ${RAYWARP_EXTRA_PACKAGES:-})
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "raywarp setup: installing ${missing[*]}"
  sudo=""
  [ "$(id -u)" = 0 ] || sudo="sudo"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
jobs=$(nproc 2>/dev/null || echo 2)
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
targets=()
[ -n "${RAYWARP_BUILD_TARGETS:-}" ] && targets=(--target ${RAYWARP_BUILD_TARGETS})
cmake --build "$build" -j "$jobs" "${targets[@]}"
