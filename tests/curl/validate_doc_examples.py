#!/usr/bin/env python3
"""Checks the example replies of the docs against the OpenAPI document, as validate_responses.py checks the
curl harness's replies (openapi_check.py says how schemas are read).

Usage: validate_doc_examples.py SOURCE_DIR
Checks SOURCE_DIR/api/openapi.json itself (openapi_check.check_spec), then reads SOURCE_DIR/README.md and
SOURCE_DIR/docs/*.md. Every ```json block there is
marked on the line right before it, either with the operation and status whose reply it is,
    <!-- response: getRobot 200 -->
and is then validated against that response's schema, or with the reason it is not a reply to validate,
    <!-- not validated: a request body -->
A ```json block without a marker, a marker without a block, an operationId or status the spec does not have,
and a block that is not JSON or does not match are failures. Exit status 0 when all pass, 1 otherwise.
"""

import glob
import json
import os
import re
import sys

import openapi_check as oc

MARKER = re.compile(r"^\s*<!--\s*(response:\s*(?P<op>\S+)\s+(?P<status>\d{3})|not validated:\s*(?P<why>.+?))\s*-->\s*$")
FENCE = re.compile(r"^\s*```")


def examples(path):
    """(line number, marker match or None, block text or None) for every ```json block and every marker."""
    with open(path, encoding="utf-8") as f:
        lines = f.read().split("\n")
    found = []
    i = 0
    while i < len(lines):
        marker = MARKER.match(lines[i])
        if marker:
            if i + 1 < len(lines) and lines[i + 1].strip() == "```json":
                i += 1
            else:
                found.append((i + 1, marker, None))
                i += 1
                continue
        if lines[i].strip() == "```json":
            start = i
            i += 1
            while i < len(lines) and not FENCE.match(lines[i]):
                i += 1
            found.append((start + 1, marker, "\n".join(lines[start + 1:i])))
        elif FENCE.match(lines[i]):  # skip other blocks whole: a marker-like line inside one is code
            i += 1
            while i < len(lines) and not FENCE.match(lines[i]):
                i += 1
        i += 1
    return found


def check_example(spec, marker, text):
    op_id, status = marker.group("op"), int(marker.group("status"))
    found = oc.operation_by_id(spec, op_id)
    if found is None:
        return ["the spec has no operation %r" % op_id]
    response = oc.response_for(spec, found[2], status)
    if response is None:
        return ["%s declares no response for status %d" % (op_id, status)]
    content = response.get("content", {}).get("application/json")
    if content is None or "schema" not in content:
        return ["%s %d has no JSON body in the spec" % (op_id, status)]
    try:
        document = json.loads(text)
    except ValueError as e:
        return ["not JSON (%s); complete it, or mark it <!-- not validated: why -->" % e]
    return oc.validation_errors(oc.to_json_schema(spec, content["schema"]), document)


def main(argv):
    if len(argv) != 2:
        sys.exit(__doc__)
    oc.require_jsonschema()
    root = argv[1]
    spec = oc.load_spec(os.path.join(root, "api", "openapi.json"))
    files = [os.path.join(root, "README.md")] + sorted(glob.glob(os.path.join(root, "docs", "*.md")))
    failures = validated = skipped = 0
    for problem in oc.check_spec(spec):
        print("FAIL spec: " + problem, file=sys.stderr)
        failures += 1
    for path in files:
        name = os.path.relpath(path, root)
        for line, marker, text in examples(path):
            where = "%s:%d" % (name, line)
            if text is None:
                errors = ["a marker without a ```json block right after it"]
            elif marker is None:
                errors = ["a ```json block without a marker: <!-- response: operationId status --> or "
                          "<!-- not validated: why -->"]
            elif marker.group("why"):
                skipped += 1
                print("skip %s: %s" % (where, marker.group("why")))
                continue
            else:
                errors = check_example(spec, marker, text)
                validated += 1
                where += " (%s %s)" % (marker.group("op"), marker.group("status"))
            if errors:
                failures += 1
                print("FAIL %s:" % where, file=sys.stderr)
                for error in errors:
                    print("    " + error, file=sys.stderr)
            else:
                print("ok   " + where)
    if validated == 0:
        print("FAIL no marked example reply found in README.md and docs/*.md", file=sys.stderr)
        failures += 1
    print("docs: %d example replies checked, %d not validated, %d failure(s)" % (validated, skipped, failures))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
