#!/usr/bin/env bash
# Builds the libFuzzer target (clang, with AddressSanitizer and UBSan) for the image reader ->
# contour tracker -> measures chain and runs it for a bounded time on a copy of the committed
# seed corpus. Prints the number of executions; fails on any crash or sanitizer report.
# Usage: scripts/fuzz.sh [seconds]   (default 60)
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
./scripts/setup.sh clang libclang-rt-dev
mkdir -p build-fuzz
srcs=(lib/image.cpp lib/digitization.cpp lib/contour.cpp lib/normals.cpp lib/measures.cpp lib/shapes.cpp lib/disk_moments.cpp
      lib/length_scale.cpp)
# No OpenMP here: one thread per input is what libFuzzer wants; the pragmas are ignored.
flags=(-std=c++17 -O2 -g -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=undefined -Wno-unknown-pragmas
       -Iinclude -I/usr/include/eigen3)
# stb's zero-byte memcpy from a null pointer is harmless: the same exemption as in lib/CMakeLists.txt.
clang++ "${flags[@]}" -fno-sanitize=nonnull-attribute -c lib/png_decode.cpp -o build-fuzz/png_decode.o
clang++ "${flags[@]}" "${srcs[@]}" tests/fuzz/fuzz_image.cpp build-fuzz/png_decode.o -o build-fuzz/fuzz_image
rm -rf build-fuzz/corpus build-fuzz/crash-* build-fuzz/leak-* build-fuzz/timeout-* build-fuzz/oom-*
cp -r tests/fuzz/corpus build-fuzz/corpus
log=build-fuzz/fuzz.log
set +e
build-fuzz/fuzz_image -max_total_time="$seconds" -print_final_stats=1 -max_len=4096 -rss_limit_mb=2048 \
  -artifact_prefix=build-fuzz/ build-fuzz/corpus > "$log" 2>&1
status=$?
set -e
execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo 0)
crashes=$( (ls build-fuzz/crash-* build-fuzz/leak-* build-fuzz/timeout-* build-fuzz/oom-* 2>/dev/null || true) | wc -l)
echo "fuzz: $execs executions in ${seconds} s, $crashes crash(es), exit status $status"
if [ "$status" -ne 0 ] || [ "$crashes" -ne 0 ]; then
  tail -40 "$log"
  exit 1
fi
