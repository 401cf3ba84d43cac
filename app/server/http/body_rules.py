"""What a request body's field allows, read from the route's own JSON Schema, for a 422 that
pydantic words without it ("Field required", "Input should be a valid integer"): every error
says what is allowed (docs/DESIGN.md §10)."""

from __future__ import annotations

from collections.abc import Sequence
from functools import cache
from typing import Any

from pydantic import TypeAdapter

MAX_NAMES = 12  # fields or choices listed before "..."


@cache
def body_schema(annotation: Any) -> dict[str, Any]:
    """The JSON Schema of a route's body type (a model, or a union of them)."""
    return TypeAdapter(annotation).json_schema()


def allowed_at(schema: dict[str, Any], loc: Sequence[str | int]) -> str:
    """What the body's part at `loc` (after "body") allows, in words; "" where the schema does
    not say (a union's branch, a free-form object)."""
    node: dict[str, Any] | None = _resolved(schema, schema)
    for key in loc:
        if node is None:
            return ""
        if isinstance(key, int):
            node = _resolved(schema, node.get("items") or node.get("prefixItems", [None])[0])
        else:
            node = _resolved(schema, (node.get("properties") or {}).get(key))
    return "" if node is None else _describe(schema, node)


def _resolved(root: dict[str, Any], node: Any) -> dict[str, Any] | None:
    """`node` with its `$ref` followed and an `anyOf` of one thing and null taken as that."""
    if not isinstance(node, dict):
        return None
    if "$ref" in node:
        node = root.get("$defs", {}).get(node["$ref"].rsplit("/", 1)[-1])
        return _resolved(root, node)
    branches = [b for b in node.get("anyOf", []) if b.get("type") != "null"]
    if len(branches) == 1:
        return _resolved(root, {**{k: v for k, v in node.items() if k != "anyOf"}, **branches[0]})
    return node


def _describe(root: dict[str, Any], node: dict[str, Any]) -> str:
    if "enum" in node or "const" in node:
        choices = node.get("enum", [node.get("const")])
        return "one of " + _listed([repr(c) if isinstance(c, str) else str(c) for c in choices])
    kind = node.get("type")
    if kind in ("integer", "number"):
        what = "a whole number" if kind == "integer" else "a finite number"
        return f"{what}{_range(node)}"
    if kind == "boolean":
        return "true or false"
    if kind == "string":
        most = node.get("maxLength")
        return f"a string{f' of at most {most} characters' if most is not None else ''}"
    if kind == "array":
        return "a list"
    if kind == "object" and node.get("properties"):
        required = set(node.get("required", []))
        names = [f"{n} (required)" if n in required else n for n in node["properties"]]
        return "a JSON object with " + _listed(names)
    if "anyOf" in node:
        branches = [_resolved(root, b) for b in node["anyOf"]]
        return " or ".join(s for b in branches if b and (s := _describe(root, b)))
    return ""


def _range(node: dict[str, Any]) -> str:
    low = node.get("minimum", node.get("exclusiveMinimum"))
    high = node.get("maximum", node.get("exclusiveMaximum"))
    above = "exclusiveMinimum" in node and "minimum" not in node
    below = "exclusiveMaximum" in node and "maximum" not in node
    if low is not None and high is not None and not above and not below:
        return f" {low:g} to {high:g}"
    parts = []
    if low is not None:
        parts.append(f"{'>' if above else '>='} {low:g}")
    if high is not None:
        parts.append(f"{'<' if below else '<='} {high:g}")
    return f" {' and '.join(parts)}" if parts else ""


def _listed(names: list[str]) -> str:
    more = f", ... ({len(names) - MAX_NAMES} more)" if len(names) > MAX_NAMES else ""
    return ", ".join(names[:MAX_NAMES]) + more
