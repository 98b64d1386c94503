"""The served OpenAPI document is 3.0 (the ``oas30`` class we claim) and complete."""

from __future__ import annotations

from typing import Any

import httpx
import pytest
from hypothesis import given
from hypothesis import strategies as st

from service.openapi import to_openapi30_schema
from service.render import METRICS

pytestmark = pytest.mark.anyio

OAS30_SCHEMA_KEYS = {
    "title",
    "multipleOf",
    "maximum",
    "exclusiveMaximum",
    "minimum",
    "exclusiveMinimum",
    "maxLength",
    "minLength",
    "pattern",
    "maxItems",
    "minItems",
    "uniqueItems",
    "maxProperties",
    "minProperties",
    "required",
    "enum",
    "type",
    "allOf",
    "oneOf",
    "anyOf",
    "not",
    "items",
    "properties",
    "additionalProperties",
    "description",
    "format",
    "default",
    "nullable",
    "discriminator",
    "readOnly",
    "writeOnly",
    "xml",
    "externalDocs",
    "example",
    "deprecated",
    "$ref",
}
OAS30_TYPES = {"string", "number", "integer", "boolean", "array", "object"}


def _assert_schema30(schema: Any, where: str) -> None:
    """``schema`` is an OpenAPI 3.0 Schema Object (the keywords and their value types)."""
    assert isinstance(schema, dict), where
    if "$ref" in schema:
        assert set(schema) == {"$ref"}, f"{where}: siblings of $ref are ignored in 3.0"
        return
    extra = {k for k in schema if not k.startswith("x-")} - OAS30_SCHEMA_KEYS
    assert not extra, f"{where}: not 3.0 keywords {extra}"
    if "type" in schema:
        assert schema["type"] in OAS30_TYPES, f"{where}: type {schema['type']!r}"
    for key in ("exclusiveMinimum", "exclusiveMaximum"):
        if key in schema:
            assert isinstance(schema[key], bool), where
    for key in ("allOf", "oneOf", "anyOf"):
        for i, sub in enumerate(schema.get(key, [])):
            _assert_schema30(sub, f"{where}/{key}/{i}")
    for key in ("items", "not"):
        if key in schema:
            _assert_schema30(schema[key], f"{where}/{key}")
    if isinstance(schema.get("additionalProperties"), dict):
        _assert_schema30(schema["additionalProperties"], f"{where}/additionalProperties")
    for name, sub in schema.get("properties", {}).items():
        _assert_schema30(sub, f"{where}/properties/{name}")


def _schemas(doc: dict[str, Any]) -> list[tuple[str, Any]]:
    out = [(f"#/components/schemas/{n}", s) for n, s in doc["components"]["schemas"].items()]
    for path, item in doc["paths"].items():
        for method, op in item.items():
            at = f"{method} {path}"
            out += [(f"{at} {p['name']}", p["schema"]) for p in op.get("parameters", [])]
            content = op.get("requestBody", {}).get("content", {})
            out += [(f"{at} body", m["schema"]) for m in content.values() if "schema" in m]
            for code, response in op["responses"].items():
                for media in response.get("content", {}).values():
                    if "schema" in media:
                        out.append((f"{at} {code}", media["schema"]))
                for name, header in response.get("headers", {}).items():
                    out.append((f"{at} {code} {name}", header["schema"]))
    return out


async def _document(client: httpx.AsyncClient) -> dict[str, Any]:
    r = await client.get("/openapi.json")
    assert r.status_code == 200
    doc: dict[str, Any] = r.json()
    return doc


async def test_the_document_is_openapi_30(client: httpx.AsyncClient) -> None:
    doc = await _document(client)
    assert doc["openapi"] == "3.0.3"
    assert "summary" not in doc["info"]
    schemas = _schemas(doc)
    assert len(schemas) > 50
    for where, schema in schemas:
        _assert_schema30(schema, where)
    conformance = (await client.get("/conformance")).json()["conformsTo"]
    assert "http://www.opengis.net/spec/ogcapi-processes-1/1.0/conf/oas30" in conformance


async def test_security_enums_prefer_and_result_responses(client: httpx.AsyncClient) -> None:
    doc = await _document(client)
    schemes = doc["components"]["securitySchemes"]
    assert schemes["apiKey"] == {"type": "apiKey", "in": "header", "name": "X-API-Key"}
    assert schemes["bearer"]["scheme"] == "bearer"
    results = doc["paths"]["/jobs/{jobId}/results"]["get"]
    assert {"apiKey": []} in results["security"]
    params = {p["name"]: p for p in results["parameters"]}
    assert set(params["f"]["schema"]["enum"]) >= {"json", "geojson", "png", "svg"}
    assert params["color"]["schema"]["enum"] == list(METRICS)
    assert {"304", "404", "406", "409", "410"} <= set(results["responses"])
    execute = doc["paths"]["/processes/mesh/execution"]["post"]
    assert "Prefer" in {p["name"] for p in execute["parameters"] if p["in"] == "header"}
    assert {"200", "201"} <= set(execute["responses"])
    assert "security" not in doc["paths"]["/conformance"]["get"]


json_schemas = st.recursive(
    st.fixed_dictionaries({"type": st.sampled_from(["string", "integer", "null"])}),
    lambda inner: st.one_of(
        st.fixed_dictionaries({"anyOf": st.lists(inner, min_size=1, max_size=3)}),
        st.fixed_dictionaries({"items": inner, "type": st.just("array")}),
        st.fixed_dictionaries(
            {"properties": st.dictionaries(st.text(max_size=3), inner, max_size=3)}
        ),
        st.fixed_dictionaries(
            {"const": st.integers(), "examples": st.lists(st.integers(), max_size=2)}
        ),
        st.fixed_dictionaries(
            {
                "type": st.lists(
                    st.sampled_from(["string", "null"]), min_size=1, max_size=2, unique=True
                )
            }
        ),
    ),
    max_leaves=8,
)


@given(json_schemas)
def test_conversion_leaves_no_31_keyword(schema: dict[str, Any]) -> None:
    converted = to_openapi30_schema(schema)

    def check(s: Any) -> None:
        assert "const" not in s
        assert "examples" not in s
        assert s.get("type", "string") in OAS30_TYPES
        for key in ("anyOf", "oneOf", "allOf"):
            for sub in s.get(key, []):
                check(sub)
        for sub in s.get("properties", {}).values():
            check(sub)
        if "items" in s:
            check(s["items"])

    check(converted)
