"""Rendering results off the event loop: a bounded pool, a size bound and a cache.

Pictures take seconds of CPU and hundreds of megabytes each at large sizes, so they run at most
``render_workers`` at a time under their own limiter (status and store work keep the shared
thread pool), their pixels are bounded before anything is loaded, and each picture of a job and
set of options is drawn once: a result never changes once the job has succeeded.

>>> import anyio
>>> pool = RenderPool(workers=1, cache_bytes=1024)
>>> calls = []
>>> def draw() -> bytes:
...     calls.append(1)
...     return b"picture"
>>> key = ("job", "png", ())
>>> anyio.run(pool.render, key, draw), anyio.run(pool.render, key, draw)
(b'picture', b'picture')
>>> len(calls)
1
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable, Hashable, Mapping

import anyio
import anyio.to_thread

from .options import PictureError, PictureOptions

__all__ = ["RenderPool", "picture_options"]

#: Height of a picture whose height follows the mesh, at most (a multiple of its width).
_AUTO_HEIGHT = 1.25


def picture_options(query: Mapping[str, str], max_pixels: int) -> PictureOptions:
    """A picture request's options, checked before any result is loaded; :class:`PictureError`
    for a wrong option or a picture over ``max_pixels`` (width x height).

    >>> picture_options({"width": "8000", "height": "8000"}, 4096 * 4096)
    Traceback (most recent call last):
    ...
    service.render.options.PictureError: the picture would be 8000 x 8000 pixels, over ...
    """
    options = PictureOptions.from_query(query)
    width = options.width or (1600 if options.compare else 1200)
    height = options.height or int(_AUTO_HEIGHT * width)
    if width * height > max_pixels:
        raise PictureError(
            "width" if options.width else "height",
            f"the picture would be {width} x {height} pixels, over the limit of {max_pixels}"
            " (max_picture_pixels)",
        )
    return options


class RenderPool:
    """Renders at most ``workers`` results at once, each (job, format, options) once."""

    def __init__(self, workers: int, cache_bytes: int) -> None:
        self.workers = workers
        self.cache_bytes = cache_bytes
        self._limiter: anyio.CapacityLimiter | None = None
        self._cache: OrderedDict[Hashable, bytes] = OrderedDict()
        self._size = 0
        self._drawing: dict[Hashable, anyio.Event] = {}

    def cached(self, key: Hashable) -> bytes | None:
        """A rendering already made (and now the most recently used)."""
        body = self._cache.get(key)
        if body is not None:
            self._cache.move_to_end(key)
        return body

    async def render(self, key: Hashable, draw: Callable[[], bytes]) -> bytes:
        """``draw()`` in the pool, unless ``key`` was drawn (or is being drawn) already."""
        while (busy := self._drawing.get(key)) is not None:
            await busy.wait()  # the same picture asked twice at once: drawn once
        body = self.cached(key)
        if body is not None:
            return body
        if self._limiter is None:  # made on the event loop that uses it
            self._limiter = anyio.CapacityLimiter(self.workers)
        done = self._drawing[key] = anyio.Event()
        try:
            body = await anyio.to_thread.run_sync(draw, limiter=self._limiter)
            self._keep(key, body)
        finally:
            del self._drawing[key]
            done.set()
        return body

    def _keep(self, key: Hashable, body: bytes) -> None:
        if len(body) > self.cache_bytes // 4:  # one huge picture must not flush the rest
            return
        self._cache[key] = body
        self._size += len(body)
        while self._size > self.cache_bytes:
            _, old = self._cache.popitem(last=False)
            self._size -= len(old)
