#!/usr/bin/env bash
# README command 2: set up, build, and run every test (ctest).
# Usage: scripts/test.sh [BUILD_DIR] [extra cmake arguments...]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
shift || true
scripts/setup.sh "$build" "$@"
cd "$build"
ctest --output-on-failure -j "$(nproc 2>/dev/null || echo 2)"
