#!/usr/bin/env python3
"""Plans from a cell's own poses on real data (docs/planning.md, "Plans from the cell's own configurations").

The IPA UR10's Series B (tests/data/ipa): its poses split at random (seed 1) into 700 candidates and 700 held-out
poses. For N = 12, 15, 30 and 40, sets of N candidates are chosen by the planner (log_det and predicted_error by
the exchange optimiser, the task being the candidates' joints; condition_number by the paper's Solis & Wets; seeds
1-5, their median held-out error the planner's figure) and at random (30 draws, the planner's random selection from
the same candidates), each calibrated through the API (a
6-D geometric fit of the tracker's measurements at the chosen poses) and judged on the held-out poses (mean
position error, E_xyz). Then "num_configurations": "auto" with a goal 10 % above the held-out mean of the fit of
all 700 candidates, planned on the robot registered from that fit (which carries its model error).

Prints the figures and checks, exit 1 when a check fails:
  - N = 12 and 15: the log_det and predicted_error plans beat at least 90 % of the random draws;
  - N = 30 and 40: neither is worse than the random draws' median by more than 3 %;
  - auto: the N it picks meets the goal on the held-out poses.

Usage: ipa_planning.py URL DATA_DIR  (a running robocal-server; tests/realdata/ipa_planning.sh starts one)
"""
import os
import random
import statistics
import sys

import ipa_data
from ipa_data import Api, data_rows, read

URL, DATA = sys.argv[1], sys.argv[2]
# ROBOCAL_REALDATA_QUICK (the sanitizer tree, where each fit is some times slower): every path once, with too few
# draws for the bars, which are then printed but not checked.
QUICK = bool(os.environ.get("ROBOCAL_REALDATA_QUICK"))
SIZES = [12] if QUICK else [12, 15, 30, 40]
DRAWS = 3 if QUICK else 30
PLAN_SEEDS = 1 if QUICK else 5
PRIOR_SIZES, PRIOR_DRAWS = ((20,), 2) if QUICK else ((20, 30, 100), 10)
api = Api(URL)
call = api.call
TEXT = read(DATA, "series_b_joint_configurations.csv")
order = [line for line, _ in data_rows(TEXT)]
random.Random(1).shuffle(order)
CANDIDATES, HELD_OUT = sorted(order[:700]), sorted(order[700:1400])
FILE = dict(ipa_data.FILE, text=TEXT)
api.register_ur10(DATA)

serial = 0


def held_out_mean(lines, robot="ur10"):
    """Calibrates from the tracker's measurements at `lines`: the campaign, the fit, its held-out E_xyz mean (and
    the evaluation as held_out_mean.last)."""
    global serial
    serial += 1
    c = f"c{serial}"
    call("POST", "/v1/campaigns", {"id": c, "robot": robot, "measurement_type": "pose", "tracker": {}})
    for role, rows in (("calibration", lines), ("validation", HELD_OUT)):
        call("POST", f"/v1/campaigns/{c}/measurements:import",
             dict(FILE, request_id=f"{c}-{role}", role=role, rows=sorted(rows)))
    fit = call("POST", f"/v1/campaigns/{c}:fit", {})
    evaluation = call("POST", f"/v1/campaigns/{c}:evaluate", {})
    held_out_mean.last = evaluation["calibrated"]["e_xyz_mm"]
    return c, fit, evaluation["calibrated"]["e_xyz_mm"]["mean"]


def plan(n, objective, optimiser, seed=1, robot="ur10", extra=None):
    body = {"robot": robot, "num_configurations": n, "measurement_type": "pose", "tracker": {}, "seed": seed,
            "objective": objective, "optimiser": optimiser,
            "candidates": {"file": dict(FILE, rows=CANDIDATES)}}
    if objective == "predicted_error":
        body["task"] = {"joints": TASK}
    body.update(extra or {})
    return call("POST", "/v1/plans", body)


# The task: the candidates' joints (where the cell works), as a plan from them reports them.
probe = call("POST", "/v1/plans", {"robot": "ur10", "num_configurations": 6, "measurement_type": "pose",
                                   "tracker": {}, "optimiser": "random", "objective": "log_det",
                                   "candidates": {"file": dict(FILE, rows=CANDIDATES)}})
print(f"{probe['candidates']['num_usable']} of {probe['candidates']['num_candidates']} candidates usable "
      f"(of {len(CANDIDATES)} rows: shots of one pose count once); {len(HELD_OUT)} held-out rows")
# Joint vectors of the candidates, read back as planned configurations of a plan of all of them.
everything = call("POST", "/v1/plans", {"robot": "ur10", "num_configurations": probe["candidates"]["num_usable"],
                                         "measurement_type": "pose", "tracker": {}, "optimiser": "random",
                                         "objective": "log_det", "num_validation": 1,
                                         "candidates": {"file": dict(FILE, rows=CANDIDATES)}})
TASK = everything["configurations"][::7]  # every 7th: 100 task poses

failures = 0


def check(name, ok):
    global failures
    if QUICK:
        print(("(ok)   " if ok else "(miss) ") + name + " [quick: not checked]")
        return
    print(("ok   " if ok else "FAIL ") + name)
    failures += 0 if ok else 1


for n in SIZES:
    randoms = []
    for seed in range(1, DRAWS + 1):
        drawn = plan(n, "log_det", "random", seed=seed)
        randoms.append(held_out_mean(drawn["candidate_lines"])[2])
    median = statistics.median(randoms)
    line = f"N {n:3d}: random median {median:.4f} mm (min {min(randoms):.4f}, max {max(randoms):.4f})"
    for objective, optimiser in (("log_det", "exchange"), ("predicted_error", "exchange"),
                                 ("condition_number", "solis_wets")):
        # A plan is one set, and one set's held-out error scatters with the poses it happens to take: the median of
        # the plans of seeds 1-5 (each the optimiser's own start) is the planner's figure.
        planned = [held_out_mean(plan(n, objective, optimiser, seed=seed)["candidate_lines"])[2]
                   for seed in range(1, PLAN_SEEDS + 1)]
        mean = statistics.median(planned)
        beaten = sum(r > mean for r in randoms) / len(randoms)
        line += (f"; {objective} {mean:.4f} mm ({mean / median:.3f} x median, beats {100 * beaten:.0f} %; seeds "
                 + " ".join(f"{x:.3f}" for x in planned) + ")")
        if objective == "condition_number":
            continue
        if n <= 15 and (objective == "predicted_error" or n == 12):
            check(f"N {n}: {objective} beats at least 90 % of {DRAWS} random draws ({100 * beaten:.0f} %)",
                  beaten >= 0.9)
        elif n <= 15:
            # log_det at 15 poses: its sets split between as good as predicted_error's and no better than random
            # (docs/planning.md, "Measured on the IPA UR10"); reported, not held to the 90 % bar.
            print(f"note N {n}: {objective} beats {100 * beaten:.0f} % of {DRAWS} random draws")
        else:
            check(f"N {n}: {objective} within 3 % of the random median ({mean / median:.3f})", mean <= 1.03 * median)
    print(line)

# How many poses: a goal 10 % above what all 700 candidates give, on the robot that fit calibrated (its model error
# is where the prediction flattens).
c_all, fit_all, mean_all = held_out_mean(CANDIDATES)
call("POST", "/v1/robots", {"id": "ur10-all", "from_calibration": c_all})
goal = 1.1 * mean_all
# No task: the candidates are where the cell works.
auto = plan("auto", "log_det", "exchange", robot="ur10-all",
            extra={"accuracy_goal_mm": goal, "min_configurations": 6, "max_configurations": 120})
curve = auto["pose_count"]
chosen = curve["chosen"]
mean_auto = held_out_mean(auto["candidate_lines"])[2]
# The smallest N whose prediction reaches the goal sits at the goal by construction: its held-out mean is judged
# within the mean's own standard error over the held-out poses.
stats = held_out_mean.last
standard_error = stats["std"] / stats["count"] ** 0.5
points = {p["num_configurations"]: p["predicted_mean_mm"] for p in curve["points"]}
print(f"all 700 candidates: held-out mean {mean_all:.4f} mm, model error {fit_all['model_error']['model_error_mm']:.4f}"
      f" mm; goal {goal:.4f} mm: auto chose N = {chosen} (predicted {points.get(chosen)}), held out {mean_auto:.4f} mm")
print("  predicted mean error against N: " + ", ".join(f"{n}: {e:.3f}" for n, e in sorted(points.items())
                                                  if e is not None and (n % 6 == 0 or n == chosen)))
check(f"auto: N = {chosen} meets the goal on the held-out poses ({mean_auto:.4f} <= {goal:.4f} mm, standard error "
      f"{standard_error:.4f} mm)", chosen is not None and mean_auto <= goal + standard_error)
# Parameter priors with few poses: N poses drawn at random from the candidates (seeds 1-10), fitted without priors
# and with "priors": "auto", both judged on the held-out poses.
for n in PRIOR_SIZES:
    plain, auto_priors = [], []
    for seed in range(1, PRIOR_DRAWS + 1):
        lines = random.Random(100 + seed).sample(CANDIDATES, n)
        plain.append(held_out_mean(lines)[2])
        c = f"p{n}-{seed}"
        call("POST", "/v1/campaigns", {"id": c, "robot": "ur10", "measurement_type": "pose", "tracker": {}})
        for role, rows in (("calibration", lines), ("validation", HELD_OUT)):
            call("POST", f"/v1/campaigns/{c}/measurements:import",
                 dict(FILE, request_id=f"{c}-{role}", role=role, rows=sorted(rows)))
        fit = call("POST", f"/v1/campaigns/{c}:fit", {"priors": "auto"})
        auto_priors.append(call("POST", f"/v1/campaigns/{c}:evaluate", {})["calibrated"]["e_xyz_mm"]["mean"])
    without, with_priors = statistics.mean(plain), statistics.mean(auto_priors)
    change = 100.0 * (with_priors / without - 1.0)
    print(f"priors N {n:3d}: held-out mean without {without:.4f} mm, priors auto {with_priors:.4f} mm ({change:+.1f} %);"
          " draws " + " ".join(f"{a:.3f}/{b:.3f}" for a, b in zip(plain, auto_priors)))
    check(f"priors N {n}: auto no worse than without on the held-out mean ({change:+.1f} %)",
          with_priors <= without * 1.0005)
    if n == 20:
        check(f"priors N 20: auto at least 3 % better ({change:+.1f} %)", change <= -3.0)

print(f"{failures} check(s) failed" if failures else "all checks passed")
sys.exit(1 if failures else 0)
