"""The OpenAPI document (api/openapi.json) as the checks of replies and of the docs' examples read it.

The spec is OpenAPI 3.0; its schemas become JSON Schema (draft 4, whose boolean exclusiveMinimum and
exclusiveMaximum are OpenAPI 3.0's) here: `$ref`s to #/components/... are inlined, `nullable: true` adds null to
the type, and every object schema that does not say otherwise is closed (additionalProperties false), so that a
property the spec does not declare is an error. An object is free-form only where the spec says so with
additionalProperties true or a schema.

The spec itself is checked too (check_spec): every operation has a unique camelCase operationId, every $ref
resolves, every object schema reachable from a response states additionalProperties and requires only properties
it declares, and the alternatives of every oneOf are mutually exclusive by construction (a property one requires
is not allowed by the other, or the two differ in type or enum), so a document matches at most one of them.
"""

import json
import re
import sys

try:
    import jsonschema
except ImportError:  # the callers turn this into a failed test, not a skip
    jsonschema = None

HTTP_METHODS = ("get", "put", "post", "delete", "patch", "head", "options", "trace")
OPERATION_ID = re.compile(r"^[a-z][a-zA-Z0-9]*$")
# Keys of an OpenAPI schema object that JSON Schema has no use for; dropped so they cannot be misread.
OPENAPI_ONLY = ("nullable", "discriminator", "readOnly", "writeOnly", "xml", "externalDocs", "example",
                "deprecated")


def require_jsonschema():
    """Exits with a message naming the Debian package when python3-jsonschema is missing."""
    if jsonschema is None:
        sys.exit("FAIL: the Python module jsonschema is missing: install python3-jsonschema "
                 "(deploy/install-deps.sh installs it)")


def load_spec(path):
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def resolve(spec, ref):
    """The object a local reference (#/components/schemas/Name) points at."""
    if not ref.startswith("#/"):
        raise ValueError("only local references are supported: " + ref)
    node = spec
    for part in ref[2:].split("/"):
        part = part.replace("~1", "/").replace("~0", "~")
        if not isinstance(node, dict) or part not in node:
            raise ValueError("unresolved reference " + ref)
        node = node[part]
    return node


def to_json_schema(spec, schema, _refs=()):
    """An OpenAPI 3.0 schema as a self-contained, closed JSON Schema (draft 4)."""
    if isinstance(schema, bool):
        return schema
    if "$ref" in schema:  # OpenAPI 3.0 ignores the siblings of a $ref
        ref = schema["$ref"]
        if ref in _refs:
            raise ValueError("recursive schema: " + " -> ".join(_refs + (ref,)))
        return to_json_schema(spec, resolve(spec, ref), _refs + (ref,))
    out = {}
    for key, value in schema.items():
        if key in OPENAPI_ONLY:
            continue
        if key in ("properties", "patternProperties"):
            out[key] = {name: to_json_schema(spec, s, _refs) for name, s in value.items()}
        elif key in ("items", "not") or (key == "additionalProperties" and isinstance(value, dict)):
            out[key] = to_json_schema(spec, value, _refs)
        elif key in ("oneOf", "anyOf", "allOf"):
            out[key] = [to_json_schema(spec, s, _refs) for s in value]
        else:
            out[key] = value
    if "allOf" in out:
        # Closing each part of an allOf would refuse the other parts' properties.
        raise ValueError("allOf is not supported by the closed-schema check; spell the object out")
    if is_object_schema(schema) and "additionalProperties" not in out:
        out["additionalProperties"] = False
    if schema.get("nullable"):
        if "type" in out:
            out["type"] = [out["type"], "null"]
            if "enum" in out:
                out["enum"] = list(out["enum"]) + [None]
        else:
            out = {"anyOf": [out, {"type": "null"}]}
    return out


def is_object_schema(schema):
    return schema.get("type") == "object" or "properties" in schema


def operations(spec):
    """(method, path template, operation) for every operation of the spec."""
    for template, item in spec.get("paths", {}).items():
        for method, op in item.items():
            if method in HTTP_METHODS:
                yield method.upper(), template, op


def template_regex(template):
    # A path parameter is one segment without ':' (custom methods such as {robot}:forward follow it).
    parts = re.split(r"(\{[^}]+\})", template)
    return re.compile("^" + "".join("[^/:]+" if p.startswith("{") else re.escape(p) for p in parts) + "$")


def find_operation(spec, method, path):
    """The operation a request (method, concrete path, query ignored) is for, or None."""
    path = path.split("?", 1)[0]
    for m, template, op in operations(spec):
        if m == method and template_regex(template).match(path):
            return template, op
    return None


def operation_by_id(spec, operation_id):
    for method, template, op in operations(spec):
        if op.get("operationId") == operation_id:
            return method, template, op
    return None


def response_for(spec, op, status):
    """The response object an operation declares for an HTTP status (exact code, then 4XX/5XX, then default)."""
    responses = op.get("responses", {})
    for key in (str(status), str(status)[0] + "XX", "default"):
        if key in responses:
            response = responses[key]
            return resolve(spec, response["$ref"]) if "$ref" in response else response
    return None


def error_response(spec):
    """The response every reply to a request the spec does not name is: the error body."""
    return spec["components"]["responses"]["Error"]


def media_type(content_type):
    return (content_type or "").split(";", 1)[0].strip().lower()


def validation_errors(schema, document):
    """Every way `document` fails the (converted) `schema`, one readable line each."""
    validator = jsonschema.Draft4Validator(schema)
    lines = []
    for error in sorted(validator.iter_errors(document), key=lambda e: list(e.absolute_path)):
        line = _where(error) + ": " + _short(error.message)
        if error.validator == "oneOf":
            # The message would repeat the whole instance; say which alternatives failed and why instead.
            if not error.context:
                line = _where(error) + ": matches more than one alternative of a oneOf"
            else:
                line = _where(error) + ": matches no alternative of a oneOf"
                seen = set()
                for sub in error.context:  # the first reason of each alternative
                    branch = sub.schema_path[0] if sub.schema_path else "?"
                    if branch not in seen:
                        seen.add(branch)
                        line += "\n      alternative %s: %s: %s" % (branch, _where(sub), _short(sub.message))
        lines.append(line)
    return lines


def _where(error):
    return "/".join(str(p) for p in error.absolute_path) or "(top)"


def _short(message, limit=300):
    return message if len(message) <= limit else message[:limit] + "..."


def check_spec(spec):
    """Problems of the spec itself: operationIds, references, closed response schemas, exclusive oneOfs."""
    problems = []
    seen = {}
    for method, template, op in operations(spec):
        name = method + " " + template
        op_id = op.get("operationId")
        if not op_id:
            problems.append(name + ": no operationId")
            continue
        if not OPERATION_ID.match(op_id):
            problems.append(name + ": operationId %r is not camelCase" % op_id)
        if op_id in seen:
            problems.append(name + ": operationId %r also names %s" % (op_id, seen[op_id]))
        seen[op_id] = name
    _check_refs(spec, spec, "#", problems)
    visited = set()  # components already checked
    for method, template, op in operations(spec):
        for status, response in op.get("responses", {}).items():
            if "$ref" in response:
                response = resolve(spec, response["$ref"])
            for media, content in response.get("content", {}).items():
                if "schema" in content:
                    where = "%s %s %s %s" % (method, template, status, media)
                    _check_response_schema(spec, content["schema"], where, visited, problems)
    _check_one_ofs(spec, spec, "#", problems)
    return problems


def _check_refs(spec, node, where, problems):
    if isinstance(node, dict):
        if "$ref" in node:
            try:
                resolve(spec, node["$ref"])
            except ValueError as e:
                problems.append(where + ": " + str(e))
        for key, value in node.items():
            _check_refs(spec, value, where + "/" + key, problems)
    elif isinstance(node, list):
        for i, value in enumerate(node):
            _check_refs(spec, value, "%s/%d" % (where, i), problems)


def _check_response_schema(spec, schema, where, visited, problems):
    if "$ref" in schema:
        ref = schema["$ref"]
        if ref in visited:
            return
        visited.add(ref)
        _check_response_schema(spec, resolve(spec, ref), ref, visited, problems)
        return
    if is_object_schema(schema):
        if "additionalProperties" not in schema:
            problems.append(where + ": an object in a response without additionalProperties (false, or true for "
                            "a free-form map)")
        undeclared = set(schema.get("required", [])) - set(schema.get("properties", {}))
        if undeclared:
            problems.append(where + ": requires undeclared properties " + ", ".join(sorted(undeclared)))
    for name, sub in schema.get("properties", {}).items():
        _check_response_schema(spec, sub, where + "/properties/" + name, visited, problems)
    for key in ("items", "not", "additionalProperties"):
        if isinstance(schema.get(key), dict):
            _check_response_schema(spec, schema[key], where + "/" + key, visited, problems)
    for key in ("oneOf", "anyOf", "allOf"):
        for i, sub in enumerate(schema.get(key, [])):
            _check_response_schema(spec, sub, "%s/%s/%d" % (where, key, i), visited, problems)


def _check_one_ofs(spec, node, where, problems):
    if isinstance(node, dict):
        if isinstance(node.get("oneOf"), list):
            alternatives = [to_json_schema(spec, s) for s in node["oneOf"]]
            for i in range(len(alternatives)):
                for j in range(i + 1, len(alternatives)):
                    if not exclusive(alternatives[i], alternatives[j]):
                        problems.append("%s/oneOf: alternatives %d and %d can match the same document (make one "
                                        "require a property the other does not allow)" % (where, i, j))
        for key, value in node.items():
            _check_one_ofs(spec, value, where + "/" + key, problems)
    elif isinstance(node, list):
        for i, value in enumerate(node):
            _check_one_ofs(spec, value, "%s/%d" % (where, i), problems)


def _types(schema):
    t = schema.get("type")
    if t is None:
        return None
    types = set(t) if isinstance(t, list) else {t}
    if "number" in types:
        types.add("integer")
    return types


def exclusive(a, b):
    """True when no document can match both converted schemas (a sufficient test, not a complete one)."""
    ta, tb = _types(a), _types(b)
    if ta is not None and tb is not None and not ta & tb:
        return True
    if "enum" in a and "enum" in b and not any(x in b["enum"] for x in a["enum"]):
        return True
    for x, y in ((a, b), (b, a)):
        if y.get("additionalProperties") is False:
            allowed = set(y.get("properties", {}))
            if set(x.get("required", [])) - allowed:
                return True
    for name in set(a.get("required", [])) & set(b.get("required", [])):
        pa, pb = a.get("properties", {}).get(name), b.get("properties", {}).get(name)
        if isinstance(pa, dict) and isinstance(pb, dict) and exclusive(pa, pb):
            return True
    return False
