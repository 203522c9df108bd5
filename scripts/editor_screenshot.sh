#!/usr/bin/env bash
# The README's picture of the editor: `raywarp edit examples/bunny_cut_thick.json` (a box cut
# shown as a thick shell) on a virtual X server, captured once the bake is on screen, to
# docs/images/editor_cut.png. Needs xvfb and imagemagick (scripts/test.sh installs them).
# Usage: scripts/editor_screenshot.sh [BUILD_DIR]
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
exec 3> "$work/display"
Xvfb -displayfd 3 -screen 0 1280x800x24 -nolisten tcp 2>/dev/null &
xvfb_pid=$!
for _ in $(seq 100); do [ -s "$work/display" ] && break; sleep 0.1; done
export DISPLAY=":$(head -1 "$work/display")"
"$build/raywarp" edit examples/bunny_cut_thick.json --width 1280 --height 800 --no-cache \
  --status-file "$work/status.json" > "$work/editor.log" 2>&1 &
editor_pid=$!
field() { grep -o "\"$1\":[^,}]*" "$work/status.json" 2>/dev/null | head -1 | cut -d: -f2 | tr -d '"'; }
for _ in $(seq 1200); do
  if [ "$(field state)" = idle ] && [ "$(field shown)" = "$(field generation)" ] &&
     [ "$(field generation)" -gt 0 ] 2>/dev/null; then break; fi
  sleep 0.05
done
[ "$(field state)" = idle ] || { echo "the editor did not become idle:" >&2; cat "$work/editor.log" >&2; exit 1; }
sleep 0.5  # the frame drawn after the state was published
mkdir -p docs/images
import -window root "PNG24:$work/shot.png"
mv "$work/shot.png" docs/images/editor_cut.png
echo "wrote docs/images/editor_cut.png"
