#!/usr/bin/env python3
"""Counts the places a wire field is declared or carried by hand (docs/architecture.md, "How to add a field").

A field is named by its shape and key, SHAPE.FIELD (CreateCampaignRequest.repeatability_mm): the shape whose
struct declares it. Its places are the lines outside the docs and the tests that a developer adding the field
must write, in the shape and the shapes that extend it (a request's resource, a stored form): a struct member in
api/, its field-table row (with the continuation lines of that row, one place), a request parser's line that
spells the key, a stored document's repair, a copy between two shapes (`a.field = b.field`), a core <-> wire
conversion written by hand, and each schema property of api/openapi.json the shape's schemas have, but for the
copies tests/service/spec_resources.py writes. Lines that *use* the value for what it does (the core's
arithmetic, a fit's options, a CLI printing it), and fields of the same name in other shapes (a drift check's
own repeatability_mm), are listed apart.

    tests/service/field_places.py [--max N] SHAPE.FIELD...

prints each field's places by kind; with --max, exits 1 when a field has more than N places.
"""
import argparse
import json
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CODE = ["api/include", "api/src", "server/src", "server/include", "client/src", "client/include"]
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import spec_resources  # noqa: E402  (the resource schemas whose shared properties are copies)

STRUCT = re.compile(r"^\s*struct\s+(?:WireFields<\s*(\w+)\s*>|(\w+))(?:\s*:\s*(?:public\s+)?(\w+))?[^;]*$")


def code_lines():
    """Every line of the code, with the shape whose struct or field table it is in (None outside them)."""
    for top in CODE:
        for directory, _, files in os.walk(os.path.join(ROOT, top)):
            for name in sorted(files):
                if not name.endswith((".h", ".cc")):
                    continue
                path = os.path.join(directory, name)
                shape, depth, outer = None, 0, 0
                with open(path, encoding="utf-8") as f:
                    for number, line in enumerate(f, 1):
                        code = line.split("//", 1)[0]
                        if shape is None:
                            m = STRUCT.match(code)
                            if m and "{" in code:
                                shape, outer = m.group(1) or m.group(2), depth
                        yield os.path.relpath(path, ROOT), number, line.rstrip("\n"), shape
                        depth += code.count("{") - code.count("}")
                        if shape is not None and depth <= outer:
                            shape = None


def bases():
    """Each api struct's base (struct X : Y)."""
    out = {}
    for top in ["api/include"]:
        for directory, _, files in os.walk(os.path.join(ROOT, top)):
            for name in files:
                with open(os.path.join(directory, name), encoding="utf-8") as f:
                    for line in f:
                        m = STRUCT.match(line.split("//", 1)[0])
                        if m and m.group(2) and m.group(3):
                            out[m.group(2)] = m.group(3)
    return out


def family(shape):
    """The shape and the shapes that extend it."""
    base = bases()
    out = {shape}
    changed = True
    while changed:
        changed = False
        for derived, b in base.items():
            if b in out and derived not in out:
                out.add(derived)
                changed = True
    return out


def classify(path, field, line, shape, shapes):
    code = line.split("//", 1)[0]
    if not re.search(r"\b%s\b" % re.escape(field), code):
        return None
    if shape is not None and shape not in shapes:
        return "another shape's field"
    if re.search(r'Field\{"%s"' % re.escape(field), code):
        return "table row"
    if shape is not None and path.endswith(".h") and re.search(r"^\s*\.", code):
        return "table row (continued)"
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


def schemas_of(shapes):
    """The spec's schemas of the shapes, as SpecTest pairs them (spec.Check<T>(Schema("Name"), ...))."""
    with open(os.path.join(ROOT, "tests/service/spec_test.cc"), encoding="utf-8") as f:
        pairs = re.findall(r'Check<(\w+)>\(Schema\("(\w+)"\)', f.read())
    pairs += [(entry["shapes"][0], entry["request"]) for entry in spec_resources.RESOURCES]
    pairs += [(entry["shapes"][1], entry["resource"]) for entry in spec_resources.RESOURCES]
    return {schema for shape, schema in pairs if shape in shapes}


def spec_places(field, shapes):
    with open(os.path.join(ROOT, "api/openapi.json"), encoding="utf-8") as f:
        spec = json.load(f)
    mine = schemas_of(shapes)
    copies = {entry["resource"]: entry for entry in spec_resources.RESOURCES}
    places, apart = [], []
    for name, schema in spec["components"]["schemas"].items():
        if field not in schema.get("properties", {}):
            continue
        where = "api/openapi.json /components/schemas/%s/properties/%s" % (name, field)
        entry = copies.get(name)
        if entry and field in spec["components"]["schemas"][entry["request"]].get("properties", {}) and \
                field not in entry["resource_form"]:
            apart.append(("spec copy (spec_resources.py)", where))
        elif name in mine:
            places.append(where)
        else:
            apart.append(("another schema's property", where))
    return places, apart


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("fields", nargs="+", metavar="SHAPE.FIELD")
    parser.add_argument("--max", type=int, default=None)
    args = parser.parse_args()
    over = False
    counted = ["struct member", "table row", "parser or repair (spells the key)", "copy between shapes",
               "conversion (core <-> wire)", "spec property"]
    for name in args.fields:
        if "." not in name:
            parser.error("%s: name the field as SHAPE.FIELD" % name)
        shape, field = name.split(".", 1)
        shapes = family(shape)
        kinds = {}
        for path, number, line, context in code_lines():
            kind = classify(path, field, line, context, shapes)
            if kind:
                kinds.setdefault(kind, []).append("%s:%d: %s" % (path, number, line.strip()))
        places, apart = spec_places(field, shapes)
        kinds["spec property"] = places
        for kind, where in apart:
            kinds.setdefault(kind, []).append(where)
        total = sum(len(kinds.get(k, [])) for k in counted)
        print("%s (%s): %d places" % (name, ", ".join(sorted(shapes)), total))
        for kind in counted + ["table row (continued)", "spec copy (spec_resources.py)", "another shape's field",
                               "another schema's property", "use"]:
            for entry in kinds.get(kind, []):
                print("  %-34s %s" % (kind, entry))
        over = over or (args.max is not None and total > args.max)
    return 1 if over else 0


if __name__ == "__main__":
    sys.exit(main())
