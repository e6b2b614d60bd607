#!/usr/bin/env bash
# One-command set-up for a Debian bookworm machine: installs the Debian
# packages in docker/debian-packages.txt (and the browser-test tooling),
# configures and builds with ccache, then runs the main job or the tests.
#
#   bash docker/bootstrap.sh run [ARGS...]   the whole pipeline on synthetic scenes
#   bash docker/bootstrap.sh test            the whole test suite
#
# Environment: SG_BUILD_DIR (default build/), CI=true turns warnings into errors.
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

configure_and_build() {
  local werror=OFF
  [ "${CI:-}" = true ] && werror=ON
  say "configuring $build"
  cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSG_WERROR="$werror" $SG_CMAKE_ARGS
  say "building with $jobs jobs"
  cmake --build "$build" -j "$jobs"
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
    ctest --test-dir "$build" -j "$jobs" --output-on-failure --timeout 600
    ;;
  *)
    echo "usage: bash docker/bootstrap.sh run|test" >&2
    exit 2
    ;;
esac
