#!/usr/bin/env python3
"""Counts the places a wire field is declared or carried by hand (docs/architecture.md, "How to add a field").

A place is a line outside the docs and the tests that a developer adding the field must write: a struct member in
api/, its field-table row, a request parser's line that spells the key, a stored document's repair, a copy between
two shapes (`a.field = b.field`), and each schema property of api/openapi.json. Lines that *use* the value for
what it does (the core's arithmetic, a fit's options, a CLI printing it) are behaviour, not bookkeeping, and are
listed apart.

    tests/service/field_places.py [--max N] FIELD...

prints each field's places by kind; with --max, exits 1 when a field has more than N places.
"""
import argparse
import json
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CODE = ["api/include", "api/src", "server/src", "server/include", "client/src", "client/include"]


def code_lines():
    for top in CODE:
        for directory, _, files in os.walk(os.path.join(ROOT, top)):
            for name in sorted(files):
                if not name.endswith((".h", ".cc")):
                    continue
                path = os.path.join(directory, name)
                with open(path, encoding="utf-8") as f:
                    for number, line in enumerate(f, 1):
                        yield os.path.relpath(path, ROOT), number, line.rstrip("\n")


def classify(path, field, line):
    code = line.split("//", 1)[0]
    if not re.search(r"\b%s\b" % re.escape(field), code):
        return None
    if re.search(r'Field\{"%s"' % re.escape(field), code):
        return "table row"
    if (re.match(r"\s*[\w:<>, ]+[\s&*]%s\s*(=[^=]|\{|;)" % re.escape(field), code) and "return" not in code
            and "(" not in code and not code.rstrip().rstrip(";").endswith(")")):
        return "struct member"
    if re.search(r'"%s"' % re.escape(field), code):
        return "parser or repair (spells the key)"
    if re.search(r"\.%s\s*=\s*[\w\[\]\.]+\.%s\s*;" % (re.escape(field), re.escape(field)), code):
        return "copy between shapes"
    if path.startswith("api/") and re.search(r"(\.%s\s*=[^=]|=[^=;]*\.%s\b)" % (re.escape(field), re.escape(field)), code):
        return "conversion (core <-> wire)"
    return "use"


def spec_places(field):
    with open(os.path.join(ROOT, "api/openapi.json"), encoding="utf-8") as f:
        spec = json.load(f)
    found = []

    def walk(node, pointer):
        if isinstance(node, dict):
            if isinstance(node.get("properties"), dict) and field in node["properties"]:
                found.append(pointer + "/properties/" + field)
            for key, value in node.items():
                walk(value, pointer + "/" + key)
        elif isinstance(node, list):
            for i, value in enumerate(node):
                walk(value, pointer + "/" + str(i))

    walk(spec, "")
    return found


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("fields", nargs="+")
    parser.add_argument("--max", type=int, default=None)
    args = parser.parse_args()
    over = False
    for field in args.fields:
        kinds = {}
        for path, number, line in code_lines():
            kind = classify(path, field, line)
            if kind:
                kinds.setdefault(kind, []).append("%s:%d: %s" % (path, number, line.strip()))
        kinds["spec property"] = ["api/openapi.json " + p for p in spec_places(field)]
        places = sum(len(v) for k, v in kinds.items() if k != "use")
        print("%s: %d places" % (field, places))
        for kind in ["struct member", "table row", "parser or repair (spells the key)", "copy between shapes",
                     "conversion (core <-> wire)", "spec property", "use"]:
            for entry in kinds.get(kind, []):
                print("  %-34s %s" % (kind, entry))
        over = over or (args.max is not None and places > args.max)
    return 1 if over else 0


if __name__ == "__main__":
    sys.exit(main())
