"""The served OpenAPI document: FastAPI's 3.1 document rewritten as OpenAPI 3.0.3 (OGC API -
Processes' ``oas30`` conformance class), with the security schemes and the enums it lacks.

>>> to_openapi30_schema({"anyOf": [{"type": "string"}, {"type": "null"}], "examples": ["a"]})
{'example': 'a', 'type': 'string', 'nullable': True}
>>> to_openapi30_schema({"const": "process", "exclusiveMinimum": 0})
{'enum': ['process'], 'minimum': 0, 'exclusiveMinimum': True}
"""

from __future__ import annotations

from typing import Any

from .formats import FORMATS

__all__ = ["complete", "to_openapi30", "to_openapi30_schema"]

#: JSON Schema keywords OpenAPI 3.0's Schema Object does not have (dropped: they only annotate).
_DROPPED = frozenset(
    {
        "$schema",
        "$id",
        "$defs",
        "$comment",
        "contentMediaType",
        "contentEncoding",
        "propertyNames",
        "unevaluatedProperties",
        "dependentRequired",
        "dependentSchemas",
        "if",
        "then",
        "else",
    }
)
#: Keywords whose value is one subschema, and those whose value is a list or a map of them.
_ONE = ("items", "not", "additionalProperties")
_LISTS = ("allOf", "anyOf", "oneOf")
_MAPS = ("properties", "patternProperties")


#: JSON Schema's ``{"type": "null"}`` in 3.0 words.
_NULL = {"nullable": True, "enum": [None]}


def _is_null(schema: Any) -> bool:
    return schema == _NULL


def _nullable(schema: dict[str, Any], rest: dict[str, Any]) -> dict[str, Any]:
    """``schema`` or null: 3.0 says ``nullable`` (next to a ``$ref`` only through ``allOf``)."""
    out = dict(rest)
    if "$ref" in schema:
        out["allOf"] = [schema]
    else:
        out.update(schema)
    out["nullable"] = True
    return out


def to_openapi30_schema(schema: Any) -> Any:
    """A JSON Schema (2020-12, as pydantic writes it) as an OpenAPI 3.0 Schema Object."""
    if isinstance(schema, list):
        return [to_openapi30_schema(s) for s in schema]
    if not isinstance(schema, dict):
        return schema
    out: dict[str, Any] = {}
    for key, value in schema.items():
        if key in _DROPPED:
            continue
        if key in _ONE and isinstance(value, dict):
            out[key] = to_openapi30_schema(value)
        elif key in _LISTS:
            out[key] = [to_openapi30_schema(s) for s in value]
        elif key in _MAPS:
            out[key] = {name: to_openapi30_schema(s) for name, s in value.items()}
        elif key == "prefixItems":  # a tuple: 3.0 has only homogeneous arrays
            out.setdefault("items", {})
        elif key == "const":
            out["enum"] = [value]
        elif key == "examples":
            if isinstance(value, list) and value:
                out["example"] = value[0]
        elif key in ("exclusiveMinimum", "exclusiveMaximum") and not isinstance(value, bool):
            out["minimum" if key == "exclusiveMinimum" else "maximum"] = value
            out[key] = True
        elif key == "type" and value == "null":
            out.update(_NULL)
        elif key == "type" and isinstance(value, list):
            kinds = [k for k in value if k != "null"]
            if not kinds:
                out.update(_NULL)
            elif len(kinds) == 1:
                out["type"] = kinds[0]
            else:
                out["anyOf"] = [{"type": k} for k in kinds]
            if "null" in value:
                out["nullable"] = True
        else:
            out[key] = value
    for key in ("anyOf", "oneOf"):
        options = out.get(key)
        if isinstance(options, list) and any(_is_null(o) for o in options):
            kept = [o for o in options if not _is_null(o)]
            rest = {k: v for k, v in out.items() if k != key}
            if not kept:
                out = {**rest, **_NULL}
            elif len(kept) == 1:
                out = _nullable(kept[0], rest)
            else:
                out = {**rest, key: kept, "nullable": True}
    if "$ref" in out and len(out) > 1:  # 3.0 ignores a $ref's siblings: keep them beside it
        out = {"allOf": [{"$ref": out.pop("$ref")}], **out}
    return out


def _media(content: dict[str, Any]) -> None:
    for media in content.values():
        if "schema" in media:
            media["schema"] = to_openapi30_schema(media["schema"])


def to_openapi30(document: dict[str, Any]) -> dict[str, Any]:
    """``document`` (OpenAPI 3.1) rewritten in place as OpenAPI 3.0.3, and returned."""
    document["openapi"] = "3.0.3"
    info = document.get("info", {})
    summary = info.pop("summary", None)  # 3.1 only
    if summary and "description" not in info:
        info["description"] = summary
    info.get("license", {}).pop("identifier", None)
    document.pop("webhooks", None)
    document.pop("jsonSchemaDialect", None)
    components = document.setdefault("components", {})
    schemas = components.get("schemas", {})
    for name, schema in schemas.items():
        schemas[name] = to_openapi30_schema(schema)
    for path in document.get("paths", {}).values():
        for operation in path.values():
            if not isinstance(operation, dict):
                continue
            for parameter in operation.get("parameters", []):
                if "schema" in parameter:
                    parameter["schema"] = to_openapi30_schema(parameter["schema"])
                parameter.pop("examples", None)  # a 3.1-style list would be invalid here
            _media(operation.get("requestBody", {}).get("content", {}))
            for response in operation.get("responses", {}).values():
                _media(response.get("content", {}))
                for header in response.get("headers", {}).values():
                    if "schema" in header:
                        header["schema"] = to_openapi30_schema(header["schema"])
    return document


#: The API keys the service accepts (``deps.require_api_key``), when it is given keys.
SECURITY_SCHEMES = {
    "apiKey": {"type": "apiKey", "in": "header", "name": "X-API-Key"},
    "bearer": {"type": "http", "scheme": "bearer", "description": "the API key as a token"},
}
#: Keyed operations: either scheme, or none when the service runs without keys.
_SECURITY: list[dict[str, list[str]]] = [{"apiKey": []}, {"bearer": []}, {}]
_KEYED = ("/jobs", "/batches")


def _picture_parameters() -> list[dict[str, Any]]:
    """The picture options of ``f=png|svg`` (read by ``render.PictureOptions.from_query``)."""
    from .render import METRICS

    def query(name: str, schema: dict[str, Any], text: str) -> dict[str, Any]:
        return {
            "name": name,
            "in": "query",
            "required": False,
            "schema": schema,
            "description": text,
        }

    flag = {"type": "string", "enum": ["1", "0", "true", "false"]}
    return [
        query("color", {"type": "string", "enum": list(METRICS)}, "picture: triangle colouring"),
        query("compare", flag, "picture: before and after, with quality histograms"),
        query("edges", flag, "picture: draw the triangle edges"),
        query("width", {"type": "integer", "minimum": 100, "maximum": 8000}, "picture: pixels"),
        query("height", {"type": "integer", "minimum": 100, "maximum": 8000}, "picture: pixels"),
        query(
            "worst",
            {"type": "integer", "minimum": 0, "maximum": 10000},
            "picture: mark the n worst",
        ),
        query("vmin", {"type": "number"}, "picture: low end of the colour range"),
        query("vmax", {"type": "number"}, "picture: high end of the colour range"),
    ]


def complete(document: dict[str, Any]) -> None:
    """Add what FastAPI cannot infer: the security schemes (and which operations take a key),
    the enum of ``f`` and the picture options of the results route."""
    components = document.setdefault("components", {})
    components["securitySchemes"] = SECURITY_SCHEMES
    for path, item in document.get("paths", {}).items():
        for operation in item.values():
            if path.startswith(_KEYED) or path.endswith("/execution"):
                operation["security"] = _SECURITY
            if path == "/jobs/{jobId}/results":
                for parameter in operation.get("parameters", []):
                    if parameter["name"] == "f":
                        parameter["schema"]["enum"] = [
                            name for name, f in FORMATS.items() if f.writer is not None
                        ]
                operation.setdefault("parameters", []).extend(_picture_parameters())
