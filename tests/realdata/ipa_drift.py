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
import os
import random
import sys

from ipa_data import JOINTS, Api, data_rows, read, shot

URL, DATA = sys.argv[1], sys.argv[2]
# ROBOCAL_REALDATA_QUICK (the sanitizer tree): a few sets, the bars printed but not checked.
QUICK = bool(os.environ.get("ROBOCAL_REALDATA_QUICK"))
SETS = 4 if QUICK else 100
# The offsets' sets (ROBOCAL_DRIFT_OFFSET_SETS: more for a closer figure; 40 keep the ctest short).
OFFSET_SETS = 2 if QUICK else int(os.environ.get("ROBOCAL_DRIFT_OFFSET_SETS", "40"))
SIZE, OFFSET_DEG, RATE = 12, 0.05, 0.05
api = Api(URL)
call = api.call


TEXT_B, TEXT_D = read(DATA, "series_b_joint_configurations.csv"), read(DATA, "series_d_iso_cubes.csv")
api.register_ur10(DATA)
rows_b = data_rows(TEXT_B)
order = [line for line, _ in rows_b]
random.Random(1).shuffle(order)
calibration = set(order[:400])
fit = api.calibrate("b400", "ur10", TEXT_B, calibration)
call("POST", "/v1/robots", {"id": "ur10-b", "from_calibration": "b400"})
print(f"Series B, 400 poses: {fit['summary']['termination']}, model error {fit['model_error']['model_error_mm']:.3f} mm"
      f" / {fit['model_error']['model_error_deg']:.4f} deg")
held_out = [row for line, row in rows_b if line not in calibration]
# Series D calibrated in its own session: 200 of its poses (seed 1), the rest for checks.
rows_d_lines = data_rows(TEXT_D)
order_d = [line for line, _ in rows_d_lines]
random.Random(1).shuffle(order_d)
calibration_d = set(order_d[:200])
api.calibrate("d200", "ur10", TEXT_D, calibration_d)
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
