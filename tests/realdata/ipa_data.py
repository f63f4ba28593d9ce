"""What the real-data scripts share (tests/realdata/ipa_*.py): the server's API, the IPA UR10's files
(tests/data/ipa/README.md) as the import reads them and as test or check shots, and the UR10 robot."""
import json
import math
import sys
import urllib.error
import urllib.request

JOINTS = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
          "wrist_3_joint"]
# The export as the import reads it: ';' and decimal commas, joints in rad, the T-Mac's pose in mm and intrinsic
# X-Y-Z Euler angles in degrees (the text itself is added per file).
FILE = {"format": "csv", "unit": "mm", "decimal": ",",
        "columns": {"x": "measurement_x", "y": "measurement_y", "z": "measurement_z"},
        "joints": {"columns": JOINTS, "unit": "rad"},
        "orientation": {"representation": "euler", "columns": ["measurement_rx", "measurement_ry", "measurement_rz"],
                        "sequence": "XYZ", "convention": "intrinsic", "unit": "deg"}}


class Api:
    """The server at `url`: call(method, path, body) returns the reply's JSON; an error reply ends the script."""

    def __init__(self, url):
        self.url = url

    def call(self, method, path, body=None):
        data = None if body is None else json.dumps(body).encode()
        request = urllib.request.Request(self.url + path, data=data, method=method,
                                         headers={"Content-Type": "application/json"})
        try:
            with urllib.request.urlopen(request, timeout=600) as reply:
                return json.loads(reply.read())
        except urllib.error.HTTPError as e:
            sys.exit(f"{method} {path}: {e.code} {e.read().decode()[:2000]}")

    def calibrate(self, campaign, robot, text, rows, fit=None):
        """A campaign of `robot` with the file's `rows` (1-based lines) as calibration measurements, fitted (with
        `fit`, the fit request's body); returns the fit."""
        self.call("POST", "/v1/campaigns", {"id": campaign, "robot": robot})
        self.call("POST", f"/v1/campaigns/{campaign}/measurements:import",
                  dict(FILE, text=text, request_id=campaign, role="calibration", rows=sorted(rows)))
        return self.call("POST", f"/v1/campaigns/{campaign}:fit", fit or {})

    def register_ur10(self, data_dir, robot_id="ur10"):
        """The public UR10 URDF with the T-Mac 109 mm out of the flange, turned -90 deg about it."""
        with open(f"{data_dir}/urdf/ur10_robot.urdf", encoding="utf-8") as f:
            return self.call("POST", "/v1/robots", {"id": robot_id, "urdf": f.read(), "base_link": "base_link",
                                                    "tip_link": "tool0",
                                                    "tool": {"position_mm": [0, 0, 109], "rpy_deg": [0, 0, -90]}})


def read(data_dir, name):
    with open(f"{data_dir}/ipa/{name}", encoding="utf-8") as f:
        return f.read()


def data_rows(text):
    """(1-based line, {column: text}) of every data row (the first non-empty line is the header)."""
    lines = text.split("\n")
    header = next(i for i, line in enumerate(lines) if line.strip())
    names = lines[header].strip().split(";")
    return [(i + 1, dict(zip(names, lines[i].strip().split(";"))))
            for i in range(header + 1, len(lines)) if lines[i].strip()]


def number(text):
    return float(text.replace(",", "."))


def quaternion_xyz_intrinsic(a_deg, b_deg, c_deg):
    """[w, x, y, z] of R = Rx(a) Ry(b) Rz(c): the product of the three axis quaternions."""
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
    """A measurement of a data row (joints in degrees, the pose with a quaternion); `offset_deg` added to joint
    `joint` (0-based) as a re-mastered robot would report it."""
    joints = [math.degrees(number(row[j])) for j in JOINTS]
    if joint is not None:
        joints[joint] += offset_deg
    return {"joints": joints,
            "pose": {"position_mm": [number(row[f"measurement_{a}"]) for a in "xyz"],
                     "quaternion": quaternion_xyz_intrinsic(*[number(row[f"measurement_r{a}"]) for a in "xyz"])}}
