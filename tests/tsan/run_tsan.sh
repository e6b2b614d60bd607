#!/bin/sh
# ThreadSanitizer on the row-band code: configures a TSan tree (default
# build-tsan; -DSG_TSAN=ON, which runs the bands on std::threads instead of
# Debian's uninstrumented libtbb, see common/vision/parallel_bands.hpp), builds
# the tests below and runs each one with tests/tsan/tsan.supp. Fails when a test
# fails or TSan reports anything (logs in BUILD_DIR/tsan-logs/).
#
#   sh tests/tsan/run_tsan.sh [BUILD_DIR] [JOBS]
#   e.g. sh tests/tsan/run_tsan.sh build-tsan 2
# Extra TSAN_OPTIONS in the environment are appended.
set -eu
src=$(cd "$(dirname "$0")/../.." && pwd)
build=${1:-$src/build-tsan}
jobs=${2:-2}
# The parallel bit-exactness tests (ParallelExact, Fast*, SymmetryExact,
# LocalizerExact, the parallel scene renderer) and the other vision tests.
tests="vision/test_vision vision/test_vision_synthetic localization/test_symmetry_exact
       localization/test_localizer_exact io/test_synthetic_scene"

cmake -S "$src" -B "$build" -G Ninja -DSG_TSAN=ON -DSG_BANDS_STD_THREAD=ON -DSG_WERROR=ON -DSG_BUILD_BENCH=OFF >/dev/null
targets=""
for t in $tests; do targets="$targets ${t#*/}"; done
# shellcheck disable=SC2086
cmake --build "$build" -j"$jobs" --target $targets

export TSAN_OPTIONS="suppressions=$src/tests/tsan/tsan.supp halt_on_error=0 exitcode=66 second_deadlock_stack=1 ${TSAN_OPTIONS:-}"
export OPENCV_LOG_LEVEL=ERROR
mkdir -p "$build/tsan-logs"
status=0
for t in $tests; do
  name=${t#*/}
  log="$build/tsan-logs/$name.log"
  start=$(date +%s)
  rc=0
  "$build/tests/unit/$t" >"$log" 2>&1 || rc=$?
  reports=$(grep -c '^WARNING: ThreadSanitizer' "$log" || true)
  result=$(grep -E '^\[  (PASSED|FAILED)  \]' "$log" | tr '\n' ' ')
  echo "$name: ${result:-no gtest summary} TSan reports: $reports, exit status $rc, $(($(date +%s) - start)) s"
  if [ "$rc" -ne 0 ] || [ "$reports" -ne 0 ]; then
    status=1
    grep -A12 '^WARNING: ThreadSanitizer' "$log" | head -40
  fi
done
exit $status
