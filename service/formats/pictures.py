"""PNG and SVG pictures drawn by :mod:`service.render`; its options come from the request."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Literal

from .registry import StoredResult, WriteError, Writer

__all__ = ["PICTURE_OPTIONS", "picture_writer"]


def picture_writer(kind: Literal["png", "svg"]) -> Writer:
    """A writer of ``kind`` pictures; a wrong option is a :class:`WriteError` naming it."""

    def write(result: StoredResult, options: Mapping[str, str]) -> bytes:
        from ..render import PictureError, PictureOptions, render_picture

        try:
            return render_picture(result.doc, kind, PictureOptions.from_query(options))
        except PictureError as exc:
            raise WriteError(exc.message, exc.parameter) from None

    return write


def picture_options() -> str:
    """The options of a picture, in words (colours from the metric registry)."""
    from ..render import METRICS

    return (
        f"triangles coloured by quality; options color={'|'.join(METRICS)}|region, compare=1 "
        "(before and after with quality histograms), width, height, worst, edges, vmin, vmax"
    )


PICTURE_OPTIONS = picture_options()
