#!/usr/bin/env bash
# Throughput of POST /v1/campaigns/{c}:compensate (docs/compensation.md, "Throughput"); run by hand, never by
# ctest. Starts the given server binary on a free port with a temporary database, calibrates a ur5e campaign
# with the mock tracker, then posts ROUNDS requests of TARGETS random nominal joint targets each, first one
# client at a time, then CLIENTS at once, and prints joint targets per second of wall time.
#
#   tests/bench/compensate_throughput.sh build/server/robocal-server build/client/robocal-mock-tracker
#
# Environment: TARGETS (default 10000), ROUNDS (default 5), CLIENTS (default 2).
set -euo pipefail

server=${1:-build/server/robocal-server}
tracker=${2:-build/client/robocal-mock-tracker}
targets=${TARGETS:-10000}
rounds=${ROUNDS:-5}
clients=${CLIENTS:-2}
[ -x "$server" ] || { echo "compensate_throughput: no server binary at $server" >&2; exit 2; }
[ -x "$tracker" ] || { echo "compensate_throughput: no mock tracker at $tracker" >&2; exit 2; }

work=$(mktemp -d)
# shellcheck source=bench_server.sh
source "$(dirname "$0")/bench_server.sh"
trap 'bench_stop_server; rm -rf "$work"' EXIT
bench_start_server compensate_throughput "$server"

"$tracker" --server "$url" --robot ur5e --count 30 --json >"$work/report.json"
campaign=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["trials"][0]["planned"]["campaign"])' "$work/report.json")

# TARGETS random nominal joint targets within the ur5e's limits (seeded: the same body every run).
python3 - "$targets" >"$work/body.json" <<'PY'
import json, random, sys
random.seed(1)
n = int(sys.argv[1])
print(json.dumps({"targets": [{"joints": [round(random.uniform(-360, 360), 6) for _ in range(6)]} for _ in range(n)]}))
PY

post() { curl -sf -o /dev/null -H 'Content-Type: application/json' --data-binary @"$work/body.json" "$url/v1/campaigns/$campaign:compensate"; }
post  # warm up

start=$(date +%s.%N)
for _ in $(seq "$rounds"); do post; done
end=$(date +%s.%N)
echo "one client:  $rounds x $targets targets: $(python3 -c "print(round($rounds * $targets / ($end - $start)))") targets/s"

start=$(date +%s.%N)
pids=()
for _ in $(seq "$clients"); do
  (for _ in $(seq "$rounds"); do post; done) &
  pids+=($!)
done
wait "${pids[@]}"  # not the server, which runs in the background too
end=$(date +%s.%N)
echo "$clients clients: $((clients * rounds)) x $targets targets: $(python3 -c "print(round($clients * $rounds * $targets / ($end - $start)))") targets/s"
echo "($(nproc) cores, server $server)"
