#!/usr/bin/env bash
# Load figures of robocal-server (docs/service.md, "Measured performance"), measured with wrk; run by hand,
# never by ctest. Starts the given server binary (a Release build) on a free port with a temporary database,
# runs each scenario with `wrk -t2 -c8 -d10s`, prints wrk's reports and stops the server.
#
#   cmake -S . -B build-release -DCMAKE_BUILD_TYPE=Release && cmake --build build-release --target robocal-server
#   tests/bench/service_load.sh build-release/server/robocal-server
#
# Environment: WRK_ARGS (default "-t2 -c8 -d10s").
set -euo pipefail

server=${1:-build-release/server/robocal-server}
wrk_args=${WRK_ARGS:--t2 -c8 -d10s}
command -v wrk >/dev/null || { echo "service_load: wrk is not installed (Debian package wrk)" >&2; exit 2; }
[ -x "$server" ] || { echo "service_load: no server binary at $server" >&2; exit 2; }

work=$(mktemp -d)
# shellcheck source=bench_server.sh
source "$(dirname "$0")/bench_server.sh"
trap 'bench_stop_server; rm -rf "$work"' EXIT
bench_start_server service_load "$server" --threads 8 --max-measurements-per-campaign 100000000
echo "server: $server at $url; wrk $wrk_args; $(nproc) cores"

curl -sf -XPOST "$url/v1/campaigns" -H 'Content-Type: application/json' \
  -d '{"id":"load","robot":"ur5e"}' >/dev/null

# Scenario bodies.
forward='{"joints":['
for i in $(seq 10); do forward+="[$((i * 10)),-90,90,0,90,0]"; [ "$i" -lt 10 ] && forward+=','; done
forward+=']}'
echo "$forward" >"$work/forward.json"
plan='{"robot":"grinder5","num_configurations":10,"measurement_type":"pose","seed":1}'
echo "$plan" >"$work/plan.json"

# A batch of 50 measurements; every request gets its own request_id, so each one is stored (no replays).
write_batch_lua "$work/batch.lua"

post_lua "$work/forward.json" >"$work/forward.lua"
post_lua "$work/plan.json" >"$work/plan.lua"

run() {  # name, path, [script]
  echo
  echo "== $1: wrk $wrk_args ${3:+-s $(basename "$3")} $url$2"
  # shellcheck disable=SC2086
  wrk $wrk_args ${3:+-s "$3"} "$url$2"
}
run "GET /healthz" /healthz
run "POST /v1/robots/ur5e:forward (10 joint vectors)" /v1/robots/ur5e:forward "$work/forward.lua"
run "POST measurements, batches of 50, unique request_ids" /v1/campaigns/load/measurements "$work/batch.lua"
run "POST /v1/plans (grinder5, M=10, pose, Solis & Wets paper preset, synchronous)" /v1/plans "$work/plan.lua"

echo
stored=$(curl -sf "$url/v1/campaigns/load" | sed -n 's/.*"calibration":\([0-9]*\).*/\1/p')
echo "measurements stored in the campaign: $stored"
