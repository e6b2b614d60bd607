#!/bin/sh
# Three "vehicle computers" on a lossy network, as network namespaces joined by
# veth links through a bridge namespace:
#   h1 (10.77.0.1): stereoguard-acquisition
#   h2 (10.77.0.2): stereoguard-features, stereoguard-segmentation
#   h3 (10.77.0.3): stereoguard-localization and a HumanDetections recorder
# Cyclone configuration: config/dds/vehicle.xml with the namespace interface
# and addresses (MaxMessageSize 1400B, unicast peers, LeaseDuration 3s).
# nftables drops LOSS % of the packets arriving at every host (netdev ingress
# of its veth, both directions of every link, each IP packet on its own).
#
# Checks (the QoS contract of docs/transport.md):
#  - results are lossless: every HumanDetections sample localization published
#    reaches the recorder (no sample_seq gap), and localization never misses a
#    Segmentation sample (no "superseded" at localization);
#  - image topics degrade to the latest frame: frames lost to the link show up
#    as "superseded" (features) or "join_timeout" (localization), never as
#    unaccounted frames: frames in = delivered + sum of every stage's drops.
# Prints the accounting and the end-to-end latency (capture -> detections at
# the recorder, all namespaces share the clock).
#
#   sh tests/integration/netns_lossy.sh ACQ FEATURES SEGMENTATION LOCALIZATION PROBE
#   environment: FRAMES (40), RATE (5 frames/s), LOSS (5 %), PRELOAD (4), SG_DDS_DOMAIN (185),
#                KEEP_LOGS=DIR (copy the logs there)
# Exit: 0 pass, 1 fail, 77 skipped (not root, no network namespaces or no nft).
# Everything it creates (namespaces, nft tables, processes, temp files) is
# removed on exit, whatever happens.
set -u

[ $# -eq 5 ] || { echo "usage: $0 ACQ FEATURES SEGMENTATION LOCALIZATION PROBE" >&2; exit 2; }
ACQ=$1; FEAT=$2; SEG=$3; LOC=$4; PROBE=$5
FRAMES=${FRAMES:-40}
RATE=${RATE:-5}
LOSS=${LOSS:-5}
PRELOAD=${PRELOAD:-4}          # synthetic frames made once and repeated: the source costs no CPU
DOMAIN=${SG_DDS_DOMAIN:-185}
HERE=$(cd "$(dirname "$0")" && pwd)
REPO=$(cd "$HERE/../.." && pwd)
P="sgl$$"                      # unique per run
NET=10.77.0
WORK=$(mktemp -d /tmp/sg-netns-XXXXXX)
PIDS=""
CREATED=""

cleanup() {
  set +e
  for pid in $PIDS; do kill -TERM "$pid" 2>/dev/null; done
  sleep 1
  for pid in $PIDS; do kill -KILL "$pid" 2>/dev/null; done
  for ns in $CREATED; do
    ip netns exec "$ns" nft delete table netdev sg_lossy 2>/dev/null
    ip netns del "$ns" 2>/dev/null
  done
  if [ -n "${KEEP_LOGS:-}" ]; then mkdir -p "$KEEP_LOGS" && cp "$WORK"/*.log "$WORK"/*.json "$KEEP_LOGS"/ 2>/dev/null; fi
  rm -rf "$WORK"
}
trap cleanup EXIT
trap 'exit 1' INT TERM HUP

skip() { echo "SKIP: $*"; exit 77; }
fail() { echo "FAIL: $*"; FAILED=1; }
FAILED=0

[ "$(id -u)" = 0 ] || skip "needs root (network namespaces)"
command -v ip >/dev/null 2>&1 || skip "iproute2 'ip' not found"
command -v nft >/dev/null 2>&1 || skip "nftables 'nft' not found"
for exe in "$ACQ" "$FEAT" "$SEG" "$LOC" "$PROBE"; do [ -x "$exe" ] || { echo "not executable: $exe" >&2; exit 1; }; done
ip netns add "${P}br" 2>/dev/null || skip "'ip netns add' is not permitted here"
CREATED="${P}br"

# --- network: h1, h2, h3 behind a bridge ----------------------------------
set -e
ip -n "${P}br" link add br0 type bridge
ip -n "${P}br" link set br0 up
for i in 1 2 3; do
  ns="${P}h$i"
  ip netns add "$ns"
  CREATED="$CREATED $ns"
  ip link add veth0 netns "$ns" type veth peer name "p$i" netns "${P}br"
  ip -n "${P}br" link set "p$i" master br0
  ip -n "${P}br" link set "p$i" up
  ip -n "$ns" addr add "$NET.$i/24" dev veth0
  ip -n "$ns" link set veth0 up
  ip -n "$ns" link set lo up
  if [ "$LOSS" -gt 0 ]; then
    printf 'table netdev sg_lossy { chain in { type filter hook ingress device "veth0" priority 0; policy accept; numgen random mod 100 < %s counter drop; }; }\n' \
      "$LOSS" | ip netns exec "$ns" nft -f -
  fi
done
set +e

# --- Cyclone configuration for these addresses ------------------------------
sed -e 's|name="eth0"|name="veth0"|' \
    -e "s|<Peer address=\"10\.77\.0\.\([0-9]*\)\"/>|<Peer address=\"$NET.\1\"/>|" \
    "$REPO/config/dds/vehicle.xml" > "$WORK/vehicle.xml"
grep -q 'name="veth0"' "$WORK/vehicle.xml" || { echo "could not derive the namespace configuration" >&2; exit 1; }
URI="file://$WORK/vehicle.xml"

config() { [ -f "$REPO/config/$1.yaml" ] && echo "--config $REPO/config/$1.yaml"; }
run_in() {  # run_in NS NAME LIMIT_S CMD...: bounded, logs to WORK/NAME.log
  ns=$1; name=$2; limit=$3; shift 3
  ip netns exec "$ns" env CYCLONEDDS_URI="$URI" SG_DDS_DOMAIN="$DOMAIN" \
    timeout -s TERM -k 5 "$limit" "$@" > "$WORK/$name.log" 2>&1 &
  PIDS="$PIDS $!"
  eval "PID_$name=$!"
}

LIMIT=$((FRAMES / RATE + 90))
echo "netns_lossy: $FRAMES frames (synthetic:11, $PRELOAD repeated) at $RATE Hz, $LOSS % loss at every host's ingress, domain $DOMAIN"
# Readers before writers (each writer also waits for its readers).
run_in "${P}h3" recorder "$LIMIT" "$PROBE" read --domain "$DOMAIN" --samples "$FRAMES" --timeout "$((LIMIT - 5))" --until-end
run_in "${P}h3" localization "$LIMIT" "$LOC" $(config localization) --frames "$FRAMES"
run_in "${P}h2" segmentation "$LIMIT" "$SEG" $(config segmentation) --frames "$FRAMES"
run_in "${P}h2" features "$LIMIT" "$FEAT" $(config features) --frames "$FRAMES"
START=$(date +%s.%N)
run_in "${P}h1" acquisition "$LIMIT" "$ACQ" $(config acquisition) --source synthetic:11 --rate "$RATE" \
  --min-readers 2 --frames "$FRAMES" --preload "$PRELOAD"

for name in acquisition features segmentation localization recorder; do
  eval "pid=\$PID_$name"
  wait "$pid"
  rc=$?
  [ "$rc" = 0 ] || fail "$name exited with status $rc: $(tail -n 5 "$WORK/$name.log")"
done
END=$(date +%s.%N)

# --- accounting -------------------------------------------------------------
# "stopped: received 20, published 19, dropped 1 (superseded 1)"
field() {  # field STAGE WORD -> the number before/after WORD in the stopped line
  line=$(grep -o 'stopped: .*' "$WORK/$1.log" | tail -n 1)
  case $2 in
    received|published|dropped) echo "$line" | sed -n "s/.*$2 \([0-9]*\).*/\1/p" ;;
    *) echo "$line" | sed -n "s/.*[(, ]$2 \([0-9]*\).*/\1/p" ;;
  esac
}
num() { v=$(field "$1" "$2"); echo "${v:-0}"; }
for s in acquisition features segmentation localization; do
  echo "  $s: $(grep -o 'stopped: .*' "$WORK/$s.log" | tail -n 1)"
  grep -q 'stopped: ' "$WORK/$s.log" || fail "$s printed no accounting"
done
REC=$(grep '^{' "$WORK/recorder.log" | tail -n 1)
echo "  recorder: $REC"
rec() { echo "$REC" | sed -n "s/.*\"$1\":\([-0-9.e]*\).*/\1/p"; }

frames_in=$(num acquisition received)
delivered=$(num localization published)
drops=0
for s in acquisition features segmentation localization; do drops=$((drops + $(num "$s" dropped))); done
unaccounted=$((frames_in - delivered - drops))
feat_superseded=$(num features superseded)
loc_superseded=$(num localization superseded)
loc_join=$(num localization join_timeout)
received=$(rec received); received=${received:-0}
gaps=$(rec seq_gaps); gaps=${gaps:-0}
p50=$(echo "$REC" | sed -n 's/.*"p50":\([0-9.e-]*\).*/\1/p')
p99=$(echo "$REC" | sed -n 's/.*"p99":\([0-9.e-]*\).*/\1/p')
max=$(echo "$REC" | sed -n 's/.*"max":\([0-9.e-]*\).*/\1/p')
for ns in ${P}h1 ${P}h2 ${P}h3; do
  echo "  nft drops at $ns ingress: $(ip netns exec "$ns" nft list table netdev sg_lossy 2>/dev/null | sed -n 's/.*counter packets \([0-9]*\).*/\1/p') packets"
done
cat > "$WORK/summary.json" <<JSON
{"frames": $FRAMES, "rate_hz": $RATE, "loss_percent": $LOSS, "frames_in": $frames_in, "delivered": $delivered,
 "dropped": $drops, "unaccounted": $unaccounted, "features_superseded": $feat_superseded,
 "localization_superseded": $loc_superseded, "localization_join_timeout": $loc_join,
 "recorder_received": $received, "recorder_seq_gaps": $gaps,
 "latency_ms": {"p50": ${p50:-null}, "p99": ${p99:-null}, "max": ${max:-null}},
 "wall_s": $(awk "BEGIN{printf \"%.1f\", $END - $START}")}
JSON
cat "$WORK/summary.json"

[ "$frames_in" = "$FRAMES" ] || fail "acquisition read $frames_in frames, expected $FRAMES"
[ "$unaccounted" = 0 ] || fail "$unaccounted frames unaccounted (in $frames_in, delivered $delivered, dropped $drops)"
[ "$received" = "$delivered" ] || fail "recorder received $received detections, localization published $delivered"
[ "$gaps" = 0 ] || fail "recorder saw $gaps HumanDetections sample_seq gaps (results must be lossless)"
[ "$loc_superseded" = 0 ] || fail "localization missed $loc_superseded Segmentation samples (results must be lossless)"
[ "$delivered" -gt 0 ] || fail "no frame delivered"
if [ "$FAILED" = 0 ]; then echo "PASS"; exit 0; fi
exit 1
