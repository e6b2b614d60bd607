#!/usr/bin/env bash
# One-command set-up for a Debian bookworm machine: installs the Debian
# packages in docker/debian-packages.txt (and the browser-test tooling),
# configures and builds with ccache, then runs the main job or the tests.
#
#   bash docker/bootstrap.sh run [ARGS...]   the whole pipeline on synthetic scenes
#   bash docker/bootstrap.sh test            the whole test suite, then the unit and
#                                            integration tests again under ASan+UBSan,
#                                            then a short run of every fuzz target
#
# Environment: SG_BUILD_DIR (default build/), SG_ASAN_BUILD_DIR (build-asan/),
# SG_FUZZ_BUILD_DIR (build-fuzz/), CI=true turns warnings into errors,
# SG_SKIP_SANITIZERS=1 / SG_SKIP_FUZZ=1 leave those parts out.
set -euo pipefail

mode=${1:-run}
shift || true
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${SG_BUILD_DIR:-$root/build}
jobs=$(nproc)

say() { printf '\n== %s\n' "$*"; }

as_root() {
  if [ "$(id -u)" = 0 ]; then "$@"; else sudo "$@"; fi
}

install_packages() {
  local missing=() p
  for p in $(grep -v '^#' "$root/docker/debian-packages.txt"); do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || missing+=("$p")
  done
  if ! command -v npm >/dev/null 2>&1; then missing+=(nodejs npm); fi
  if ((${#missing[@]})); then
    say "installing ${#missing[@]} Debian packages: ${missing[*]}"
    as_root apt-get update
    DEBIAN_FRONTEND=noninteractive as_root apt-get install -y --no-install-recommends "${missing[@]}"
  fi
}

install_browser_tooling() {
  if [ ! -d "$root/tests/browser/node_modules/playwright-core" ]; then
    say "installing playwright-core for the browser tests"
    (cd "$root/tests/browser" && npm ci --no-audit --no-fund)
  fi
}

# Every tree hashes paths relative to the clone (ccache base_dir), so a fresh
# clone anywhere reuses what another clone compiled.
sg_ccache() { CCACHE_BASEDIR=${CCACHE_BASEDIR:-$root} CCACHE_NOHASHDIR=${CCACHE_NOHASHDIR:-true} "$@"; }

# -O2 with line tables (-g1) for the main and fuzz trees: backtraces, perf and sanitizer
# reports keep file and line, at three quarters of the compile time of full debug
# information (-g).
optimised_line_tables=(-DCMAKE_C_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG"
                       -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG")

configure_and_build() {
  local werror=OFF unity=OFF
  # CI builds once from nothing, where combined translation units (CMAKE_UNITY_BUILD)
  # pay off (with the line tables: 8.5 -> 5.7 min on 2 cores); a working tree keeps one
  # file per unit for quick rebuilds after an edit.
  [ "${CI:-}" = true ] && werror=ON unity=ON
  say "configuring $build"
  cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSG_WERROR="$werror" \
        -DCMAKE_UNITY_BUILD="$unity" "${optimised_line_tables[@]}" $SG_CMAKE_ARGS
  say "building with $jobs jobs"
  sg_ccache cmake --build "$build" -j "$jobs"
}

# Sanitizer tree: the unit and integration tests under ASan + UBSan (no
# benchmarks, no browser test). Any sanitizer report fails the test that ran it.
sanitizer_tests() {
  local dir=${SG_ASAN_BUILD_DIR:-$root/build-asan} werror=OFF
  [ "${CI:-}" = true ] && werror=ON
  say "configuring $dir (ASan + UBSan)"
  # -O1 -g1: line tables for the reports at a fraction of the compile time of -O2 -g.
  cmake -S "$root" -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSG_WERROR="$werror" -DSG_SANITIZE=ON \
        -DSG_BUILD_BENCH=OFF -DCMAKE_UNITY_BUILD=ON -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g1" -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1" || return 1
  say "building the unit and integration tests with ASan + UBSan"
  # Called as `sanitizer_tests || status=1`, where set -e does not apply: every step says so itself.
  sg_ccache cmake --build "$dir" -j "$jobs" || return 1
  say "running the unit and integration tests under ASan + UBSan"
  # The statistics over many seeds (two of them the obstacle and people acceptance tests) take
  # minutes each under the sanitizers; they go through
  # the same stages as the shorter synthetic tests run here, so they run in the main tree only.
  local slow_statistics='FarPeopleBelowTheObstacleThresholdsComeOutAsPersonSizedClusters|FarPeopleWithoutAClusterAreFoundStandingOnTheGround|RecallFalsePositivesDistanceAndFeetRow|RecallAndSpuriousOverManySeeds'
  ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1} \
  UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1} \
    ctest --test-dir "$dir" -j "$jobs" -L 'unit|integration' -E "containers_static_checks|$slow_statistics" \
          --output-on-failure --timeout 600
}

# Fuzz tree (clang, libFuzzer): a short run of every target from its seeds.
fuzz_smoke() {
  local dir=${SG_FUZZ_BUILD_DIR:-$root/build-fuzz} werror=OFF
  [ "${CI:-}" = true ] && werror=ON
  say "configuring $dir (clang, libFuzzer)"
  cmake -S "$root" -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSG_WERROR="$werror" -DSG_FUZZ=ON \
        -DSG_BUILD_BENCH=OFF -DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 -DCMAKE_UNITY_BUILD=ON \
        "${optimised_line_tables[@]}" || return 1
  sg_ccache cmake --build "$dir" -j "$jobs" --target fuzz_targets || return 1
  say "running every fuzz target for a short while"
  ctest --test-dir "$dir" -j "$jobs" -L fuzz --output-on-failure --timeout 600
}

SG_CMAKE_ARGS=${SG_CMAKE_ARGS:-}
install_packages
case "$mode" in
  run)
    configure_and_build
    say "starting the pipeline (Ctrl-C stops it)"
    exec "$build/services/cli/stereoguard" run "$@"
    ;;
  test)
    [ -f "$root/tests/browser/package.json" ] && install_browser_tooling
    configure_and_build
    say "running the tests"
    status=0
    ctest --test-dir "$build" -j "$jobs" --output-on-failure --timeout 600 || status=1
    if [ "${SG_SKIP_SANITIZERS:-}" != 1 ]; then sanitizer_tests || status=1; fi
    if [ "${SG_SKIP_FUZZ:-}" != 1 ]; then fuzz_smoke || status=1; fi
    exit "$status"
    ;;
  *)
    echo "usage: bash docker/bootstrap.sh run|test" >&2
    exit 2
    ;;
esac
