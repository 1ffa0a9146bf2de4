#!/usr/bin/env bash
# Builds the libFuzzer targets (clang, with AddressSanitizer and UBSan) for the image reader ->
# contour tracker -> measures chain and for the volume readers (.npy, NIfTI) -> surfels -> measures chain,
# and runs each for a bounded time (the image target 60%, the volume target 40% of the budget)
# on a copy of its committed seed corpus. Prints the number of executions; fails on any crash
# or sanitizer report.
# Usage: scripts/fuzz.sh [seconds]   (default 60, in all)
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
./scripts/setup.sh clang libclang-rt-dev
mkdir -p build-fuzz
srcs=(lib/curve/image.cpp lib/curve/digitization.cpp lib/curve/contour.cpp lib/curve/normals.cpp lib/curve/measures.cpp
      lib/curve/shapes.cpp lib/curve/disk_moments.cpp lib/curve/length_scale.cpp lib/core/shape_parameters.cpp)
# No OpenMP here: one thread per input is what libFuzzer wants; the pragmas are ignored.
flags=(-std=c++17 -O2 -g -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=undefined -Wno-unknown-pragmas
       -Iinclude -Ilib -I/usr/include/eigen3)
# stb's zero-byte memcpy from a null pointer is harmless: the same exemption as in lib/CMakeLists.txt.
clang++ "${flags[@]}" -fno-sanitize=nonnull-attribute -c lib/curve/png_decode.cpp -o build-fuzz/png_decode.o
clang++ "${flags[@]}" "${srcs[@]}" tests/fuzz/fuzz_image.cpp build-fuzz/png_decode.o -o build-fuzz/fuzz_image
volume_srcs=(lib/surface/volume.cpp lib/surface/nifti_volume.cpp lib/surface/digitization.cpp lib/surface/surfels.cpp lib/surface/normals.cpp
             lib/surface/measures.cpp lib/surface/shapes.cpp lib/surface/length_scale.cpp lib/surface/ball_moments.cpp
             lib/curve/digitization.cpp lib/curve/shapes.cpp lib/core/shape_parameters.cpp)
# nifticlib (Debian's, not instrumented) is linked as it is: ASan still sees its heap.
clang++ "${flags[@]}" -I/usr/include/nifti "${volume_srcs[@]}" tests/fuzz/fuzz_volume.cpp -lnifti2 -lz -o build-fuzz/fuzz_volume
status=0
run_target() {  # run_target <name> <seed corpus> <seconds> <largest input in bytes>
  local name="$1" seeds="$2" time="$3" max_len="$4"
  rm -rf "build-fuzz/$name-corpus" build-fuzz/crash-* build-fuzz/leak-* build-fuzz/timeout-* build-fuzz/oom-*
  cp -r "$seeds" "build-fuzz/$name-corpus"
  local log="build-fuzz/$name.log" code
  set +e
  "build-fuzz/$name" -max_total_time="$time" -print_final_stats=1 -max_len="$max_len" -rss_limit_mb=2048 \
    -artifact_prefix=build-fuzz/ "build-fuzz/$name-corpus" > "$log" 2>&1
  code=$?
  set -e
  local execs crashes
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo 0)
  crashes=$( (ls build-fuzz/crash-* build-fuzz/leak-* build-fuzz/timeout-* build-fuzz/oom-* 2>/dev/null || true) | wc -l)
  echo "fuzz $name: $execs executions in ${time} s, $crashes crash(es), exit status $code"
  if [ "$code" -ne 0 ] || [ "$crashes" -ne 0 ]; then
    tail -40 "$log"
    status=1
  fi
}
run_target fuzz_image tests/fuzz/corpus $(( seconds * 6 / 10 )) 4096
# Volumes up to 64 KiB: a .npy header holding a 40 KB string crashed a recursive regex (issue 25).
run_target fuzz_volume tests/fuzz/volume_corpus $(( seconds - seconds * 6 / 10 )) 65536
exit $status
