#!/usr/bin/env bash
# README command 1: set up, build, and render every shipped example scene into out/.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh build
mkdir -p out
for scene in examples/*.json; do
  name=$(basename "$scene" .json)
  echo "== $name"
  build/raywarp render "$scene" -o "out/$name.png" --depth "out/$name.f32" --mask "out/${name}_mask.png"
done
echo "rendered $(ls examples/*.json | wc -l) scenes into out/"
