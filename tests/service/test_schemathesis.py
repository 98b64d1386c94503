"""Property-based testing of our own OpenAPI document: no input makes the service fail (5xx),
and every response matches what the document says (status, media type, schema, headers).

The service runs for real on a loopback port (its lifespan, workers and store included), with
small limits so generated jobs stay tiny; examples per operation are bounded.
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
import schemathesis
from hypothesis import HealthCheck, settings
from schemathesis import checks

from service.app import create_app

from .conftest import make_settings
from .live import serving

CHECKS = [
    checks.not_a_server_error,
    checks.status_code_conformance,
    checks.content_type_conformance,
    checks.response_schema_conformance,
    checks.response_headers_conformance,
]


def _app(data_dir: Path):  # type: ignore[no-untyped-def]
    return create_app(
        make_settings(
            data_dir,
            max_vertices=200,
            max_rings=10,
            max_triangles=2_000,
            max_body_bytes=256 * 1024,
            max_batch_items=5,
            job_timeout=10.0,
        )
    )


schema = schemathesis.openapi.from_dict(_app(Path(tempfile.gettempdir())).openapi())


@pytest.fixture(scope="module")
def base_url(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    with serving(_app(tmp_path_factory.mktemp("schemathesis"))) as url:
        # /ready is 503 (rightly) until the workers have warmed up: test the service once it is.
        deadline = time.monotonic() + 180
        while httpx.get(f"{url}/ready").status_code != 200:
            assert time.monotonic() < deadline, "the workers did not warm up in 180 s"
            time.sleep(0.1)
        yield url


@schema.parametrize()
@settings(
    max_examples=25,
    deadline=None,
    suppress_health_check=list(HealthCheck),
    derandomize=True,
)
def test_api_never_fails(case: schemathesis.Case, base_url: str) -> None:
    case.call_and_validate(base_url=base_url, checks=CHECKS)
