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
echo "== bunny_simulation by the tetrahedral route: the body's tetrahedra walked in a fragment shader"
build/raywarp render examples/bunny_simulation.json --route tets -o out/bunny_simulation_tets.png \
  --depth out/bunny_simulation_tets.f32
echo "== animation: the head's twist from 0 to 360 degrees, one bake for 60 frames"
build/raywarp render examples/bunny_head_twist.json -o out/anim/bunny_head_twist.png --frames 60 \
  --param 'boxes[0].deformer.angle_deg=0:360' --width 256 --height 256
echo "== sequence: the bunny's head nodding, nine deformed copies (examples/sequence/) and in-betweens"
build/raywarp render examples/bunny_sequence.json -o out/anim/bunny_nod.png --sequence --frames 17 \
  --width 256 --height 256
echo "== library: the deformations of examples/library on the probe mesh, exported with a contact sheet"
build/raywarp library examples/library --out out/library
echo "rendered $(ls examples/*.json | wc -l) scenes and two animations (out/anim/) into out/, and a library"
echo "of $(ls examples/library/*.json | wc -l) textures into out/library/ (contact_sheet.png, viewer/index.html)"
