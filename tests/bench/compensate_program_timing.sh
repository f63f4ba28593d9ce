#!/usr/bin/env bash
# Wall time of POST /v1/campaigns/{c}:compensate-program for a KUKA KRL program of TARGETS targets (docs/programs.md,
# "Speed"); run by hand, never by ctest. Starts the given server binary on a free port with a temporary database,
# calibrates a ur5e campaign with the mock tracker, builds a .src + .dat of TARGETS PTP moves (half E6AXIS, half
# E6POS at the nominal poses of seeded random joints, from the server's :forward), posts it ROUNDS times with curl
# and prints the time of each request.
#
#   tests/bench/compensate_program_timing.sh build/server/robocal-server build/client/robocal-mock-tracker
#
# Environment: TARGETS (default 10000), ROUNDS (default 3).
set -euo pipefail

server=${1:-build/server/robocal-server}
tracker=${2:-build/client/robocal-mock-tracker}
targets=${TARGETS:-10000}
rounds=${ROUNDS:-3}
[ -x "$server" ] || { echo "compensate_program_timing: no server binary at $server" >&2; exit 2; }
[ -x "$tracker" ] || { echo "compensate_program_timing: no mock tracker at $tracker" >&2; exit 2; }

work=$(mktemp -d)
# shellcheck source=bench_server.sh
source "$(dirname "$0")/bench_server.sh"
trap 'bench_stop_server; rm -rf "$work"' EXIT
bench_start_server compensate_program_timing "$server"

"$tracker" --server "$url" --robot ur5e --count 30 --json >"$work/report.json"
campaign=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["trials"][0]["planned"]["campaign"])' "$work/report.json")

# Seeded joints within +-170 deg (joint 5 kept off its singularity), their nominal poses from :forward.
python3 - "$targets" >"$work/joints.json" <<'PY'
import json, random, sys
random.seed(1)
n = (int(sys.argv[1]) + 1) // 2
joints = []
for _ in range(n):
    q = [round(random.uniform(-170, 170), 3) for _ in range(6)]
    q[4] = round(random.choice([-1, 1]) * random.uniform(20, 160), 3)
    joints.append(q)
print(json.dumps({"joints": joints}))
PY
curl -sf -H 'Content-Type: application/json' --data-binary @"$work/joints.json" "$url/v1/robots/ur5e:forward" >"$work/poses.json"
python3 - "$work/joints.json" "$work/poses.json" "$targets" >"$work/body.json" <<'PY'
import json, math, sys
joints = json.load(open(sys.argv[1]))["joints"]
poses = json.load(open(sys.argv[2]))["poses"]
n = int(sys.argv[3])
src, dat = ["DEF bench( )"], ["DEFDAT bench"]
for i in range(n):
    q, name = joints[i // 2], "XP%d" % i
    src.append("  PTP %s C_PTP" % name)
    if i % 2 == 0:
        dat.append("DECL E6AXIS %s={%s,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}" %
                   (name, ",".join("A%d %.3f" % (k + 1, v) for k, v in enumerate(q))))
        continue
    p = poses[i // 2]
    w, x, y, z = p["quaternion"]
    a = math.degrees(math.atan2(2 * (x * y + w * z), 1 - 2 * (y * y + z * z)))
    b = math.degrees(math.asin(max(-1.0, min(1.0, 2 * (w * y - x * z)))))
    c = math.degrees(math.atan2(2 * (y * z + w * x), 1 - 2 * (x * x + y * y)))
    x_mm, y_mm, z_mm = p["position_mm"]
    # No S and T: each Cartesian target is solved on the branch of the joint target before it.
    dat.append("DECL E6POS %s={X %.3f,Y %.3f,Z %.3f,A %.4f,B %.4f,C %.4f,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}" %
               (name, x_mm, y_mm, z_mm, a, b, c))
src.append("END")
dat.append("ENDDAT")
print(json.dumps({"files": {"bench.src": "\r\n".join(src) + "\r\n", "bench.dat": "\r\n".join(dat) + "\r\n"}}))
PY
echo "$(du -k "$work/body.json" | cut -f1) kB request, $targets targets"
for round in $(seq "$rounds"); do
  curl -sf -o "$work/reply.json" -w "round $round: %{time_total} s\n" -H 'Content-Type: application/json' \
    --data-binary @"$work/body.json" "$url/v1/campaigns/$campaign:compensate-program"
done
python3 -c 'import json,sys; s=json.load(open(sys.argv[1]))["summary"]; print("targets %d, rewritten %d, kept as written %d" % (s["targets"], s["rewritten"], s["failed"]))' "$work/reply.json"
echo "($(nproc) cores, server $server)"
