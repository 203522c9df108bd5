#!/usr/bin/env bash
# README command 2: set up, build, and run every test (ctest).
# Usage: scripts/test.sh [BUILD_DIR] [extra cmake arguments...]
# RAYWARP_TEST_LABELS='unit|smoke' runs only the tests with those labels (docs/testing.md).
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
shift || true
# The editor's test drives a window on a virtual X server: Xvfb, xdotool, ImageMagick's import.
RAYWARP_EXTRA_PACKAGES="${RAYWARP_EXTRA_PACKAGES:-} xvfb xdotool imagemagick" scripts/setup.sh "$build" "$@"
cd "$build"
labels=()
[ -n "${RAYWARP_TEST_LABELS:-}" ] && labels=(-L "$RAYWARP_TEST_LABELS")
ctest --output-on-failure -j "$(nproc 2>/dev/null || echo 2)" "${labels[@]}"
