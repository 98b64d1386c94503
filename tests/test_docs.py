"""The docs: generated reference sections, the mesh document's JSON Schema, offline ``/docs``."""

from __future__ import annotations

import asyncio
import doctest
import importlib.util
import json
import sys
import tempfile
from pathlib import Path
from types import ModuleType
from typing import Any

import httpx
import jsonschema_rs
import pytest

from service.app import create_app
from service.formats import FORMATS
from service.settings import Settings
from tests.conftest import load_case
from tests.e2e.browser import Browser, chromium_path
from tests.e2e.server import Server

ROOT = Path(__file__).resolve().parents[1]
SCHEMA_FILE = ROOT / "service" / "static" / "schemas" / "mesh-document.json"


def _load(name: str, path: Path) -> ModuleType:
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


hooks = _load("docs_hooks_generated", ROOT / "docs" / "hooks" / "generated.py")


def _app(data_dir: str) -> Any:
    return create_app(Settings(_env_file=None, data_dir=Path(data_dir), workers=1))


# -- generated sections ---------------------------------------------------------------------------


def test_settings_table_names_every_setting_with_its_meaning() -> None:
    text = hooks.render_settings()
    for name, field in Settings.model_fields.items():
        assert field.description, name
        assert f"| `EVOMESH_{name.upper()}` |" in text
    assert "one of `local`, `dask`" in text


def test_api_reference_has_every_operation_and_schema(tmp_path: Path) -> None:
    doc = _app(str(tmp_path)).openapi()
    text = hooks.render_openapi(doc)
    operations = [
        f"### `{method.upper()} {path}`"
        for path, item in doc["paths"].items()
        for method in item
        if method in ("get", "post", "delete")
    ]
    assert len(operations) > 10
    for heading in operations:
        assert heading in text
    for name in doc["components"]["schemas"]:
        assert f"### {name}\n" in text


def test_benchmark_tables_come_from_the_result_files(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    assert "No result files yet" in hooks.render_benchmarks(tmp_path)
    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        import record
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    monkeypatch.setattr(record, "RESULTS", tmp_path)
    rows = [{"case": "l_shape", "triangles": 7884, "s": 0.05234}, {"case": "a|b", "s": 1234.5}]
    record.write_rows("mesh", rows, title="Mesher", notes="same run")
    text = hooks.render_benchmarks(tmp_path)
    assert "### Mesher" in text
    assert "same run" in text
    assert "| case | triangles | s |" in text
    assert "| l_shape | 7,884 | 0.05234 |" in text
    assert "| a\\|b |  | 1,234 |" in text  # a missing column stays empty; pipes are escaped


def test_hook_docstring_examples() -> None:
    result = doctest.testmod(hooks, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0
    assert result.failed == 0


def test_markers_expand_and_unknown_ones_fail() -> None:
    page = "# Settings\n\n<!-- generated: settings -->\n"
    assert "`EVOMESH_WORKERS`" in hooks.expand(page)
    with pytest.raises(KeyError, match="no generator"):
        hooks.expand("<!-- generated: nothing-like-it -->\n")


# -- the mesh document's JSON Schema --------------------------------------------------------------

SQUARE = {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]]}
SMALL_GA = {"method": "ga", "population": 8, "generations": 4, "max_sweeps": 1, "seed": 3}


async def _run(api: httpx.AsyncClient, process: str, inputs: dict[str, Any]) -> str:
    r = await api.post(f"/processes/{process}/execution", json={"inputs": inputs})
    assert r.status_code == 201, r.text
    job = r.headers["Location"]
    for _ in range(3000):
        status = (await api.get(job)).json()
        if status["status"] not in ("accepted", "running"):
            break
        await asyncio.sleep(0.05)
    assert status["status"] == "successful", status
    return str(job)


async def _documents_and_formats() -> tuple[Any, dict[str, dict[str, Any]], dict[str, set[int]]]:
    """The served schema, each process's result document, and the status of every format."""
    documents: dict[str, dict[str, Any]] = {}
    formats: dict[str, set[int]] = {}
    with tempfile.TemporaryDirectory() as data:
        app = _app(data)
        async with app.router.lifespan_context(app):
            transport = httpx.ASGITransport(app=app)
            async with httpx.AsyncClient(transport=transport, base_url="http://evomesh") as api:
                r = await api.get("/schemas/mesh-document.json")
                assert r.status_code == 200
                assert r.headers["content-type"].startswith("application/schema+json")
                schema = r.json()
                lonlat = {
                    "type": "Polygon",
                    "coordinates": [[[10, 50], [10.01, 50], [10, 50.01], [10, 50]]],
                }
                jobs = {
                    "mesh": await _run(
                        api, "mesh", {"boundary": SQUARE, "size": 0.2, "smoothing": SMALL_GA}
                    ),
                    "mesh-wgs84": await _run(
                        api,
                        "mesh",
                        {
                            "boundary": lonlat,
                            "size": 200,
                            "coordinates": "wgs84",
                            "smoothing": {"method": "none"},
                        },
                    ),
                    "mesh-case": await _run(
                        api,
                        "mesh",
                        {
                            "boundary": load_case("annulus"),
                            "size": 0.2,
                            "smoothing": {"method": "none"},
                        },
                    ),
                }
                mesh = (await api.get(f"{jobs['mesh']}/results")).json()
                small = {"points": mesh["points"], "triangles": mesh["triangles"]}
                jobs["smooth"] = await _run(api, "smooth", {"mesh": small, "smoothing": SMALL_GA})
                jobs["quality"] = await _run(api, "quality", {"mesh": small})
                for name, job in jobs.items():
                    documents[name] = (await api.get(f"{job}/results?f=json")).json()
                    formats[name] = {
                        (await api.get(f"{job}/results", params={"f": f})).status_code
                        for f in FORMATS
                    }
    return schema, documents, formats


@pytest.fixture(scope="module")
def served() -> tuple[Any, dict[str, dict[str, Any]], dict[str, set[int]]]:
    return asyncio.run(_documents_and_formats())


def test_the_served_schema_is_the_published_file(served: tuple[Any, ...]) -> None:
    schema, _, _ = served
    assert schema == json.loads(SCHEMA_FILE.read_text())
    jsonschema_rs.meta.validate(schema)


def test_every_process_result_validates_and_renders_in_every_format(
    served: tuple[Any, ...],
) -> None:
    schema, documents, formats = served
    validator = jsonschema_rs.validator_for(schema)
    assert set(documents) == {"mesh", "mesh-wgs84", "mesh-case", "smooth", "quality"}
    for name, doc in documents.items():
        errors = [str(e) for e in validator.iter_errors(doc)]
        assert not errors, (name, errors[:3])
        assert formats[name] == {200}, (name, formats[name])
    assert documents["mesh"]["summary"]["history"]  # the GA's sweeps are in the schema's scope
    assert "points" in documents["mesh-wgs84"]["projected"]
    assert documents["mesh-wgs84"]["crs"]["geographic"] is True


@pytest.mark.parametrize(
    "breakage",
    [
        lambda d: d.pop("points"),
        lambda d: d["triangles"][0].pop(),
        lambda d: d["points"][0].append(0.0),
        lambda d: d["cell_data"]["quality"].__setitem__(0, 1.5),
        lambda d: d["summary"]["smoothed"].pop("count"),
        lambda d: d["point_data"]["boundary"].__setitem__(0, 2),
    ],
)
def test_the_schema_rejects_broken_documents(served: tuple[Any, ...], breakage: Any) -> None:
    schema, documents, _ = served
    doc = json.loads(json.dumps(documents["mesh"]))
    breakage(doc)
    assert not jsonschema_rs.validator_for(schema).is_valid(doc)


# -- /docs offline --------------------------------------------------------------------------------


@pytest.mark.e2e
def test_swagger_ui_renders_offline_from_the_service_alone(tmp_path: Path) -> None:
    assert chromium_path(), "chromium is not installed: `make test` installs it (APT_PACKAGES)"
    server = Server(tmp_path / "data", workers=1)
    try:
        operations = {
            (method.upper(), path)
            for path, item in server.client.get("/openapi.json").json()["paths"].items()
            for method in item
            if method in ("get", "post", "delete")
        }
        with Browser(tmp_path / "profile", timeout=60) as b:
            b.call("Network.enable")
            b.goto(f"{server.url}/docs")
            # Every operation's summary line is on the page: Swagger UI loaded and rendered.
            shown = b.wait_for(
                "(() => { const rows = [...document.querySelectorAll('.opblock-summary')]"
                ".map(r => [r.querySelector('.opblock-summary-method').textContent,"
                " r.querySelector('.opblock-summary-path').dataset.path]);"
                f" return rows.length >= {len(operations)} && rows; }})()",
                timeout=60,
            )
            title = b.evaluate("document.querySelector('.info .title').textContent")
            requested = [
                e["params"]["request"]["url"]
                for e in b.events
                if e.get("method") == "Network.requestWillBeSent"
            ]
            errors = b.console_errors()
    finally:
        server.stop()
    assert {(method, path) for method, path in shown} == operations
    assert "evomesh" in title
    assert requested
    outside = [u for u in requested if not u.startswith((server.url, "data:", "blob:"))]
    assert not outside, outside
    assert not errors, errors


@pytest.mark.parametrize(
    "page", [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))], ids=lambda p: p.name
)
def test_every_fenced_block_renders_as_code(page: Path) -> None:
    """The site's Markdown (mkdocs.yml's extensions) turns every fence into a code block.

    An info string the fences do not understand (``sh run`` once) leaves the block as text and
    runs the rest of the page into one code block, headings included.
    """
    import markdown
    import yaml

    config = yaml.load((ROOT / "mkdocs.yml").read_text(), Loader=yaml.BaseLoader)
    extensions = [e if isinstance(e, str) else next(iter(e)) for e in config["markdown_extensions"]]
    text = page.read_text()
    fences = sum(1 for line in text.splitlines() if line.startswith("```")) // 2
    html = markdown.markdown(text, extensions=extensions)
    assert "```" not in html
    assert html.count("<pre") == fences
