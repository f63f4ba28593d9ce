#!/usr/bin/env python3
"""The ISO 9283 pose test on real data (docs/iso9283.md, docs/real-data.md "ISO 9283 on the UR10").

The IPA UR10's Series D (tests/data/ipa) visits ISO 9283 cubes: each group of 9 rows is a cube's centre and its
eight corners. Each cube is one test: P1 its centre, P2-P5 the four corners on the measuring plane (the dataset
measured the corners themselves, not the points 10 % inside them). The cubes are visited once each, so every pose
has one cycle and the repeatability is not measurable: the report must say so (null, not 0).

Two robots run each test: the nominal UR10 and the UR10 registered from a calibration of 400 Series B poses
(seed 1). Series D was measured in another session with the tracker elsewhere, so each test campaign ties its
tracker to the base by a frames fit ("scope": "frames") on 30 Series D poses that are no test pose (corners off the
measuring planes, seed 1). The commands are each robot's model at the shot's joints: the nominal robot's is the
controller's own, the calibrated robot's the one a compensated controller aims at.

Prints AP per cube pose and the mean over all, nominal and calibrated; checks, exit 1 when a check fails:
  - every test's RP is reported as not measurable (null, with the note), never 0;
  - the calibrated robot's mean AP is below 0.8 times the nominal robot's.

Usage: ipa_iso9283.py URL DATA_DIR  (a running robocal-server; tests/realdata/ipa_iso9283.sh starts one)
"""
import math
import os
import random
import statistics
import sys

from ipa_data import FILE, JOINTS, Api, data_rows, number, read, shot

URL, DATA = sys.argv[1], sys.argv[2]
# ROBOCAL_REALDATA_QUICK (the sanitizer tree): a few cubes only, the bars printed but not checked.
QUICK = bool(os.environ.get("ROBOCAL_REALDATA_QUICK"))
api = Api(URL)
call = api.call


def test_shot(row, pose, cycle=1):
    return dict(shot(row), test_pose=pose, cycle=cycle)


TEXT_B, TEXT_D = read(DATA, "series_b_joint_configurations.csv"), read(DATA, "series_d_iso_cubes.csv")
api.register_ur10(DATA)

# The calibration: 400 Series B poses (seed 1), geometric, registered as a robot.
b_lines = [line for line, _ in data_rows(TEXT_B)]
random.Random(1).shuffle(b_lines)
fit_b = api.calibrate("b400", "ur10", TEXT_B, b_lines[:400])
call("POST", "/v1/robots", {"id": "ur10-b", "from_calibration": "b400"})
print(f"Series B, 400 poses: {fit_b['summary']['termination']}, model error "
      f"{fit_b['model_error']['model_error_mm']:.3f} mm")

# The cubes: groups of 9 rows, the centre first; each corner's side of the centre in the base frame from the
# nominal robot's forward kinematics of its joints.
rows_d = data_rows(TEXT_D)
groups = [rows_d[k:k + 9] for k in range(0, len(rows_d) - 8, 9)]
MEASURING_PLANE = {(-1, -1, 1): "P2", (-1, 1, 1): "P3", (1, 1, -1): "P4", (1, -1, -1): "P5"}
cubes, off_plane = [], []
for group in groups:
    joints = [[math.degrees(number(r[j])) for j in JOINTS] for _, r in group]
    tool = call("POST", "/v1/robots/ur10:forward", {"joints": joints})["poses"]
    centre = tool[0]["position_mm"]
    sides = [tuple(1 if p["position_mm"][a] > centre[a] else -1 for a in range(3)) for p in tool[1:]]
    if len(set(sides)) != 8:
        continue  # not a cube's centre and eight corners
    size = statistics.mean(abs(p["position_mm"][a] - centre[a]) * 2 for p in tool[1:] for a in range(3))
    test = [(group[0], "P1")]
    for (line, row), side in zip(group[1:], sides):
        if side in MEASURING_PLANE:
            test.append(((line, row), MEASURING_PLANE[side]))
        else:
            off_plane.append(line)
    cubes.append({"line": group[0][0], "size_mm": size, "test": test})
skipped = len(groups) - len(cubes)
frames_rows = sorted(random.Random(1).sample(off_plane, 30))
if QUICK:
    cubes = cubes[:3]
print(f"Series D: {len(cubes)} cubes ({skipped} groups not a centre and eight corners); frames fitted on 30 "
      f"off-plane corners")

results = {"ur10": [], "ur10-b": []}
rp_reported_zero = 0
for k, cube in enumerate(cubes):
    for robot in results:
        c = f"d{k}-{robot}"
        call("POST", "/v1/campaigns", {"id": c, "robot": robot})
        call("POST", f"/v1/campaigns/{c}/measurements:import",
             dict(FILE, text=TEXT_D, request_id=f"{c}-frames", role="calibration", rows=frames_rows))
        call("POST", f"/v1/campaigns/{c}:fit", {"scope": "frames"})
        call("POST", f"/v1/campaigns/{c}/measurements",
             {"request_id": f"{c}-test", "role": "test",
              "measurements": [test_shot(row, pose) for (_, row), pose in cube["test"]]})
        report = call("GET", f"/v1/campaigns/{c}/iso9283")
        for p in report["measured"]["poses"]:
            if p["rpl_mm"] is not None:
                rp_reported_zero += 1
            results[robot].append((k, p["pose"], p["ap_mm"]))
        if not any("not measurable" in n for n in report["notes"]):
            rp_reported_zero += 1

print(f"{'cube':>5} {'line':>5} {'edge':>7}  " + "  ".join(f"{p:>13}" for p in ("P1", "P2", "P3", "P4", "P5")))
print(f"{'':>5} {'':>5} {'mm':>7}  " + "  ".join(f"{'nominal/cal':>13}" for _ in range(5)))
ap = {robot: {(k, pose): v for k, pose, v in results[robot]} for robot in results}
for k, cube in enumerate(cubes):
    cells = []
    for pose in ("P1", "P2", "P3", "P4", "P5"):
        if (k, pose) in ap["ur10"]:
            cells.append(f"{ap['ur10'][(k, pose)]:6.3f}/{ap['ur10-b'][(k, pose)]:6.3f}")
        else:
            cells.append(f"{'-':>13}")
    print(f"{k:>5} {cube['line']:>5} {cube['size_mm']:7.1f}  " + "  ".join(cells))
nominal_mean = statistics.mean(v for _, _, v in results["ur10"])
calibrated_mean = statistics.mean(v for _, _, v in results["ur10-b"])
print(f"AP over {len(results['ur10'])} cube poses: nominal mean {nominal_mean:.3f} mm (max "
      f"{max(v for _, _, v in results['ur10']):.3f}), calibrated from Series B mean {calibrated_mean:.3f} mm (max "
      f"{max(v for _, _, v in results['ur10-b']):.3f}): {calibrated_mean / nominal_mean:.2f}x")
for edge in sorted({round(c["size_mm"] / 50) * 50 for c in cubes}):
    ks = {k for k, c in enumerate(cubes) if round(c["size_mm"] / 50) * 50 == edge}
    n = [v for k, _, v in results["ur10"] if k in ks]
    b = [v for k, _, v in results["ur10-b"] if k in ks]
    print(f"  cubes of about {edge} mm: {len(ks)}, AP mean nominal {statistics.mean(n):.3f} mm, calibrated "
          f"{statistics.mean(b):.3f} mm")

failures = []
if rp_reported_zero:
    failures.append(f"{rp_reported_zero} poses or reports gave a repeatability from one cycle")
if not QUICK and not calibrated_mean < 0.8 * nominal_mean:
    failures.append(f"calibrated mean AP {calibrated_mean:.3f} mm is not below 0.8 x nominal {nominal_mean:.3f} mm")
for f in failures:
    print("FAIL:", f)
sys.exit(1 if failures else 0)
