#!/usr/bin/env python3
"""A reference timing for docs/identification.md, "Measured cost": a plain Levenberg-Marquardt fit of the IPA
UR10's Series B (tests/data/ipa, real laser-tracker poses) with numpy/scipy, to compare robocal's own fit speed against.
It is the textbook fit only: no robust rounds, no model error estimate, no studentised residuals, no covariance.

Usage: python3 tests/bench/ipa_scipy_fit.py [--repeats 5] [--seed 1]
For N = 100 and 400 calibration rows drawn at random (the other rows held out) it times, from the same start each
time, the registration and the fit, and prints the median and minimum time, the evaluations, the RMS position
residual of the N poses and the mean position error of the held-out rows.

Model (mm, rad): T_tracker_tool(q) = T_reg C_base prod_j [O_j E_j Rot(a_j, q_j)] O_tool0 T_flange_tool E_tool,
O_j the URDF joint origins, T_reg the closed-form (Kabsch) registration of the nominal tool points onto the
measured ones, and C_base, E_1..E_6, E_tool error transforms Trans(dx, dy, dz) Rx(a) Ry(b) Rz(c), 48 numbers.
Only 30 are identifiable (4 per revolute joint + 6). This script fits a minimal set of 30 by dropping exactly
redundant parameters: E_1 whole (only the constant O_1 separates it from C_base), and, for every joint j, the
rotation about and translation along its axis a_j from the NEXT error transform (E_j+1, or E_tool after joint 6),
where a_j reads as one coordinate axis of that transform's frame; those two motions commute with Rot(a_j, q_j),
so the same freedom stays in the transform before the joint (e.g. E_j's rotation about a_j is joint j's offset).
"""
import argparse
import os
import sys
import time
import xml.etree.ElementTree as ET

# One process, one BLAS thread (set before numpy loads); numpy/scipy are Debian's, so a pyenv python3 without them
# hands over to the system interpreter.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
try:
    import numpy as np
    import scipy
    from scipy.optimize import least_squares
    from scipy.spatial.transform import Rotation
except ImportError:
    if os.path.exists("/usr/bin/python3") and os.path.realpath(sys.executable) != os.path.realpath("/usr/bin/python3"):
        os.execv("/usr/bin/python3", ["/usr/bin/python3"] + sys.argv)
    sys.exit("needs numpy and scipy (Debian: apt-get install python3-numpy python3-scipy)")

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "data")
sys.path.insert(0, os.path.join(HERE, "..", "realdata"))
import ipa_data  # noqa: E402  (the project's reader of the IPA files)

SIGMA_POSITION_MM = 0.05                  # 1-sigma per position row (tracker + repeatability, datasheet-like)
SIGMA_ORIENTATION_RAD = np.radians(0.01)  # 1-sigma per orientation row (T-Mac, 0.01 deg)
TOLERANCE = 1e-8                          # scipy's default ftol = xtol = gtol


def frame(R=np.eye(3), p=(0.0, 0.0, 0.0)):
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    return T


def error_transform(e):
    """Trans(dx, dy, dz) Rx(a) Ry(b) Rz(c) of e = (dx, dy, dz, a, b, c)."""
    return frame(Rotation.from_euler("XYZ", e[3:]).as_matrix(), e[:3])  # upper case, intrinsic: Rx Ry Rz


def read_urdf(path, base="base_link", tip="tool0"):
    """[(O_j, a_j)] of the revolute joints from base to tip (fixed joints folded into the next origin) and the
    fixed transform after the last one; lengths in mm."""
    by_child = {j.find("child").get("link"): j for j in ET.parse(path).getroot().findall("joint")}
    path_joints, link = [], tip
    while link != base:
        path_joints.append(by_child[link])
        link = path_joints[-1].find("parent").get("link")
    joints, pending = [], np.eye(4)
    for j in reversed(path_joints):
        o = j.find("origin")
        rpy = [float(v) for v in o.get("rpy", "0 0 0").split()]
        xyz = [1000.0 * float(v) for v in o.get("xyz", "0 0 0").split()]
        pending = pending @ frame(Rotation.from_euler("xyz", rpy).as_matrix(), xyz)  # fixed axes: Rz Ry Rx
        if j.get("type") != "fixed":
            axis = np.array([float(v) for v in j.find("axis").get("xyz").split()])
            joints.append((pending, axis / np.linalg.norm(axis)))
            pending = np.eye(4)
    return joints, pending


def read_series_b():
    """Joints (rad), measured positions (mm) and rotations of every row of Series B."""
    rows = [r for _, r in ipa_data.data_rows(ipa_data.read(DATA, "series_b_joint_configurations.csv"))]
    q = np.array([[ipa_data.number(r[j]) for j in ipa_data.JOINTS] for r in rows])
    p = np.array([[ipa_data.number(r[f"measurement_{a}"]) for a in "xyz"] for r in rows])
    euler = np.array([[ipa_data.number(r[f"measurement_r{a}"]) for a in "xyz"] for r in rows])
    return q, p, Rotation.from_euler("XYZ", euler, degrees=True).as_matrix()  # upper case: intrinsic X-Y-Z


class Ur10Model:
    def __init__(self, joints, tail):
        self.origins = [o for o, _ in joints]
        self.axes = [a for _, a in joints]
        self.tail = tail @ frame(Rotation.from_euler("z", -90, degrees=True).as_matrix(), (0, 0, 109))
        # Free parameters over the 8 error transforms (C_base, E_1..E_6, E_tool) x 6: see the module docstring.
        free = np.ones((8, 6), bool)
        free[1] = False
        for j, axis in enumerate(self.axes):
            nxt = self.origins[j + 1] if j + 1 < len(self.axes) else self.tail
            local = nxt[:3, :3].T @ axis  # a_j in the next error transform's frame
            k = int(np.argmax(abs(local)))
            assert abs(abs(local[k]) - 1) < 1e-6, "joint axis not along a coordinate axis of the next frame"
            free[j + 2, [k, 3 + k]] = False
        self.free = free.ravel()

    def poses(self, x, q, T_reg):
        """Tool poses (n, 4, 4) for the free parameters x, and per error transform the world frame before it."""
        e = np.zeros(48)
        e[self.free] = x
        e = e.reshape(8, 6)
        T = np.broadcast_to(T_reg, (len(q), 4, 4))
        before = [T]
        T = T @ error_transform(e[0])
        for j, (origin, axis) in enumerate(zip(self.origins, self.axes)):
            T = T @ origin
            before.append(T)
            T = T @ error_transform(e[j + 1]) @ frame_stack(Rotation.from_rotvec(np.outer(q[:, j], axis)).as_matrix())
        T = T @ self.tail
        before.append(T)
        return T @ error_transform(e[7]), before, e

    def residuals(self, x, q, p_meas, R_meas, T_reg):
        T = self.poses(x, q, T_reg)[0]
        return stack_rows(p_meas - T[:, :3, 3], rotvec(R_meas @ T[:, :3, :3].transpose(0, 2, 1)))

    def jacobian(self, x, q, p_meas, R_meas, T_reg, all_parameters=False):
        """Analytic d residuals / d parameters (exact at x, not only at 0): per error transform, its translations
        move the tool by R_F e_i, its angles turn it about the transform's origin with world rate w."""
        T, before, e = self.poses(x, q, T_reg)
        p_tool = T[:, :3, 3]
        phi = rotvec(R_meas @ T[:, :3, :3].transpose(0, 2, 1))
        Jr_inv = right_jacobian_inverse(phi)
        columns = []
        for F, (d, angles) in zip(before, ((ei[:3], ei[3:]) for ei in e)):
            R_F = F[:, :3, :3]
            for i in range(3):
                columns.append((R_F[:, :, i], np.zeros_like(p_tool)))
            p_E = F[:, :3, 3] + R_F @ d
            partial = [np.eye(3), Rotation.from_euler("X", angles[0]).as_matrix(),
                       Rotation.from_euler("XY", angles[:2]).as_matrix()]
            for i in range(3):
                w = R_F @ partial[i][:, i]  # Rx(a) Ry(b) Rz(c): each angle's axis after the ones before it
                columns.append((np.cross(w, p_tool - p_E), w))
        if not all_parameters:
            columns = [c for c, keep in zip(columns, self.free) if keep]
        # residual = measured - model; orientation d log(R_m R^T) = -Jr^-1(phi) w
        return np.stack([stack_rows(-dp, -np.einsum("nij,nj->ni", Jr_inv, w)) for dp, w in columns], axis=1)


def frame_stack(R):
    T = np.zeros((len(R), 4, 4))
    T[:, :3, :3], T[:, 3, 3] = R, 1.0
    return T


def rotvec(R):
    return Rotation.from_matrix(R).as_rotvec()


def stack_rows(dp, dphi):
    """Weighted residual rows, pose by pose: 3 position (mm / sigma), 3 orientation (rad / sigma)."""
    return np.hstack([dp / SIGMA_POSITION_MM, dphi / SIGMA_ORIENTATION_RAD]).ravel()


def right_jacobian_inverse(phi):
    """Jr^-1(phi) (n, 3, 3): log(exp(phi) exp(d)) = phi + Jr^-1(phi) d to first order."""
    theta = np.maximum(np.linalg.norm(phi, axis=1), 1e-12)[:, None, None]
    K = np.zeros((len(phi), 3, 3))  # [phi]x
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -phi[:, 2], phi[:, 1], -phi[:, 0]
    K -= K.transpose(0, 2, 1)
    c = 1 / theta**2 - (1 + np.cos(theta)) / (2 * theta * np.sin(theta))
    return np.eye(3) + 0.5 * K + c * (K @ K)


def register(model, q, p_meas):
    """Kabsch: the rigid motion taking the nominal tool points onto the measured ones."""
    p_nom = model.poses(np.zeros(30), q, np.eye(4))[0][:, :3, 3]
    a, b = p_nom - p_nom.mean(0), p_meas - p_meas.mean(0)
    U, _, Vt = np.linalg.svd(a.T @ b)
    D = np.diag([1, 1, np.sign(np.linalg.det(Vt.T @ U.T))])
    R = Vt.T @ D @ U.T
    return frame(R, p_meas.mean(0) - R @ p_nom.mean(0))


def fit(model, q, p, R):
    T_reg = register(model, q, p)
    result = least_squares(model.residuals, np.zeros(30), jac=model.jacobian, method="lm", x_scale="jac",
                           ftol=TOLERANCE, xtol=TOLERANCE, gtol=TOLERANCE, args=(q, p, R, T_reg))
    return result, T_reg


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    model = Ur10Model(*read_urdf(os.path.join(DATA, "urdf", "ur10_robot.urdf")))
    q_all, p_all, R_all = read_series_b()
    rng = np.random.default_rng(args.seed)
    print(f"numpy {np.__version__}, scipy {scipy.__version__}, python {sys.version.split()[0]}; one process, "
          f"OPENBLAS_NUM_THREADS={os.environ['OPENBLAS_NUM_THREADS']}; Series B {len(q_all)} rows, seed {args.seed}")
    print(f"least_squares(method='lm', analytic Jacobian, x_scale='jac', ftol=xtol=gtol={TOLERANCE:g}); "
          f"{model.free.sum()} of 48 parameters; rows weighted 1/{SIGMA_POSITION_MM} mm, 1/0.01 deg")
    for n in (100, 400):
        rows = rng.permutation(len(q_all))
        cal, held = np.sort(rows[:n]), np.sort(rows[n:])
        data = (q_all[cal], p_all[cal], R_all[cal])
        T_reg = register(model, data[0], data[1])
        J_all = model.jacobian(np.zeros(30), *data, T_reg, all_parameters=True)
        J = J_all[:, model.free]
        s = np.linalg.svd(J / np.linalg.norm(J, axis=0), compute_uv=False)
        rank_all = np.linalg.matrix_rank(J_all / np.linalg.norm(J_all, axis=0))
        x_test = np.random.default_rng(0).normal(0, 1e-3, 30)
        numeric = np.stack([(model.residuals(x_test + h, *data, T_reg) - model.residuals(x_test - h, *data, T_reg))
                            / 2e-7 for h in 1e-7 * np.eye(30)], axis=1)
        analytic = model.jacobian(x_test, *data, T_reg)
        wall, cpu = [], []
        for _ in range(args.repeats):
            t0, c0 = time.perf_counter(), time.process_time()
            result, T_reg = fit(model, *data)
            wall.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
        dp_cal = p_all[cal] - model.poses(result.x, q_all[cal], T_reg)[0][:, :3, 3]
        dp_held = p_all[held] - model.poses(result.x, q_all[held], T_reg)[0][:, :3, 3]
        rows_cal = result.fun.reshape(-1, 6)
        print(f"\nN = {n} calibration rows, {len(held)} held out")
        print(f"  Jacobian: rank {rank_all} of 48 with every parameter; the 30 kept: condition {s[0] / s[-1]:.3g} "
              f"(unit columns); analytic vs central differences: max |diff| {abs(analytic - numeric).max():.2g} "
              f"(max |J| {abs(analytic).max():.3g})")
        print(f"  fit (registration + LM), {args.repeats} runs: wall median {1e3 * np.median(wall):.1f} ms, "
              f"min {1e3 * min(wall):.1f} ms; CPU median {1e3 * np.median(cpu):.1f} ms")
        print(f"  {result.nfev} residual and {result.njev} Jacobian evaluations; status {result.status} "
              f"({result.message})")
        print(f"  cost 0.5|r|^2 {result.cost:.1f}, sigma_hat {np.sqrt(2 * result.cost / (6 * n - 30)):.2f}; "
              f"calibration RMS position {np.sqrt((dp_cal**2).sum(1).mean()):.3f} mm, orientation "
              f"{np.degrees(np.sqrt((rows_cal[:, 3:] ** 2).sum(1).mean()) * SIGMA_ORIENTATION_RAD):.4f} deg")
        print(f"  held out: mean position error {np.linalg.norm(dp_held, axis=1).mean():.3f} mm, RMS "
              f"{np.sqrt((dp_held**2).sum(1).mean()):.3f} mm, max {np.linalg.norm(dp_held, axis=1).max():.3f} mm")


if __name__ == "__main__":
    main()
