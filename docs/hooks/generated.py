"""mkdocs hook: reference sections generated at build time, so the docs cannot drift from the code.

A page asks for a section with a marker line ``<!-- generated: NAME -->``; ``GENERATORS`` maps each
name to the function that writes its markdown:

- ``openapi``: every path, operation and schema of the service's OpenAPI document
  (``service.app.create_app``), as tables;
- ``settings``: every ``EVOMESH_*`` setting of ``service.settings.Settings``;
- ``mesh-document``: the members of the mesh document's JSON Schema (the file the service serves);
- ``benchmarks``: one table per result file in ``benchmarks/results/`` (``benchmarks/record.py``).

The README's pictures (``service/static/img``) are added to the site as ``img/...``.
"""

from __future__ import annotations

import json
import re
import tempfile
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any, Literal, get_args, get_origin

ROOT = Path(__file__).resolve().parents[2]
RESULTS = ROOT / "benchmarks" / "results"
IMAGES = ROOT / "service" / "static" / "img"
SCHEMA = ROOT / "service" / "static" / "schemas" / "mesh-document.json"
_MARKER = re.compile(r"^<!-- generated: ([a-z-]+) -->$", re.MULTILINE)
_METHODS = ("get", "post", "put", "patch", "delete")


def _cell(value: object) -> str:
    """Text safe in a markdown table cell."""
    text = "" if value is None else str(value)
    return text.replace("|", "\\|").replace("\n", " ").strip()


def table(header: Iterable[str], rows: Iterable[Iterable[object]]) -> str:
    """A markdown table.

    >>> print(table(["a", "b"], [[1, "x|y"]]))
    | a | b |
    |---|---|
    | 1 | x\\|y |
    """
    head = list(header)
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(_cell(v) for v in row) + " |" for row in rows]
    return "\n".join(lines)


def type_of(schema: Mapping[str, Any]) -> str:
    """A short name for a JSON Schema's type.

    >>> type_of({"anyOf": [{"type": "integer"}, {"type": "null"}]})
    'integer or null'
    >>> type_of({"type": "array", "items": {"$ref": "#/components/schemas/Link"}})
    'array of Link'
    """
    if "$ref" in schema:
        return str(schema["$ref"]).rsplit("/", 1)[-1]
    for key in ("anyOf", "oneOf"):
        if key in schema:
            return " or ".join(type_of(s) for s in schema[key])
    if "enum" in schema:
        return " \\| ".join(f"`{json.dumps(v)}`" for v in schema["enum"])
    if "const" in schema:
        return f"`{json.dumps(schema['const'])}`"
    kind = schema.get("type", "any")
    if isinstance(kind, list):
        return " or ".join(kind)
    if kind == "array" and isinstance(schema.get("items"), Mapping):
        return f"array of {type_of(schema['items'])}"
    return str(kind)


def _properties(schema: Mapping[str, Any]) -> str:
    required = set(schema.get("required", []))
    rows = [
        (f"`{name}`", type_of(prop), "yes" if name in required else "", prop.get("description"))
        for name, prop in schema.get("properties", {}).items()
    ]
    return table(["member", "type", "required", "description"], rows) if rows else ""


def render_openapi(doc: Mapping[str, Any]) -> str:
    """The operations and schemas of an OpenAPI document as markdown."""
    out = [f"OpenAPI {doc.get('openapi', '')}, API version {doc['info'].get('version', '')}."]
    for path, item in doc.get("paths", {}).items():
        for method in _METHODS:
            op = item.get(method)
            if op is None:
                continue
            out.append(f"### `{method.upper()} {path}`")
            out.append(op.get("summary", ""))
            if op.get("description"):
                out.append(op["description"])
            params = [
                (
                    f"`{p['name']}`",
                    p["in"],
                    type_of(p.get("schema", {})),
                    "yes" if p.get("required") else "",
                    p.get("description"),
                )
                for p in op.get("parameters", [])
            ]
            if params:
                out.append(table(["parameter", "in", "type", "required", "description"], params))
            body = op.get("requestBody", {}).get("content", {})
            if body:
                out.append(
                    "Request body: "
                    + ", ".join(f"`{m}` ({type_of(c.get('schema', {}))})" for m, c in body.items())
                )
            responses = [
                (code, r.get("description"), ", ".join(f"`{m}`" for m in r.get("content", {})))
                for code, r in op.get("responses", {}).items()
            ]
            out.append(table(["status", "meaning", "media types"], responses))
    schemas = doc.get("components", {}).get("schemas", {})
    if schemas:
        out.append("## Schemas")
    for name, schema in schemas.items():
        out.append(f"### {name}")
        if schema.get("description"):
            out.append(schema["description"])
        out.append(_properties(schema) or f"Type: {type_of(schema)}.")
    return "\n\n".join(part for part in out if part) + "\n"


def _openapi_document() -> dict[str, Any]:
    from service.app import create_app
    from service.settings import Settings

    with tempfile.TemporaryDirectory() as data:
        # No lifespan runs: building the app starts no store and no workers.
        app = create_app(Settings(_env_file=None, data_dir=Path(data), workers=1))
        return app.openapi()


def render_settings() -> str:
    """Every setting: its variable, default, bounds and meaning."""
    from service.settings import Settings

    rows = []
    for name, field in Settings.model_fields.items():
        if field.default_factory is list:
            default = "none"
        elif field.default_factory is not None:
            default = "computed at start"
        elif field.default is None:
            default = "none"
        else:
            default = f"`{field.default}`"
        bounds = ", ".join(
            f"{op} {getattr(m, attr)}"
            for m in field.metadata
            for attr, op in (("ge", ">="), ("gt", ">"), ("le", "<="), ("lt", "<"))
            if hasattr(m, attr)
        )
        if get_origin(field.annotation) is Literal:
            bounds = "one of " + ", ".join(f"`{v}`" for v in get_args(field.annotation))
        rows.append((f"`EVOMESH_{name.upper()}`", default, bounds, field.description))
    return table(["variable", "default", "bounds", "meaning"], rows) + "\n"


def render_schema(schema: Mapping[str, Any]) -> str:
    """The top-level members of a JSON Schema, its local ``$defs`` resolved one level."""
    defs = schema.get("$defs", {})
    props = {}
    for name, prop in schema.get("properties", {}).items():
        ref = str(prop.get("$ref", ""))
        if ref.startswith("#/$defs/"):
            prop = {**defs[ref.removeprefix("#/$defs/")], **prop}
            prop.pop("$ref")
        props[name] = prop
    resolved = {**schema, "properties": props}
    return (schema.get("description", "") + "\n\n" + _properties(resolved)).strip() + "\n"


def _number(value: object) -> str:
    if isinstance(value, bool) or not isinstance(value, int | float):
        return "" if value is None else str(value)
    if isinstance(value, int):
        return f"{value:,}"
    return f"{value:,.0f}" if abs(value) >= 1000 else f"{value:.4g}"


def render_result(name: str, doc: Mapping[str, Any]) -> str:
    """One benchmark result file as a section with its table.

    >>> print(render_result("x", {"title": "T", "rows": [{"case": "a", "s": 0.12345}]}))
    ### T
    <BLANKLINE>
    `benchmarks/results/x.json`
    <BLANKLINE>
    | case | s |
    |---|---|
    | a | 0.1235 |
    <BLANKLINE>
    """
    rows: list[Mapping[str, Any]] = doc.get("rows", [])
    columns: dict[str, None] = {}
    for row in rows:
        columns.update(dict.fromkeys(row))
    source = f"`benchmarks/results/{name}.json`"
    if doc.get("machine"):
        source += f", measured on {doc['machine']}"
    parts = [f"### {doc.get('title') or name}", source, doc.get("notes", "")]
    parts.append(table(columns, ([_number(r.get(c)) for c in columns] for r in rows)))
    return "\n\n".join(p for p in parts if p) + "\n"


def render_benchmarks(results: Path = RESULTS) -> str:
    """A section per result file, or a line saying there is none yet."""
    files = sorted(results.glob("*.json"))
    if not files:
        return "No result files yet: `make bench` writes them to `benchmarks/results/`.\n"
    listing = ", ".join(f"`{f.name}`" for f in files)
    sections = [render_result(f.stem, json.loads(f.read_text())) for f in files]
    return f"Result files: {listing}.\n\n" + "\n".join(sections)


GENERATORS: dict[str, Callable[[], str]] = {
    "openapi": lambda: render_openapi(_openapi_document()),
    "settings": render_settings,
    "mesh-document": lambda: render_schema(json.loads(SCHEMA.read_text())),
    "benchmarks": render_benchmarks,
}


def expand(markdown: str) -> str:
    """``markdown`` with each marker replaced by its generated section."""

    def one(match: re.Match[str]) -> str:
        name = match.group(1)
        if name not in GENERATORS:
            raise KeyError(f"no generator {name!r}; known: {sorted(GENERATORS)}")
        return GENERATORS[name]()

    return _MARKER.sub(one, markdown)


def on_page_markdown(markdown: str, **kwargs: Any) -> str:
    return expand(markdown)


def on_files(files: Any, *, config: Any) -> Any:
    from mkdocs.structure.files import File

    for image in sorted(IMAGES.glob("*.png")):
        files.append(File.generated(config, f"img/{image.name}", abs_src_path=str(image)))
    return files
