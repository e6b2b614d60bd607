#!/bin/sh
# Long fuzzing runs, one target after the other (each libFuzzer process uses
# one core). Each target starts from a copy of its committed seeds plus what
# earlier runs found (kept in OUT/corpus/<name>), and writes a log whose last
# lines hold the figures: executions (stat::number_of_executed_units), coverage
# (cov: edges, ft: features), corpus size, peak RSS; crashes land in OUT as
# <name>-crash-*.
#
#   sh tests/fuzz/run_long.sh BUILD_DIR [SECONDS] [OUT] [TARGETS...]
#   e.g. sh tests/fuzz/run_long.sh build-fuzz 600 /tmp/sg-fuzz-long
# FUZZ_TIMEOUT (seconds, default 10): an input running longer is a finding.
set -eu
build=${1:?usage: run_long.sh BUILD_DIR [SECONDS] [OUT] [TARGETS...]}
seconds=${2:-600}
out=${3:-/tmp/sg-fuzz-long}
shift 3 2>/dev/null || shift $#
targets=${*:-calib_opencv calib_ros calib_kitti config image dds_samples}
src=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$out"
export OPENCV_LOG_LEVEL=FATAL
for t in $targets; do
  mkdir -p "$out/corpus/$t"
  echo "== $t: $seconds s, started $(date -u +%H:%M:%S)" | tee -a "$out/summary.txt"
  status=0
  "$build/tests/fuzz/fuzz_$t" -max_total_time="$seconds" -timeout="${FUZZ_TIMEOUT:-10}" -rss_limit_mb=2048 -print_final_stats=1 \
    -artifact_prefix="$out/$t-" "$out/corpus/$t" "$src/corpus/$t" >"$out/$t.log" 2>&1 || status=$?
  {
    grep -E '^#[0-9]+[[:space:]]+DONE' "$out/$t.log" | tail -1
    grep -E '^stat::(number_of_executed_units|average_exec_per_sec|peak_rss_mb)' "$out/$t.log"
    echo "exit status $status; crash/leak/timeout/oom files: $(ls "$out" | grep -c "^$t-" || true)"
  } | tee -a "$out/summary.txt"
done
