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

__all__ = ["acceptable", "etag", "etag_matches", "ranked"]


def ranked(accept: str) -> list[tuple[str, float]]:
    """The media ranges of an ``Accept`` header (lower case) and their ``q`` weights, in order.

    >>> ranked("text/html, */*;q=0.5")
    [('text/html', 1.0), ('*/*', 0.5)]
    """
    out = []
    for item in accept.split(","):
        media, *params = (part.strip() for part in item.split(";"))
        q = 1.0
        for param in params:
            name, _, value = param.partition("=")
            if name.strip().lower() == "q":
                try:
                    q = float(value)
                except ValueError:
                    q = 0.0
        if media:
            out.append((media.lower(), q))
    return out


def _ranges(header: str) -> list[str]:
    """The accepted media ranges of ``header``, heaviest first (ties keep their order)."""
    weighted = [(-q, i, media) for i, (media, q) in enumerate(ranked(header)) if q > 0]
    return [media for _, _, media in sorted(weighted)]


def acceptable(header: str | None) -> list[ResultFormat]:
    """The writable formats ``header`` accepts, best first; the mesh document for no header."""
    offered = [f for f in FORMATS.values() if f.writer is not None]
    if not header or not header.strip():
        return offered[:1]
    chosen: list[ResultFormat] = []
    for media in _ranges(header):
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
