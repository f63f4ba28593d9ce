#!/usr/bin/env bash
# Several instances on one PostgreSQL database against one instance, and PostgreSQL against SQLite
# (docs/scaling.md, "Measured"); run by hand, never by ctest. Starts a private PostgreSQL cluster
# (tests/storage/pg_cluster.sh), then for each setup (SQLite x 1, PostgreSQL x 1, PostgreSQL x 3) starts the
# instances on free ports and measures with wrk: always WRKS wrk processes at once (default 3, each 3
# connections), process j sending to instance j mod N, so that the load generator costs the same in every
# setup and only the servers differ:
#   - uploads: POST .../measurements, batches of 50, a new request_id each, every instance its own campaign
#     (cells of a plant);
#   - :compensate of 10 joint targets on a calibrated campaign;
#   - p99 latency of a small request (GET /v1/campaigns/{c}) on one instance while another instance (or, with
#     one instance, the same one) runs a long async fit, and without it.
#
#   tests/bench/instances_load.sh build/server/robocal-server build/client/robocal-mock-tracker
#
# Environment: DURATION (wrk -d, default 10s), WRKS (wrk processes, default 3), CONNECTIONS (each, default 3).
set -euo pipefail

server=${1:-build/server/robocal-server}
tracker=${2:-build/client/robocal-mock-tracker}
duration=${DURATION:-10s}
wrks=${WRKS:-3}
connections=${CONNECTIONS:-3}
here=$(cd "$(dirname "$0")" && pwd)
command -v wrk >/dev/null || { echo "instances_load: wrk is not installed (Debian package wrk)" >&2; exit 2; }
command -v psql >/dev/null || { echo "instances_load: psql is not installed (Debian package postgresql-client)" >&2; exit 2; }
[ -x "$server" ] || { echo "instances_load: no server binary at $server" >&2; exit 2; }
[ -x "$tracker" ] || { echo "instances_load: no mock tracker at $tracker" >&2; exit 2; }

work=$(mktemp -d)
chmod 0755 "$work"
pids=()
stop_instances() {
  for p in "${pids[@]}"; do kill -TERM "$p" 2>/dev/null || true; done
  for p in "${pids[@]}"; do wait "$p" 2>/dev/null || true; done
  pids=()
}
trap 'stop_instances; bash "$here/../storage/pg_cluster.sh" stop "$work/pg" >/dev/null; rm -rf "$work"' EXIT
# fsync on: a 2xx means on disk, as with SQLite's synchronous=FULL.
PG_CLUSTER_FSYNC=on bash "$here/../storage/pg_cluster.sh" start "$work/pg" >/dev/null
socket=$(cat "$work/pg/socket_dir")

# CPU seconds used so far by the instances and by the PostgreSQL cluster (its postmaster and every backend),
# for the per-request costs: "server_s postgres_s".
clk=$(getconf CLK_TCK)
cpu_seconds() {
  local server=0 pg=0 p postmaster
  for p in "${pids[@]}"; do server=$((server + $(awk '{print $14 + $15}' "/proc/$p/stat" 2>/dev/null || echo 0))); done
  postmaster=$(head -1 "$socket/data/postmaster.pid" 2>/dev/null || true)
  if [ -n "$postmaster" ]; then
    for p in $postmaster $(pgrep -P "$postmaster"); do pg=$((pg + $(awk '{print $14 + $15}' "/proc/$p/stat" 2>/dev/null || echo 0))); done
  fi
  echo "$(python3 -c "print($server / $clk)") $(python3 -c "print($pg / $clk)")"
}
# per_request BEFORE AFTER REQUESTS: CPU milliseconds per request in the instances and in PostgreSQL.
per_request() {
  python3 -c "b='$1'.split(); a='$2'.split(); n=$3
print('CPU per request: instances %.2f ms, PostgreSQL %.2f ms' % ((float(a[0])-float(b[0]))*1000/n, (float(a[1])-float(b[1]))*1000/n))"
}

urls=()
# start_instances N DB: N instances on DB; sets urls.
start_instances() {
  local n=$1 db=$2
  urls=()
  for i in $(seq "$n"); do
    # Its first line, once bound, says where it listens: read from a pipe, waiting for that line or its exit.
    rm -f "$work/out$i"
    mkfifo "$work/out$i"
    "$server" --port 0 --db "$db" --log-level warn --threads 8 --db-pool-size 8 \
      --max-measurements-per-campaign 100000000 >"$work/out$i" 2>"$work/err$i" &
    pids+=($!)
    local u
    u=$(read_listening_line "$work/out$i")
    [ -n "$u" ] || { echo "instances_load: instance $i did not start" >&2; cat "$work/err$i" >&2; exit 1; }
    urls+=("$u")
  done
}

fresh_database() {  # NAME: an empty PostgreSQL database; prints its URL
  psql -q -h "$socket" -U robocal -d postgres -c "CREATE DATABASE $1" >/dev/null
  echo "postgresql://robocal@/$1?host=$socket"
}

# shellcheck source=bench_server.sh
source "$here/bench_server.sh"
write_batch_lua "$work/batch.lua"
python3 - >"$work/compensate.json" <<'PY'
import json, random
random.seed(1)
print(json.dumps({"targets": [{"joints": [round(random.uniform(-170, 170), 6) for _ in range(6)]} for _ in range(10)]}))
PY
post_lua "$work/compensate.json" >"$work/compensate.lua"

# wrk_all PATH SCRIPT: the wrk processes at once over the instances; prints the summed requests/s.
wrk_all() {
  local path=$1 script=$2
  local n=${#urls[@]} each=$connections i
  local outs=() before
  before=$(cpu_seconds)
  for i in $(seq "$wrks"); do
    wrk -t1 -c"$each" -d"$duration" -s "$script" "${urls[$(((i - 1) % n))]}$path" >"$work/wrk$i" 2>&1 &
    outs+=("$work/wrk$i")
  done
  wait_wrk
  local after total=0 non2xx=0 requests=0
  after=$(cpu_seconds)
  for o in "${outs[@]}"; do
    total=$(python3 -c "print($total + $(sed -n 's/^Requests\/sec: *//p' "$o"))")
    requests=$((requests + $(sed -n 's/^ *\([0-9]*\) requests in.*/\1/p' "$o")))
    local bad
    bad=$(sed -n 's/.*Non-2xx or 3xx responses: *//p' "$o" | tr -d ' ')
    non2xx=$((non2xx + ${bad:-0}))
  done
  printf '%.0f requests/s (%d instance(s), %d wrk x %d connections, non-2xx %d); ' "$total" "$n" "$wrks" "$each" "$non2xx"
  per_request "$before" "$after" "$requests"
}
wait_wrk() { while pgrep -P $$ -x wrk >/dev/null; do sleep 0.2; done; }

calibrate() {  # URL: a calibrated ur5e campaign made by the mock tracker; prints its id
  "$tracker" --server "$1" --robot ur5e --count 30 --json >"$work/report.json" 2>/dev/null
  python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["trials"][0]["planned"]["campaign"])' "$work/report.json"
}

# A campaign with a long fit to run: 3000 shots (60 poses x 50) of the mock cell, a model chosen by 20-fold cross-validation.
long_fit_campaign() {  # URL
  "$tracker" --server "$1" --robot ur5e --count 60 --shots 50 --optimiser random --json >"$work/long.json" 2>/dev/null
  python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["trials"][0]["planned"]["campaign"])' "$work/long.json"
}

# p99 of GET /v1/campaigns/{c} on the last instance, with and without a long fit running on the first.
latency() {
  local small=$1 long=$2 target=${urls[${#urls[@]}-1]}
  wrk -t1 -c2 -d"$duration" --latency "$target/v1/campaigns/$small" >"$work/idle" 2>&1
  echo "  idle:             p50 $(sed -n 's/^ *50% *//p' "$work/idle"), p99 $(sed -n 's/^ *99% *//p' "$work/idle")"
  curl -sf -XPOST -H 'Content-Type: application/json' \
    -d '{"async":true,"model":"auto","cross_validation":{"folds":20,"seed":1}}' \
    "${urls[0]}/v1/campaigns/$long:fit" >"$work/op.json"
  local op
  op=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["id"])' "$work/op.json")
  wrk -t1 -c2 -d"$duration" --latency "$target/v1/campaigns/$small" >"$work/busy" 2>&1
  local state
  state=$(curl -sf "${urls[0]}/v1/operations/$op" | python3 -c 'import json,sys; print(json.load(sys.stdin)["state"])')
  echo "  during a long fit: p50 $(sed -n 's/^ *50% *//p' "$work/busy"), p99 $(sed -n 's/^ *99% *//p' "$work/busy") (the fit was $state when wrk ended)"
  curl -sf -XPOST "${urls[0]}/v1/operations/$op:cancel" >/dev/null || true
}

run_setup() {  # LABEL N DB
  local label=$1 n=$2 db=$3
  echo
  echo "== $label"
  start_instances "$n" "$db"
  local i
  for i in $(seq "$wrks"); do
    curl -sf -XPOST "${urls[0]}/v1/campaigns" -H 'Content-Type: application/json' \
      -d "{\"id\":\"cell$i\",\"robot\":\"ur5e\"}" >/dev/null
  done
  local calibrated long
  calibrated=$(calibrate "${urls[0]}")
  long=$(long_fit_campaign "${urls[0]}")
  # Wrk process j uploads to its own campaign, cell<j> (a plant's cells), through instance j mod N.
  local n_urls=${#urls[@]} j
  echo -n "uploads, 50 per batch: "
  local outs=() each=$connections before after requests=0
  before=$(cpu_seconds)
  for j in $(seq "$wrks"); do
    wrk -t1 -c"$each" -d"$duration" -s "$work/batch.lua" "${urls[$(((j - 1) % n_urls))]}/v1/campaigns/cell$j/measurements" \
      -- "cell$j" "w$j-" >"$work/up$j" 2>&1 &
    outs+=("$work/up$j")
  done
  wait_wrk
  after=$(cpu_seconds)
  local total=0
  for o in "${outs[@]}"; do
    total=$(python3 -c "print($total + $(sed -n 's/^Requests\/sec: *//p' "$o"))")
    requests=$((requests + $(sed -n 's/^ *\([0-9]*\) requests in.*/\1/p' "$o")))
  done
  printf '%.0f batches/s = %.0f measurements/s (%d instance(s), %d wrk x %d connections); ' "$total" \
    "$(python3 -c "print($total * 50)")" "$n_urls" "$wrks" "$each"
  per_request "$before" "$after" "$requests"
  echo -n ":compensate, 10 targets: "
  wrk_all "/v1/campaigns/$calibrated:compensate" "$work/compensate.lua"
  echo "p99 of GET /v1/campaigns/{c} on instance $n_urls (a long async fit on instance 1):"
  latency "$calibrated" "$long"
  stop_instances
}

echo "server $server; $wrks wrk processes x $connections connections, -d$duration; $(nproc) cores"
run_setup "SQLite, 1 instance" 1 "$work/sqlite/robocal.db"
run_setup "PostgreSQL, 1 instance" 1 "$(fresh_database bench_one)"
run_setup "PostgreSQL, 3 instances" 3 "$(fresh_database bench_three)"
