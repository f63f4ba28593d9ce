#!/usr/bin/env python3
"""Checks recorded replies against the OpenAPI document: each reply's body against the schema its operation
declares for its status, undeclared properties being errors (openapi_check.py says how schemas are read).

Usage: validate_responses.py SPEC REPLIES
REPLIES is a tab-separated file, one reply a line: method, path (with its query), HTTP status, Content-Type,
body file (relative to the REPLIES file's directory). A reply to a request no operation of the spec matches
(an unknown endpoint) must be an error status with the error body. A reply whose Content-Type is not JSON is
checked for being a media type its response declares, its body is not read. The spec itself is checked first.
Exit status 0 when everything matches, 1 otherwise (each failure printed with method, path, status and why).
"""

import json
import os
import sys

import openapi_check as oc


def check_reply(spec, method, path, status, content_type, body_path):
    """Why the reply does not match the spec (a list of lines), or [] when it does."""
    found = oc.find_operation(spec, method, path)
    if found is None:
        if status < 400:
            return ["no operation of the spec matches, and the status is not an error"]
        response = oc.error_response(spec)
    else:
        response = oc.response_for(spec, found[1], status)
        if response is None:
            return ["%s (%s) declares no response for status %d" % (found[1].get("operationId"), found[0], status)]
    media = oc.media_type(content_type)
    content = response.get("content", {})
    if media not in content:
        return ["Content-Type %r, the spec declares %s" % (content_type, ", ".join(sorted(content)) or "no body")]
    if media != "application/json":
        return []
    try:
        with open(body_path, "rb") as f:
            document = json.loads(f.read().decode("utf-8"))
    except (ValueError, UnicodeDecodeError) as e:
        return ["the body is not JSON: %s" % e]
    if "schema" not in content[media]:
        return ["the spec declares no schema for this JSON body"]
    return oc.validation_errors(oc.to_json_schema(spec, content[media]["schema"]), document)


def main(argv):
    if len(argv) != 3:
        sys.exit(__doc__)
    oc.require_jsonschema()
    spec = oc.load_spec(argv[1])
    failures = 0
    for problem in oc.check_spec(spec):
        print("FAIL spec: " + problem, file=sys.stderr)
        failures += 1
    base = os.path.dirname(os.path.abspath(argv[2]))
    checked = skipped = 0
    with open(argv[2], encoding="utf-8", errors="replace") as f:
        for line in f:
            fields = line.rstrip("\n").split("\t")
            if len(fields) != 5:
                print("FAIL schema: malformed record %r" % line, file=sys.stderr)
                failures += 1
                continue
            method, path, status, content_type, body = fields
            if not status.isdigit() or status == "000":
                print("FAIL schema: %s %s: no HTTP reply was recorded" % (method, path), file=sys.stderr)
                failures += 1
                continue
            errors = check_reply(spec, method, path, int(status), content_type, os.path.join(base, body))
            if oc.media_type(content_type) != "application/json" and not errors:
                skipped += 1
            else:
                checked += 1
            if errors:
                failures += 1
                print("FAIL schema: %s %s -> %s (%s):" % (method, path, status, body), file=sys.stderr)
                for error in errors:
                    print("    " + error, file=sys.stderr)
    print("schema: %d JSON replies checked against %s, %d of other media types, %d failure(s)"
          % (checked, argv[1], skipped, failures))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
