"""Results over HTTP: links per media type, Accept negotiation, ETag / If-None-Match, gzip."""

from __future__ import annotations

import httpx
import pytest

from service.formats import FORMATS
from service.views import REL_RESULTS

from ..conftest import SQUARE, assert_problem, submit, wait_for

pytestmark = pytest.mark.anyio

MESH = {"boundary": SQUARE, "size": 0.1, "smoothing": {"method": "none"}}


async def _done(client: httpx.AsyncClient) -> dict[str, object]:
    job = await submit(client, "mesh", MESH)
    done = await wait_for(client, str(job["jobID"]))
    assert done["status"] == "successful", done
    return done


async def test_one_results_link_per_media_type(client: httpx.AsyncClient) -> None:
    done = await _done(client)
    links = [link for link in done["links"] if link["rel"] == REL_RESULTS]  # type: ignore[attr-defined]
    offered = [f.media_type for f in FORMATS.values() if f.writer is not None]
    assert [link["type"] for link in links] == offered
    for link in links:  # each link answers in its media type
        r = await client.get(link["href"])
        assert r.status_code == 200, (link, r.text)
        assert r.headers["content-type"].startswith(link["type"])


@pytest.mark.parametrize(
    ("accept", "media"),
    [
        ("application/geo+json", "application/geo+json"),
        ("image/svg+xml;q=0.4, application/geo+json;q=0.9", "application/geo+json"),
        ("image/*", "image/svg+xml"),
        ("*/*", "application/json"),
        (None, "application/json"),
    ],
)
async def test_accept_negotiation(
    client: httpx.AsyncClient, accept: str | None, media: str
) -> None:
    done = await _done(client)
    headers = {"Accept": accept} if accept else {}
    r = await client.get(f"/jobs/{done['jobID']}/results", headers=headers)
    assert r.status_code == 200, r.text
    assert r.headers["content-type"].startswith(media)
    assert "Accept" in r.headers["vary"]


async def test_f_wins_over_accept_and_nothing_acceptable_is_406(client: httpx.AsyncClient) -> None:
    done = await _done(client)
    url = f"/jobs/{done['jobID']}/results"
    r = await client.get(url, params={"f": "geojson"}, headers={"Accept": "image/png"})
    assert r.headers["content-type"].startswith("application/geo+json")
    assert_problem(await client.get(url, headers={"Accept": "text/csv"}), 406, "not-acceptable")


async def test_etag_and_not_modified(client: httpx.AsyncClient) -> None:
    done = await _done(client)
    url = f"/jobs/{done['jobID']}/results"
    first = await client.get(url, params={"f": "geojson"})
    tag = first.headers["etag"]
    assert first.headers["cache-control"] == "private, no-cache"
    again = await client.get(url, params={"f": "geojson"}, headers={"If-None-Match": tag})
    assert again.status_code == 304
    assert again.content == b""
    assert again.headers["etag"] == tag
    other = await client.get(url, params={"f": "json"}, headers={"If-None-Match": tag})
    assert other.status_code == 200  # another format is another entity
    assert other.headers["etag"] != tag
    await client.delete(f"/jobs/{done['jobID']}")
    gone = await client.get(url, params={"f": "geojson"}, headers={"If-None-Match": tag})
    assert gone.status_code == 410  # a dismissed job is never "not modified"


async def test_json_and_geojson_are_gzipped(client: httpx.AsyncClient) -> None:
    done = await _done(client)
    url = f"/jobs/{done['jobID']}/results"
    r = await client.get(url, params={"f": "geojson"}, headers={"Accept-Encoding": "gzip"})
    assert r.headers["content-encoding"] == "gzip"
    assert "Accept-Encoding" in r.headers["vary"]
    assert r.json()["type"] == "FeatureCollection"  # httpx decoded it
    raw = await client.get(url, params={"f": "json"}, headers={"Accept-Encoding": "gzip"})
    assert raw.headers["content-encoding"] == "gzip"
    assert "triangles" in raw.json()
    plain = await client.get(url, params={"f": "geojson"}, headers={"Accept-Encoding": "identity"})
    assert "content-encoding" not in plain.headers
    assert plain.json() == r.json()
