#!/usr/bin/env bash
# The editor's responsiveness while it bakes: starts `raywarp edit` on a virtual X server (Xvfb)
# with a 512x512 viewport on the bunny twist at a 128 distance grid and a 128 deformation texture,
# drags the box's upper corner (which re-bakes both), and prints, from the editor's --frame-log,
# the longest gap between shown frames while the bake ran, the bake's time, and the viewport's
# render time. Needs xvfb and xdotool (scripts/test.sh installs them).
# Usage: bench/editor_frames.sh [BUILD_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
[ -x "$build/raywarp" ] || bash scripts/setup.sh "$build" >/dev/null
work=$(mktemp -d)
xvfb_pid=""
editor_pid=""
cleanup() {
  [ -n "$editor_pid" ] && kill "$editor_pid" 2>/dev/null || true
  [ -n "$xvfb_pid" ] && kill "$xvfb_pid" 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT
# The scene: bunny_twist with its camera inline and both grids at 128.
mesh=$(readlink -f examples/meshes/bunny.ply)
sed -e "s|\"meshes/bunny.ply\"|\"$mesh\"|" examples/bunny_twist.json > "$work/scene.json"
camera=$(tr -d '\n' < examples/cameras/front.json)
sed -i -e "s|\"cameras/front.json\"|$camera|" \
    -e 's|"deformer": {|"deformation": {"resolution": 128}, "deformer": {|' \
    "$work/scene.json"
exec 3> "$work/display"
Xvfb -displayfd 3 -screen 0 1280x800x24 -nolisten tcp 2>/dev/null &
xvfb_pid=$!
for _ in $(seq 100); do [ -s "$work/display" ] && break; sleep 0.1; done
export DISPLAY=":$(head -1 "$work/display")"
"$build/raywarp" edit "$work/scene.json" --width 872 --height 540 --no-cache \
  --status-file "$work/status.json" --frame-log "$work/frames.log" > "$work/editor.log" 2>&1 &
editor_pid=$!
field() { grep -o "\"$1\":[^,}]*" "$work/status.json" 2>/dev/null | head -1 | cut -d: -f2 | tr -d '"'; }
wait_idle() {  # wait_idle AFTER: idle at a state number > AFTER
  for _ in $(seq 1200); do
    if [ "$(field state)" = idle ] && [ "$(field generation)" -gt "$1" ] 2>/dev/null &&
       [ "$(field shown)" = "$(field generation)" ]; then return 0; fi
    sleep 0.05
  done
  echo "the editor did not become idle; its log:" >&2; cat "$work/editor.log" >&2; exit 1
}
wait_idle 0
gen=$(field generation)
# The widget box.max: [x, y, w, h] in window pixels (the window sits at the screen's origin).
rect=$(grep -o '"box.max":\[[^]]*\]' "$work/status.json" | grep -o '\[.*\]' | tr -d '[]')
x=$(echo "$rect" | awk -F, '{printf "%d", $1 + 0.15 * $3}')
y=$(echo "$rect" | awk -F, '{printf "%d", $2 + 0.5 * $4}')
start_ms=$(awk 'END {print $1}' "$work/frames.log")
# Separate events, a frame or more apart, as a hand gives them (else the press and the release
# land in one frame and make a click).
xdotool mousemove "$x" "$y"; sleep 0.1
xdotool mousedown 1; sleep 0.1
xdotool mousemove $((x + 6)) "$y"; sleep 0.1
xdotool mouseup 1
wait_idle "$gen"
sleep 0.5
echo "viewport: $(grep -o '"viewport":\[[^]]*\]' "$work/status.json")"
echo "bake of the edit: $(field bake_s) s; viewport render: $(field frame_ms) ms"
# Gaps between consecutive frames that both fall while the bake runs, and the time from the
# bake's last frame to the frame that shows the new image (it uploads and renders the new
# textures). Before the bake, frames come as the drag's events do; after the new image the window
# waits for input, showing nothing new.
awk -v from="$start_ms" '$1 > from && !done {
    if (prev != "" && $3 == 1 && prev_busy == 1 && $1 - prev > busy_gap) busy_gap = $1 - prev
    if (seen_busy && $3 == 0 && $2 > 0) { done = 1; shown_after = $1 - last_busy }
    if ($3 == 1) { seen_busy = 1; last_busy = $1 }
    prev = $1; prev_busy = $3; busy += $3 }
  END { printf "frames while it baked: %d, longest gap between them: %.1f ms; the new image shown %.1f ms after the bake'"'"'s last frame\n", busy, busy_gap, shown_after }' \
  "$work/frames.log"
