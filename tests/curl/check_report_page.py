#!/usr/bin/env python3
"""Checks a campaign report as headless Chromium rendered it (report_browser_test.sh).

Usage: check_report_page.py SCREENSHOT.png DOM.html CALIBRATION.json EVALUATION.json PLAN.json

The PNG (decoded here with zlib: no imaging library needed) must not be blank: enough non-white pixels, spread
over the page, with dark text among them. The DOM (Chromium's --dump-dom, i.e. after parsing) must hold the
report's tables with the numbers of the calibration (GET .../calibration), the evaluation (:evaluate, h_mm 30)
and the plan (GET /v1/plans/{p}): every parameter's value and std, the residuals, the outliers, the paper's
validation table in micrometres and arcseconds, the plan's configurations; and the drawings: one stick figure
per planned configuration in both views, one bar group per configuration, the E_xyz distribution. Each
number is compared twice: its exact data-value, and the text a reader sees, rounded as the page rounds it.
Exit status 0 when everything holds; each failure is printed.
"""

import html.parser
import json
import math
import struct
import sys
import zlib

failures = []


def check(condition, message):
    if not condition:
        failures.append(message)


# ---- PNG -------------------------------------------------------------------------------------------------

def read_png(path):
    """(width, height, rows of RGB tuples) of an 8-bit RGB or RGBA PNG."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError("not a PNG")
    pos, idat, header = 8, b"", None
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        chunk = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", chunk)
        elif kind == b"IDAT":
            idat += chunk
        pos += 12 + length
    width, height, depth, colour, _, _, interlace = header
    if depth != 8 or colour not in (2, 6) or interlace != 0:
        raise ValueError("unsupported PNG: depth %d colour type %d interlace %d" % (depth, colour, interlace))
    channels = 3 if colour == 2 else 4
    raw = zlib.decompress(idat)
    stride = width * channels
    rows, previous, pos = [], bytearray(stride), 0
    for _ in range(height):
        kind = raw[pos]
        line = bytearray(raw[pos + 1:pos + 1 + stride])
        pos += 1 + stride
        for i in range(stride):
            left = line[i - channels] if i >= channels else 0
            up = previous[i]
            upper_left = previous[i - channels] if i >= channels else 0
            if kind == 1:
                line[i] = (line[i] + left) & 0xFF
            elif kind == 2:
                line[i] = (line[i] + up) & 0xFF
            elif kind == 3:
                line[i] = (line[i] + (left + up) // 2) & 0xFF
            elif kind == 4:
                p = left + up - upper_left
                pa, pb, pc = abs(p - left), abs(p - up), abs(p - upper_left)
                predictor = left if pa <= pb and pa <= pc else (up if pb <= pc else upper_left)
                line[i] = (line[i] + predictor) & 0xFF
        rows.append([tuple(line[x * channels:x * channels + 3]) for x in range(width)])
        previous = line
    return width, height, rows


def check_png(path):
    width, height, rows = read_png(path)
    check(width >= 800 and height >= 1000, "screenshot is %dx%d, expected the requested window" % (width, height))
    non_white = dark = 0
    rows_with_ink = 0
    colours = set()
    for row in rows:
        ink = 0
        for (r, g, b) in row:
            if r < 245 or g < 245 or b < 245:
                non_white += 1
                ink += 1
                if len(colours) < 64:
                    colours.add((r // 32, g // 32, b // 32))
            if r < 80 and g < 80 and b < 80:
                dark += 1
        rows_with_ink += 1 if ink > 0 else 0
    total = width * height
    print("png: %dx%d, %.1f %% non-white, %.2f %% dark, ink on %d rows, %d colour bins"
          % (width, height, 100.0 * non_white / total, 100.0 * dark / total, rows_with_ink, len(colours)))
    check(non_white > 0.03 * total, "the screenshot is (nearly) blank: %d non-white pixels of %d" % (non_white, total))
    check(dark > 0.003 * total, "the screenshot has (nearly) no dark text: %d dark pixels" % dark)
    check(rows_with_ink > 0.4 * height, "ink on only %d of %d rows: the page did not fill the window" % (rows_with_ink, height))
    check(len(colours) >= 4, "only %d colour bins: no charts drawn" % len(colours))


# ---- DOM -------------------------------------------------------------------------------------------------

class Dom(html.parser.HTMLParser):
    """Collects, per element id, the data-key/data-value cells (with their text) and the tags inside it."""

    def __init__(self):
        super().__init__()
        self.stack = []          # (tag, id of the nearest ancestor with an id, attributes)
        self.cells = {}          # id -> list of (data-key, data-value, text, row's data-parameter)
        self.tags = {}           # id -> list of (tag, attributes)
        self.ids = set()
        self.row_parameter = None
        self.open_cell = None
        self.text = []

    def scope(self):
        for tag, element_id, _ in reversed(self.stack):
            if element_id:
                return element_id
        return None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if "id" in a:
            self.ids.add(a["id"])
            self.tags.setdefault(a["id"], []).append((tag, a))
        # Every element counts for each ancestor with an id (a polyline for its svg, its figure, its section).
        for _, element_id, _ in self.stack:
            if element_id:
                self.tags.setdefault(element_id, []).append((tag, a))
        if tag == "tr":
            self.row_parameter = a.get("data-parameter")
        if tag == "td" and "data-value" in a:
            self.open_cell = (a.get("data-key"), a["data-value"], self.row_parameter, self.scope())
            self.text = []
        self.stack.append((tag, a.get("id"), a))

    def handle_endtag(self, tag):
        if tag == "td" and self.open_cell:
            key, value, parameter, scope = self.open_cell
            self.cells.setdefault(scope, []).append((key, value, "".join(self.text).strip(), parameter))
            self.open_cell = None
        while self.stack:
            if self.stack.pop()[0] == tag:
                break

    def handle_data(self, data):
        if self.open_cell:
            self.text.append(data)


def close(a, b, relative=1e-9):
    return abs(a - b) <= relative * max(abs(a), abs(b), 1e-300)


def fixed(value, digits):
    text = "%.*f" % (digits, value)
    return text[1:] if text.startswith("-") and not any(c in "123456789" for c in text) else text


def cell(dom, table, key, parameter=None):
    for k, value, text, p in dom.cells.get(table, []):
        if k == key and (parameter is None or p == parameter):
            return float(value), text
    failures.append("table %s has no cell %s%s" % (table, key, "" if parameter is None else " of " + parameter))
    return math.nan, ""


def check_number(dom, table, key, expected, digits, parameter=None):
    value, text = cell(dom, table, key, parameter)
    label = "%s %s%s" % (table, key, "" if parameter is None else " (" + parameter + ")")
    check(close(value, expected), "%s: data-value %r, expected %r" % (label, value, expected))
    check(text == fixed(expected, digits), "%s: shows %r, expected %r" % (label, text, fixed(expected, digits)))


def check_dom(path, calibration, evaluation, plan):
    with open(path, encoding="utf-8") as f:
        page = f.read()
    dom = Dom()
    dom.feed(page)
    for element_id in ("campaign-summary", "robot-joints", "plan-configurations", "plan-indices", "fit-summary",
                       "fit-residuals", "parameters", "correlations", "singular-values", "robust",
                       "residual-position-chart", "residual-orientation-chart", "validation-table", "improvement",
                       "exyz-cdf", "cell-figure", "view-top", "view-side"):
        check(element_id in dom.ids, "the DOM has no element #%s" % element_id)
    check("<script" not in page.lower(), "the DOM holds a script element")

    # The fit: every parameter, the residuals, the outliers.
    for p in calibration["parameters"]:
        digits = 4 if p["unit"] == "mm" else 5
        check_number(dom, "parameters", "value", p["value"], digits, p["name"])
        check_number(dom, "parameters", "std", p["std"], digits, p["name"])
        if p["value"] != 0:
            check_number(dom, "parameters", "std_percent", 100.0 * p["std"] / abs(p["value"]), 1, p["name"])
    rows = [c for c in dom.cells.get("parameters", []) if c[0] == "value"]
    check(len(rows) == len(calibration["parameters"]),
          "%d parameter rows, the calibration has %d" % (len(rows), len(calibration["parameters"])))
    for side in ("residuals_before", "residuals_after"):
        check_number(dom, "fit-residuals", side + ".rms_position_mm", calibration[side]["rms_position_mm"], 4)
        check_number(dom, "fit-residuals", side + ".max_position_mm", calibration[side]["max_position_mm"], 4)
    check_number(dom, "fit-summary", "condition_number", calibration["condition_number"], 2)
    recomputed = [a for tag, a in dom.tags.get("fit", []) if a.get("id") == "fit-condition-number"]
    check(len(recomputed) == 1 and close(float(recomputed[0]["data-value"]), calibration["condition_number"], 1e-6),
          "the recomputed condition number differs from the fit's %r" % calibration["condition_number"])
    outliers = [c for c in dom.cells.get("outliers", []) if c[0] == "sequence"]
    check(sorted(int(float(c[1])) for c in outliers) == sorted(o["sequence"] for o in calibration["outliers"]),
          "the outlier table's sequences differ from the calibration's")
    check(len(calibration["outliers"]) > 0, "the mock tracker's outliers were not excluded: nothing to mark")
    singular = [c for c in dom.cells.get("singular-values", []) if c[0] == "singular_value"]
    check(len(singular) == len(calibration["parameters"]), "%d singular values for %d parameters"
          % (len(singular), len(calibration["parameters"])))
    values = [float(c[1]) for c in singular]
    check(values == sorted(values, reverse=True), "singular values not in descending order")
    if values:
        check(close(values[0] / values[-1], calibration["condition_number"], 1e-6),
              "largest over smallest singular value is not the condition number")
    rho = [float(c[1]) for c in dom.cells.get("correlations", []) if c[0] == "rho"]
    check(len(rho) == 10 and all(-1.0 - 1e-12 <= r <= 1.0 + 1e-12 for r in rho), "correlations: %r" % rho)
    check([abs(r) for r in rho] == sorted((abs(r) for r in rho), reverse=True), "correlations not by |rho|")

    # The validation table: :evaluate's statistics in um (E_xyz, E_tot) and arcsec (E_cos).
    for side in ("nominal", "calibrated"):
        for error, unit, factor, digits in (("e_xyz", "um", 1000.0, 1), ("e_cos", "arcsec", 3600.0, 2),
                                            ("e_tot", "um", 1000.0, 1)):
            wire = evaluation[side][error + ("_deg" if error == "e_cos" else "_mm")]
            for stat in ("mean", "std", "max", "rp"):
                check_number(dom, "validation-table", "%s.%s_%s.%s" % (side, error, unit, stat), factor * wire[stat],
                             digits)
    for key in ("e_xyz_mean", "e_xyz_rp", "e_tot_mean", "e_tot_rp"):
        if evaluation["improvement_percent"][key] is not None:
            check_number(dom, "improvement", "improvement." + key, evaluation["improvement_percent"][key], 1)
    curves = {a.get("data-curve"): int(a.get("data-count", -1)) for tag, a in dom.tags.get("exyz-cdf", [])
              if tag == "polyline"}
    check(curves == {"before": evaluation["num_validation"], "after": evaluation["num_validation"]},
          "E_xyz curves %r, expected %d poses each" % (curves, evaluation["num_validation"]))

    # The plan: its configurations (deg), drawn in both views.
    configurations = plan["configurations"]
    for i, q in enumerate(configurations):
        for k, value in enumerate(q):
            check_number(dom, "plan-configurations", "plan.configurations.%d.%d" % (i, k), value, 3)
    check_number(dom, "plan-indices", "plan.condition_number", plan["indices"]["condition_number"], 2)
    for view in ("view-top", "view-side"):
        figures = [a for tag, a in dom.tags.get(view, []) if tag == "polyline" and a.get("class") == "configuration"]
        check(len(figures) == len(configurations), "%s draws %d configurations of %d"
              % (view, len(figures), len(configurations)))
        check(any(a.get("class") == "tracker" for tag, a in dom.tags.get(view, [])), "%s has no tracker" % view)
    poses = [a for tag, a in dom.tags.get("residual-position-chart", []) if tag == "g"
             and "pose" in a.get("class", "").split()]
    check(len(poses) == len(configurations), "%d residual bar groups for %d planned configurations"
          % (len(poses), len(configurations)))
    marked = sum(int(a["data-outliers"]) for a in poses)
    check(marked == len(calibration["outliers"]), "%d shots marked as outliers in the bars, the fit excluded %d"
          % (marked, len(calibration["outliers"])))
    print("dom: %d parameters, %d validation poses, %d configurations, %d outliers checked"
          % (len(calibration["parameters"]), evaluation["num_validation"], len(configurations), len(outliers)))


def main(argv):
    if len(argv) != 6:
        sys.exit(__doc__)
    with open(argv[3]) as f:
        calibration = json.load(f)
    with open(argv[4]) as f:
        evaluation = json.load(f)
    with open(argv[5]) as f:
        plan = json.load(f)
    check_png(argv[1])
    check_dom(argv[2], calibration, evaluation, plan)
    for failure in failures:
        print("FAIL " + failure, file=sys.stderr)
    print("report page: %d failure(s)" % len(failures))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
