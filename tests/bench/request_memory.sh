#!/usr/bin/env bash
# Memory of robocal-server's largest requests at the default limits (docs/service.md, "Memory of one
# request"); run by hand, never by ctest. For each scenario it starts the given server binary on a free port
# with one prepared database, sends the request once and then 8 at a time, and prints the server's resident
# memory before, its peak (VmHWM) and what stays resident afterwards (VmRSS), from /proc (Linux).
#
#   cmake --build build --target robocal-server
#   tests/bench/request_memory.sh build/server/robocal-server
#
# Takes about 5 minutes on 2 cores. Every input is generated deterministically (no random numbers): joint values
# from a fixed arithmetic sequence, poses from the server's own forward kinematics.
set -euo pipefail

server=${1:-build/server/robocal-server}
for tool in curl jq; do
  command -v "$tool" >/dev/null || { echo "request_memory: $tool is not installed" >&2; exit 2; }
done
[ -x "$server" ] || { echo "request_memory: no server binary at $server" >&2; exit 2; }
[ -r /proc/self/status ] || { echo "request_memory: needs /proc (Linux)" >&2; exit 2; }

work=$(mktemp -d)
# shellcheck source=bench_server.sh
source "$(dirname "$0")/bench_server.sh"
stop_server() { bench_stop_server; }
trap 'stop_server; rm -rf "$work"' EXIT
start_server() { bench_start_server request_memory "$server"; }

# VmRSS or VmHWM of the server, MB.
mb() { awk -v key="$1:" '$1 == key { printf "%d", $2 / 1024 }' "/proc/$server_pid/status"; }

post() { curl -s -o /dev/null -w '%{http_code}\n' -XPOST "$url$1" -H 'Content-Type: application/json' --data-binary "@$2"; }

# COUNT ur5e joint vectors (deg) from a fixed sequence, offset by SEED.
joints() {
  jq -nc --argjson n "$1" --argjson s "$2" \
    '[range($n)] | map(. as $i | [range(6)] | map((($i * 7919 + . * 104729 + $s * 15485863) % 72000) / 100 - 360))'
}

# Uploads COUNT measurements of ROLE to CAMPAIGN in batches of 10,000: nominal poses at the joints.
fill() {
  local campaign=$1 role=$2 count=$3 seed=$4 done=0 n
  while [ "$done" -lt "$count" ]; do
    n=$((count - done < 10000 ? count - done : 10000))
    joints "$n" "$((seed + done))" >"$work/joints.json"
    jq -c '{joints: .}' "$work/joints.json" >"$work/forward.json"
    curl -sf -XPOST "$url/v1/robots/ur5e:forward" -H 'Content-Type: application/json' \
      --data-binary "@$work/forward.json" >"$work/poses.json"
    jq -c --slurpfile q "$work/joints.json" --arg id "$campaign-$role-$seed-$done" --arg role "$role" \
      '{request_id: $id, role: $role, measurements: [.poses, $q[0]] | transpose
        | map({joints: .[1], pose: {position_mm: .[0].position_mm, quaternion: .[0].quaternion}})}' \
      "$work/poses.json" >"$work/batch.json"
    [ "$(post "/v1/campaigns/$campaign/measurements" "$work/batch.json")" = 200 ] || {
      echo "request_memory: upload to $campaign failed" >&2; exit 1; }
    done=$((done + n))
  done
}

echo "preparing the database ($work)"
start_server
for c in fit evaluate; do
  curl -sf -XPOST "$url/v1/campaigns" -H 'Content-Type: application/json' -d "{\"id\":\"$c\",\"robot\":\"ur5e\"}" >/dev/null
done
# The largest fit max_fit_jacobian_entries (2,000,000) allows for ur5e pose: 6 rows x 11,111 x 30 parameters.
fill fit calibration 11111 1
# The largest campaign (max_measurements_per_campaign 100,000), evaluated over 88,889 validation measurements.
fill evaluate calibration 11111 1
fill evaluate validation 88889 2
curl -sf -XPOST "$url/v1/campaigns/fit:fit" -H 'Content-Type: application/json' -d '{}' >/dev/null
curl -sf -XPOST "$url/v1/campaigns/evaluate:fit" -H 'Content-Type: application/json' -d '{}' >/dev/null
for c in up1x0 up8x0 up8x1 up8x2 up8x3 up8x4 up8x5 up8x6 up8x7; do
  curl -sf -XPOST "$url/v1/campaigns" -H 'Content-Type: application/json' -d "{\"id\":\"$c\",\"robot\":\"ur5e\"}" \
    >/dev/null
done
joints 10000 7 >"$work/joints.json"
jq -c '{joints: .}' "$work/joints.json" >"$work/forward.json"
curl -sf -XPOST "$url/v1/robots/ur5e:forward" -H 'Content-Type: application/json' \
  --data-binary "@$work/forward.json" >"$work/poses.json"
stop_server

# Request bodies, one file per scenario and copy (the 8 copies differ in seed or request id).
for i in $(seq 0 7); do
  echo "{\"robot\":\"ur5e\",\"num_configurations\":10,\"optimiser\":\"exchange\",\"seed\":$i,
    \"options\":{\"num_candidates\":20000,\"max_evaluations\":1000000}}" >"$work/exchange$i.json"
  echo "{\"robot\":\"ur5e\",\"num_configurations\":1000,\"seed\":$i,\"num_validation\":10000,
    \"options\":{\"k_max\":100}}" >"$work/solis_wets$i.json"
  echo '{}' >"$work/empty$i.json"
  # Unreachable pose targets from the far side of a joint range: every one runs all its solver iterations.
  jq -nc --argjson s "$i" '{targets: [range(10000)] | map({pose: {position_mm: [2000 + (. % 1000), (. % 700) - 350,
    (. % 600) + $s], rpy_deg: [180, 0, (. % 360) - 180]}, frame: "tracker", start_joints: [-300, 200, -100, 50, 150, 300]})}' \
    >"$work/compensate$i.json"
  jq -c --slurpfile q "$work/joints.json" --arg id "up-$i" \
    '{request_id: $id, measurements: [.poses, $q[0]] | transpose
      | map({joints: .[1], pose: {position_mm: .[0].position_mm, quaternion: .[0].quaternion}})}' \
    "$work/poses.json" >"$work/upload$i.json"
done

# scenario NAME PATH BODY: one request, then 8 at once; %n in PATH is the count, %i the copy.
scenario() {
  local name=$1 path=$2 body=$3 n i base start codes pids
  for n in 1 8; do
    start_server
    base=$(mb VmRSS)
    start=$EPOCHREALTIME
    pids=()
    for i in $(seq 0 $((n - 1))); do
      local target=${path//%n/$n}
      post "${target//%i/$i}" "$work/$body$i.json" >"$work/code$i" &
      pids+=($!)
    done
    wait "${pids[@]}" || true  # a failed request shows as HTTP 000
    codes=$(cat "$work"/code* | sort -u | tr '\n' ' ')
    rm -f "$work"/code*
    printf '%-46s x%d  HTTP %s%6.1f s   before %4d MB, peak %4d MB, ' "$name" "$n" "$codes" \
      "$(awk -v a="$start" -v b="$EPOCHREALTIME" 'BEGIN { print b - a }')" "$base" "$(mb VmHWM)"
    sleep 1
    printf 'after %4d MB\n' "$(mb VmRSS)"
    stop_server
  done
}

echo "server: $server; $(nproc) cores; default limits"
scenario "plan, exchange, 20,000 candidates (limit)" /v1/plans exchange
scenario "plan, solis_wets, M = 1000, 10,000 validation" /v1/plans solis_wets
scenario "fit, 11,111 pose measurements (limit)" /v1/campaigns/fit:fit empty
scenario "evaluate, 88,889 validation measurements" /v1/campaigns/evaluate:evaluate empty
scenario "compensate, 10,000 unreachable pose targets" /v1/campaigns/evaluate:compensate compensate
scenario "upload, 10,000 measurements" /v1/campaigns/up%nx%i/measurements upload
