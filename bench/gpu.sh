#!/usr/bin/env bash
# GPU frame times: on a machine with an NVIDIA GPU, builds raywarp if needed (scripts/setup.sh),
# then prints the median EGL frame time of every shipped example (examples/*.json) at 1920x1080
# and 512x512 at the scenes' own settings, with the GPU's name. Bakes are cached after the first
# size, so only the frames are timed; the whole run takes a few minutes.
# Usage: bench/gpu.sh [FRAMES] (frames timed per case after the first, default 30)
set -euo pipefail
cd "$(dirname "$0")/.."
frames=${1:-30}
[ -x build/raywarp ] || bash scripts/setup.sh build -DRAYWARP_TESTS=OFF -DRAYWARP_BENCH=OFF >/dev/null
gpu=$(nvidia-smi --query-gpu=name,driver_version --format=csv,noheader 2>/dev/null || echo "no nvidia-smi")
echo "GPU: $gpu"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
printf '| example | context | 1920x1080 median ms | 512x512 median ms |\n| --- | --- | ---: | ---: |\n'
for scene in examples/*.json; do
  name=$(basename "$scene" .json)
  row="| \`$name\` |"
  ctx=""
  for size in "1920 1080" "512 512"; do
    set -- $size
    log=$(build/raywarp render "$scene" -o "$out/$name.png" --context egl --width "$1" --height "$2" \
          --time "$frames" 2>&1) || { echo "$log" >&2; exit 1; }
    [ -n "$ctx" ] || ctx=$(echo "$log" | grep -o '^context: .*' | head -1 | sed 's/^context: //; s/|/\//g')
    median=$(echo "$log" | grep -o 'median [0-9.]* ms' | grep -o '[0-9.]*')
    row="$row $median |"
  done
  echo "| \`$name\` | $ctx |${row#*|*|}"
done
