#!/usr/bin/env python3
"""Keeps each resource schema of api/openapi.json whose shape extends a request's (docs/architecture.md, "How to
add a field") in step with the request's schema: the properties they share are written once, in the request's
schema, and copied into the resource's by this script.

    tests/service/spec_resources.py [--write]

Without --write, exits 1 and names each resource schema that differs from what the copy gives (the ctest
`spec_resources`); with --write, rewrites api/openapi.json. A resource's copy of a shared property is the
request's, made nullable where the resource writes null for an unset value (a `$ref` is then spelt out, since
OpenAPI 3.0 cannot mark a reference nullable); the resource's `required` lists every shared property but those
the resource leaves out when empty, then its own. The C++ tables own what is right: SpecTest compares every
schema, the resource's too, with its table.
"""
import argparse
import copy
import json
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SPEC = os.path.join(ROOT, "api", "openapi.json")

# The resource schemas whose table is ResourceRows(the request's rows) plus rows of their own (with the C++
# shapes of the request and the resource, for field_places.py): which shared
# properties the resource writes as null when unset (its member is optional and always written), and which it
# does not always write (a row with `When` or InResource(kOmitEmpty)), and which it describes in a form of its own
# (a reply form of a request's schema).
RESOURCES = [
    {
        "request": "CreateCampaignRequest",
        "resource": "Campaign",
        "shapes": ["CreateCampaignRequest", "Campaign"],
        "nullable": ["plan"],
        "not_always_written": [],
        # The campaign states its noise, tracker model and payload whole (every member required; tracker and
        # payload null when none), where a request may give part.
        "resource_form": ["noise", "tracker", "payload"],
    },
    {
        "request": "Joint",
        "resource": "RobotJoint",
        "shapes": ["JointWire", "RobotJoint"],
        "nullable": [],
        "not_always_written": ["a_mm", "alpha_deg", "d_mm", "theta_deg", "xyz_mm", "rpy_deg", "min_deg", "max_deg",
                               "min_mm", "max_mm", "error_map"],
        "resource_form": [],
    },
]


def resolve(spec, node):
    while isinstance(node, dict) and "$ref" in node:
        path = node["$ref"][2:].split("/")
        target = spec
        for part in path:
            target = target[part]
        node = target
    return node


def shared_copy(spec, prop, nullable):
    out = copy.deepcopy(prop)
    if not nullable:
        return out
    if "$ref" in out:
        description = out.get("description")
        out = copy.deepcopy(resolve(spec, out))
        if description is not None:
            out["description"] = description
    out["nullable"] = True
    return out


def expected(spec, entry):
    schemas = spec["components"]["schemas"]
    request = schemas[entry["request"]]
    resource = copy.deepcopy(schemas[entry["resource"]])
    shared = list(request["properties"].keys())
    own = [k for k in resource["properties"] if k not in shared]
    properties = {}
    for key in shared:
        if key in entry["resource_form"] and key in resource["properties"]:
            properties[key] = resource["properties"][key]
        else:
            properties[key] = shared_copy(spec, request["properties"][key], key in entry["nullable"])
    for key in own:
        properties[key] = resource["properties"][key]
    resource["properties"] = properties
    required = [k for k in shared if k not in entry["not_always_written"]]
    required += [k for k in resource.get("required", []) if k in own]
    resource["required"] = required
    return resource


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--write", action="store_true", help="rewrite api/openapi.json")
    args = parser.parse_args()
    with open(SPEC, encoding="utf-8") as f:
        spec = json.load(f)
    stale = []
    for entry in RESOURCES:
        want = expected(spec, entry)
        if spec["components"]["schemas"][entry["resource"]] != want:
            stale.append(entry["resource"])
            spec["components"]["schemas"][entry["resource"]] = want
    if args.write:
        if stale:
            with open(SPEC, "w", encoding="utf-8") as f:
                f.write(json.dumps(spec, indent=1, ensure_ascii=False) + "\n")
        print("rewrote " + ", ".join(stale) if stale else "up to date")
        return 0
    for name in stale:
        print("%s: differs from its request's properties; run tests/service/spec_resources.py --write" % name,
              file=sys.stderr)
    return 1 if stale else 0


if __name__ == "__main__":
    sys.exit(main())
