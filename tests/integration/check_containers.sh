#!/usr/bin/env bash
# Static checks of the container files (no container engine needed):
#  1. docker/Dockerfile's build stage installs exactly docker/debian-packages.txt,
#     selected the same way as docker/bootstrap.sh, and nothing else;
#  2. every shared library the built executables need comes from a package in
#     docker/runtime-packages.txt (the runtime stage's list);
#  3. docker/compose.yaml names only config files that exist and executables
#     the Dockerfile copies into the image (and that were built);
#  4. `docker compose config` when a compose plugin works here (skipped otherwise).
#
#   check_containers.sh SOURCE_DIR EXECUTABLE...
set -uo pipefail
root=$1; shift
dockerfile=$root/docker/Dockerfile
compose=$root/docker/compose.yaml
failures=0
fail() { echo "FAIL: $*" >&2; failures=$((failures + 1)); }
ok() { echo "ok: $*"; }

# --- 1. build-stage packages -------------------------------------------------
build_stage=$(awk '/^FROM .* AS build/{on=1; next} /^FROM /{on=0} on' "$dockerfile")
[ -n "$build_stage" ] || fail "Dockerfile has no 'FROM ... AS build' stage"
grep -q '^COPY docker/debian-packages.txt /tmp/debian-packages.txt$' <<<"$build_stage" \
  || fail "build stage does not COPY docker/debian-packages.txt to /tmp/debian-packages.txt"
installs=$(grep -c 'apt-get install' <<<"$build_stage")
[ "$installs" = 1 ] || fail "build stage has $installs apt-get install commands, expected exactly 1"
grep -q "apt-get install -y --no-install-recommends \$(grep -v '^#' /tmp/debian-packages.txt)" <<<"$build_stage" \
  || fail "build stage does not install \$(grep -v '^#' /tmp/debian-packages.txt)"
grep -q "grep -v '^#' \"\$root/docker/debian-packages.txt\"" "$root/docker/bootstrap.sh" \
  || fail "docker/bootstrap.sh no longer selects packages with grep -v '^#' (the Dockerfile copies that selection)"
# The same selection applied to the list must give real package names (no blank or inline-comment lines).
while read -r line; do
  [[ "$line" =~ ^[a-z0-9][a-z0-9.+-]+$ ]] || fail "docker/debian-packages.txt: '$line' is not a package name"
done < <(grep -v '^#' "$root/docker/debian-packages.txt")
[ "$failures" = 0 ] && ok "build stage installs exactly docker/debian-packages.txt ($(grep -vc '^#' "$root/docker/debian-packages.txt") packages)"

# --- 2. runtime libraries ----------------------------------------------------
runtime_stage=$(awk '/^FROM .* AS runtime/{on=1; next} /^FROM /{on=0} on' "$dockerfile")
grep -q "apt-get install -y --no-install-recommends \$(grep -v '^#' /tmp/runtime-packages.txt)" <<<"$runtime_stage" \
  || fail "runtime stage does not install docker/runtime-packages.txt"
mapfile -t runtime_pkgs < <(grep -v '^#' "$root/docker/runtime-packages.txt")
before=$failures
declare -A needed_by=()
for exe in "$@"; do
  [ -x "$exe" ] || { fail "executable $exe was not built"; continue; }
  for lib in $(readelf -d "$exe" | awk '/NEEDED/{gsub(/[][]/, "", $5); print $5}'); do
    case "$lib" in libc.so.*|libm.so.*|libgcc_s.so.*|libstdc++.so.*|ld-linux*) continue ;; esac  # in every Debian image
    needed_by[$lib]=$(basename "$exe")
  done
done
for lib in "${!needed_by[@]}"; do
  path=$(ldconfig -p | awk -v l="$lib" '$1 == l {print $NF; exit}')
  [ -n "$path" ] || { fail "${needed_by[$lib]} needs $lib, not found on this machine"; continue; }
  pkg=$(dpkg -S "$(readlink -f "$path")" 2>/dev/null | head -1 | cut -d: -f1)
  [ -n "$pkg" ] || pkg=$(dpkg -S "$path" 2>/dev/null | head -1 | cut -d: -f1)
  # A here-string, not a pipe: grep -q stops reading at the first match, and with pipefail the
  # writer's SIGPIPE would count as a failure.
  grep -qxF "$pkg" <<<"$(printf '%s\n' "${runtime_pkgs[@]}")" \
    || fail "${needed_by[$lib]} needs $lib from package '$pkg', missing in docker/runtime-packages.txt"
done
[ "$failures" = "$before" ] && ok "docker/runtime-packages.txt provides every library of $# executables"

# --- 3. compose.yaml ---------------------------------------------------------
before=$failures
copied=$(grep -o '/build/services/[a-z_0-9]*/stereoguard[a-z0-9-]*' "$dockerfile" | xargs -n1 basename | sort -u)
commands=$(grep -o 'command: \[[a-z0-9-]*' "$compose" | sed 's/command: \[//' | sort -u)
[ -n "$commands" ] || fail "compose.yaml has no command: [EXECUTABLE, ...] lines"
for c in $commands; do
  grep -qx "$c" <<<"$copied" || fail "compose.yaml runs '$c', which the Dockerfile does not copy into the image"
  found=0; for exe in "$@"; do [ "$(basename "$exe")" = "$c" ] && found=1; done
  [ "$found" = 1 ] || fail "compose.yaml runs '$c', which is not one of the built executables"
done
for f in $(grep -o '/opt/stereoguard/config/[A-Za-z0-9_./-]*' "$compose" | grep -v '/$' | sort -u); do
  [ -f "$root/config/${f#/opt/stereoguard/config/}" ] || fail "compose.yaml names $f, but config/${f#/opt/stereoguard/config/} does not exist"
done
for dds in loopback.xml vehicle.xml; do
  [ -f "$root/config/dds/$dds" ] || fail "config/dds/$dds (SG_DDS_CONFIG choice) does not exist"
done
grep -q '^    - \.\./config:/opt/stereoguard/config:ro$' "$compose" || fail "compose.yaml does not mount ../config read-only"
grep -q 'network_mode: host' "$compose" || fail "compose.yaml does not use host networking"
for s in acquisition features segmentation localization display; do
  awk -v s="  $s:" '$0 == s {on=1; next} /^  [a-z]/{on=0} on && /profiles:.*single/{found=1} END{exit !found}' "$compose" \
    || fail "service '$s' is missing or not in profile 'single'"
done
[ "$failures" = "$before" ] && ok "compose.yaml: $(wc -w <<<"$commands") executables and every config file exist; all stages in profile 'single'"

# --- 4. docker compose config (needs the compose plugin, not the engine) -----
if docker compose version >/dev/null 2>&1; then
  if (cd "$root" && docker compose -f docker/compose.yaml --profile single config -q); then
    ok "docker compose config accepts docker/compose.yaml"
  else
    fail "docker compose config rejects docker/compose.yaml"
  fi
else
  echo "skipped: docker compose config (no compose plugin on this machine)"
fi

if [ "$failures" != 0 ]; then echo "$failures check(s) failed" >&2; exit 1; fi
echo "all container checks passed"
