"""Interactive API docs and published schemas, served from the package (no CDN), so both work on
a machine without internet.

``/docs`` is Swagger UI from the vendored ``swagger-ui-dist`` under ``static/vendor/swagger-ui``
(FastAPI's own page would load it from a CDN); ``/schemas/mesh-document.json`` is the JSON
Schema of the mesh document every result format is written from.
"""

from __future__ import annotations

from functools import cache

from fastapi import APIRouter, Request
from fastapi.openapi.docs import get_swagger_ui_html
from fastapi.responses import HTMLResponse, Response

from .viewer import STATIC

__all__ = ["MESH_DOCUMENT_SCHEMA", "router"]

#: The mesh document's JSON Schema (package data).
MESH_DOCUMENT_SCHEMA = STATIC / "schemas" / "mesh-document.json"

_SWAGGER = "/static/vendor/swagger-ui"

router = APIRouter(include_in_schema=False)


@router.get("/docs", response_class=HTMLResponse)
def swagger_ui(request: Request) -> HTMLResponse:
    root = request.scope.get("root_path", "")
    return get_swagger_ui_html(
        openapi_url=f"{root}{request.app.openapi_url}",
        title=f"{request.app.title} - API",
        swagger_js_url=f"{root}{_SWAGGER}/swagger-ui-bundle.js",
        swagger_css_url=f"{root}{_SWAGGER}/swagger-ui.css",
        swagger_favicon_url=f"{root}/static/favicon.svg",
        # no badge from validator.swagger.io: nothing on the page may need the internet
        swagger_ui_parameters={"validatorUrl": None},
    )


@cache
def _schema() -> bytes:
    return MESH_DOCUMENT_SCHEMA.read_bytes()


@router.get("/schemas/mesh-document.json")
def mesh_document_schema() -> Response:
    """The JSON Schema (draft 2020-12) of the mesh document."""
    return Response(
        _schema(),
        media_type="application/schema+json",
        headers={"Cache-Control": "public, max-age=3600"},
    )
