#!/usr/bin/env python3
"""Drift checks on real data (docs/drift.md, "Measured on the IPA UR10").

The IPA UR10 (tests/data/ipa) calibrated from 400 Series B poses (seed 1, geometric) and registered as a robot. Then
checks of 12 poses each, at the stated false alarm rate of 5 %:
  - unchanged, same session: random sets of Series B's other poses, the frames kept (the tracker stayed) and
    registered on the check;
  - unchanged, another session: random sets of Series D's poses (the tracker elsewhere), frames registered;
  - re-mastered: the same Series B sets with 0.05 deg added to one joint's reported angle, for each joint.

  - Series D calibrated in its own session (200 of its poses) and checked on its others; and Series B's calibration
    checked on Series D, where it holds less well (docs/real-data.md: 0.50 mm held out there against 0.40 mm in
    its own session): reported, not held to the false alarm bar.

Prints the rates and checks, exit 1 when a check fails:
  - false alarms of a calibration checked in its own session at most 2x the stated 5 %;
  - a 0.05 deg offset on any one joint found in at least 90 % of 40 sets (95 %, less the spread of 40) and named (its offset the first
    suspect) in at least 80 %, frames kept; with frames registered, for joints 2 and 3 (a joint 1 offset is a turn
    of the base, a joint 6 offset one of the tool about its axis, which a registration takes up; the wrist's is
    reported).

Usage: ipa_drift.py URL DATA_DIR  (a running robocal-server; tests/realdata/ipa_drift.sh starts one)
"""
import json
import math
import os
import random
import sys
import urllib.error
import urllib.request

URL, DATA = sys.argv[1], sys.argv[2]
# ROBOCAL_REALDATA_QUICK (the sanitizer tree): a few sets, the bars printed but not checked.
QUICK = bool(os.environ.get("ROBOCAL_REALDATA_QUICK"))
SETS = 4 if QUICK else 100
# The offsets' sets (ROBOCAL_DRIFT_OFFSET_SETS: more for a closer figure; 40 keep the ctest short).
OFFSET_SETS = 2 if QUICK else int(os.environ.get("ROBOCAL_DRIFT_OFFSET_SETS", "40"))
SIZE, OFFSET_DEG, RATE = 12, 0.05, 0.05
JOINTS = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
          "wrist_3_joint"]


def call(method, path, body=None):
    data = None if body is None else json.dumps(body).encode()
    request = urllib.request.Request(URL + path, data=data, method=method,
                                     headers={"Content-Type": "application/json"})
    try:
        with urllib.request.urlopen(request, timeout=600) as reply:
            return json.loads(reply.read())
    except urllib.error.HTTPError as e:
        sys.exit(f"{method} {path}: {e.code} {e.read().decode()[:2000]}")


def read(name):
    with open(f"{DATA}/ipa/{name}", encoding="utf-8") as f:
        return f.read()


def data_rows(text):
    lines = text.split("\n")
    header = next(i for i, line in enumerate(lines) if line.strip())
    names = lines[header].strip().split(";")
    return [(i + 1, dict(zip(names, lines[i].strip().split(";"))))
            for i in range(header + 1, len(lines)) if lines[i].strip()]


def number(text):
    return float(text.replace(",", "."))


def quaternion_xyz_intrinsic(a_deg, b_deg, c_deg):
    """[w, x, y, z] of R = Rx(a) Ry(b) Rz(c)."""
    def axis(k, angle):
        q = [math.cos(math.radians(angle) / 2), 0.0, 0.0, 0.0]
        q[1 + k] = math.sin(math.radians(angle) / 2)
        return q

    def mul(p, q):
        return [p[0] * q[0] - p[1] * q[1] - p[2] * q[2] - p[3] * q[3],
                p[0] * q[1] + p[1] * q[0] + p[2] * q[3] - p[3] * q[2],
                p[0] * q[2] - p[1] * q[3] + p[2] * q[0] + p[3] * q[1],
                p[0] * q[3] + p[1] * q[2] - p[2] * q[1] + p[3] * q[0]]
    return mul(mul(axis(0, a_deg), axis(1, b_deg)), axis(2, c_deg))


def shot(row, joint=None, offset_deg=0.0):
    joints = [math.degrees(number(row[j])) for j in JOINTS]
    if joint is not None:
        joints[joint] += offset_deg
    return {"joints": joints,
            "pose": {"position_mm": [number(row[f"measurement_{a}"]) for a in "xyz"],
                     "quaternion": quaternion_xyz_intrinsic(*[number(row[f"measurement_r{a}"]) for a in "xyz"])}}


TEXT_B, TEXT_D = read("series_b_joint_configurations.csv"), read("series_d_iso_cubes.csv")
FILE = {"format": "csv", "unit": "mm", "decimal": ",",
        "columns": {"x": "measurement_x", "y": "measurement_y", "z": "measurement_z"},
        "joints": {"columns": JOINTS, "unit": "rad"},
        "orientation": {"representation": "euler", "columns": ["measurement_rx", "measurement_ry", "measurement_rz"],
                        "sequence": "XYZ", "convention": "intrinsic", "unit": "deg"}}
with open(f"{DATA}/urdf/ur10_robot.urdf", encoding="utf-8") as f:
    call("POST", "/v1/robots", {"id": "ur10", "urdf": f.read(), "base_link": "base_link", "tip_link": "tool0",
                                "tool": {"position_mm": [0, 0, 109], "rpy_deg": [0, 0, -90]}})
rows_b = data_rows(TEXT_B)
order = [line for line, _ in rows_b]
random.Random(1).shuffle(order)
calibration = set(order[:400])
call("POST", "/v1/campaigns", {"id": "b400", "robot": "ur10"})
call("POST", "/v1/campaigns/b400/measurements:import",
     dict(FILE, text=TEXT_B, request_id="b400", role="calibration", rows=sorted(calibration)))
fit = call("POST", "/v1/campaigns/b400:fit", {})
call("POST", "/v1/robots", {"id": "ur10-b", "from_calibration": "b400"})
print(f"Series B, 400 poses: {fit['summary']['termination']}, model error {fit['model_error']['model_error_mm']:.3f} mm"
      f" / {fit['model_error']['model_error_deg']:.4f} deg")
held_out = [row for line, row in rows_b if line not in calibration]
# Series D calibrated in its own session: 200 of its poses (seed 1), the rest for checks.
rows_d_lines = data_rows(TEXT_D)
order_d = [line for line, _ in rows_d_lines]
random.Random(1).shuffle(order_d)
calibration_d = set(order_d[:200])
call("POST", "/v1/campaigns", {"id": "d200", "robot": "ur10"})
call("POST", "/v1/campaigns/d200/measurements:import",
     dict(FILE, text=TEXT_D, request_id="d200", role="calibration", rows=sorted(calibration_d)))
call("POST", "/v1/campaigns/d200:fit", {})
call("POST", "/v1/robots", {"id": "ur10-d", "from_calibration": "d200"})
rows_d = [row for line, row in rows_d_lines]
held_out_d = [row for line, row in rows_d_lines if line not in calibration_d]


def check(rows, frames, joint=None, robot="ur10-b"):
    return call("POST", f"/v1/robots/{robot}:check",
                {"measurements": [shot(r, joint, OFFSET_DEG) for r in rows], "frames": frames,
                 "false_alarm_rate": RATE})


failures = []
rng = random.Random(7)
b_sets = [rng.sample(held_out, SIZE) for _ in range(SETS)]
d_sets = [rng.sample(rows_d, SIZE) for _ in range(SETS)]
d_own_sets = [rng.sample(held_out_d, SIZE) for _ in range(SETS)]
print(f"{SETS} random sets of {SIZE} poses, stated false alarm rate {RATE:.0%}:")
for label, sets, frames, robot, bar in (
        ("B's calibration on Series B (same session), frames kept", b_sets, "keep", "ur10-b", True),
        ("B's calibration on Series B (same session), frames registered", b_sets, "register", "ur10-b", True),
        ("D's calibration on Series D (same session), frames kept", d_own_sets, "keep", "ur10-d", True),
        ("D's calibration on Series D (same session), frames registered", d_own_sets, "register", "ur10-d", True),
        ("B's calibration on Series D (another session), frames registered", d_sets, "register", "ur10-b", False)):
    replies = [check(s, frames, robot=robot) for s in sets]
    alarms = sum(r["verdict"] == "drifted" for r in replies)
    level = sum(r["statistic"] > r["threshold"] for r in replies)
    single = sum(r["largest_drop"] > r["drop_threshold"] for r in replies)
    rms = sorted(r["rms_position_mm"] for r in replies)[len(replies) // 2]
    print(f"  {label}: {alarms} drifted ({alarms / len(sets):.0%}; level test {level}, one-parameter test {single}); "
          f"median RMS {rms:.3f} mm, expected {replies[0]['expected_rms_position_mm']:.3f} mm")
    if not QUICK and bar and alarms > 2 * RATE * len(sets):
        failures.append(f"{label}: false alarms {alarms} of {len(sets)}, above twice {RATE:.0%}")

robot = call("GET", "/v1/robots/ur10-b")
print(f"a {OFFSET_DEG} deg offset on one joint, {OFFSET_SETS} of the Series B sets:")
for frames in ("keep", "register"):
    for j, joint in enumerate(JOINTS):
        replies = [check(s, frames, j) for s in b_sets[:OFFSET_SETS]]
        found = sum(r["verdict"] == "drifted" for r in replies)
        named = sum(bool(r["suspects"]) and r["suspects"][0]["parameter"] == f"{joint}.rz" for r in replies)
        others = sorted({r["suspects"][0]["parameter"] for r in replies
                         if r["suspects"] and r["suspects"][0]["parameter"] != f"{joint}.rz"})
        changes = [r["suspects"][0]["change"] for r in replies
                   if r["suspects"] and r["suspects"][0]["parameter"] == f"{joint}.rz"]
        change = f", change {sum(changes) / len(changes):+.4f} deg" if changes else ""
        print(f"  frames {frames:8} joint {j + 1}: found {found}/{len(replies)}, named {named}{change}"
              + (f" (else {', '.join(others)})" if others else ""))
        # With the frames registered a joint 1 offset is a turn of the base and a joint 6 offset one of the tool
        # about its axis: no check sees them. The wrist's 0.05 deg (joints 4 and 5) is of the orientation's own model
        # error (0.05 deg RMS), beyond 12 poses beside a registration: reported, not held to the bar.
        held = frames == "keep" or j in (1, 2)
        if not QUICK and held:
            # 95 % found, less the sampling spread of 40 sets (36 of 40 or more: 5 % of the time below at 95 %).
            if found < 0.9 * len(replies):
                failures.append(f"frames {frames}, joint {j + 1}: found in {found} of {len(replies)}")
            if named < 0.8 * len(replies):
                failures.append(f"frames {frames}, joint {j + 1}: named in {named} of {len(replies)}")

for f in failures:
    print("FAIL:", f)
sys.exit(1 if failures else 0)
