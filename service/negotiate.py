"""HTTP content negotiation of a job's results: the ``Accept`` header (RFC 9110 12.5.1) against
the formats that can be written, and the results' entity tag.

>>> [f.name for f in acceptable("image/png;q=0.5, application/geo+json")]
['geojson', 'png']
>>> [f.name for f in acceptable("*/*")][0], acceptable(None)[0].name
('json', 'json')
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable

from .formats import FORMATS, ResultFormat

__all__ = ["acceptable", "etag", "etag_matches"]


def _ranges(header: str) -> list[tuple[float, str]]:
    """The media ranges of ``header`` with their weights, heaviest first (ties keep order)."""
    out: list[tuple[float, int, str]] = []
    for index, item in enumerate(header.split(",")):
        media, *params = (p.strip() for p in item.split(";"))
        if not media:
            continue
        weight = 1.0
        for param in params:
            name, _, value = param.partition("=")
            if name.strip().lower() == "q":
                try:
                    weight = float(value)
                except ValueError:
                    weight = 0.0
        if weight > 0:
            out.append((-weight, index, media.lower()))
    return [(-w, media) for w, _, media in sorted(out)]


def acceptable(header: str | None) -> list[ResultFormat]:
    """The writable formats ``header`` accepts, best first; the mesh document for no header."""
    offered = [f for f in FORMATS.values() if f.writer is not None]
    if not header or not header.strip():
        return offered[:1]
    chosen: list[ResultFormat] = []
    for _, media in _ranges(header):
        kind = media.split("/", 1)[0]
        for fmt in offered:
            fits = media in ("*/*", fmt.media_type) or (
                media == f"{kind}/*" and (fmt.media_type.startswith(f"{kind}/"))
            )
            if fits and fmt not in chosen:
                chosen.append(fmt)
    return chosen


def etag(parts: Iterable[object]) -> str:
    """A strong entity tag of a finished result: the same job, end and options give the same."""
    digest = hashlib.sha256(repr(tuple(parts)).encode()).hexdigest()[:32]
    return f'"{digest}"'


def etag_matches(header: str | None, tag: str) -> bool:
    """Whether ``If-None-Match`` names ``tag`` (or is ``*``); weak tags compare weakly."""
    if not header:
        return False
    for item in header.split(","):
        candidate = item.strip()
        if candidate == "*" or candidate.removeprefix("W/") == tag:
            return True
    return False
