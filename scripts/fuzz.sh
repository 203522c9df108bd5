#!/usr/bin/env bash
# Builds the libFuzzer targets of fuzz/ with clang (AddressSanitizer, UndefinedBehaviorSanitizer)
# and runs each for SECONDS (default 60), all at once, on a corpus kept in BUILD_DIR/corpus and
# seeded with the shipped scenes and meshes. Exits non-zero when a target crashes, leaks, hangs
# (10 s per input) or allocates over 2 GiB; the input that did it lands in BUILD_DIR/artifacts.
# Usage: scripts/fuzz.sh [SECONDS] [BUILD_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
build=${2:-build-fuzz}
# A build folder configured with RAYWARP_FUZZ (.ci/run's sanitizer build, which also runs the unit
# tests) is reused; otherwise one is configured for the fuzz targets alone, at -O1 as that build.
if grep -q '^RAYWARP_FUZZ:BOOL=ON' "$build/CMakeCache.txt" 2>/dev/null; then
  cmake --build "$build" -j "$(nproc 2>/dev/null || echo 2)" --target fuzz_scene fuzz_mesh fuzz_texture >/dev/null
else
  RAYWARP_EXTRA_PACKAGES="clang libclang-rt-14-dev lld" RAYWARP_BUILD_TARGETS="fuzz_scene fuzz_mesh fuzz_texture" \
    bash scripts/setup.sh "$build" -DRAYWARP_FUZZ=ON -DCMAKE_CXX_COMPILER=clang++ -DRAYWARP_TESTS=OFF \
    -DRAYWARP_BENCH=OFF "-DCMAKE_CXX_FLAGS_RELEASE=-O1 -DNDEBUG" >/dev/null
fi
mkdir -p "$build/corpus/scene" "$build/corpus/mesh" "$build/corpus/texture" "$build/artifacts"
# Seeds: every shipped scene; the shipped bunny and small meshes of each format, each behind
# the byte that picks its format (0 ply, 1 obj, 2 stl, 3 off).
cp examples/*.json examples/extreme/*.json "$build/corpus/scene/"
cp fuzz/seeds/mesh/* "$build/corpus/mesh/"
# Textures: the orientation test volume as KTX2 and DDS, behind the byte that picks the reader.
cp fuzz/seeds/texture/* "$build/corpus/texture/"
{ printf '\0'; cat examples/meshes/bunny.ply; } > "$build/corpus/mesh/bunny.ply"
export ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=0
export LSAN_OPTIONS=suppressions=$PWD/fuzz/lsan.supp
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
pids=()
targets=(scene mesh texture)
for target in "${targets[@]}"; do
  extra=()
  [ "$target" = scene ] && extra=(-dict=fuzz/scene.dict)
  "$build/fuzz_$target" "$build/corpus/$target" -max_total_time="$seconds" -max_len=16384 \
    -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 "${extra[@]}" \
    -artifact_prefix="$build/artifacts/${target}_" >"$build/fuzz_$target.log" 2>&1 &
  pids+=($!)
done
status=0
for i in "${!targets[@]}"; do
  target=${targets[$i]}
  if wait "${pids[$i]}"; then result=ok; else result=FAILED; status=1; fi
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$build/fuzz_$target.log" | grep -o '[0-9]*$' || echo "?")
  echo "fuzz_$target: $result, $runs inputs in ${seconds} s, corpus $(ls "$build/corpus/$target" | wc -l) files"
  [ $result = ok ] || tail -40 "$build/fuzz_$target.log"
done
exit $status
