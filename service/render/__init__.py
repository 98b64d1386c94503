"""Pictures of meshes: PNG and SVG drawn by matplotlib (Agg, no display).

Triangles are coloured by a metric (triangle ``quality`` by default, or node ``fitness``, or
another per-triangle figure), with a colour bar naming it; the worst triangles by quality are
outlined in red (and ringed when they are too small to see). ``compare`` draws the mesh before
(the document's ``initial``) and after side by side, each over its quality histogram.

matplotlib is optional (the ``formats`` extra) and imported only when a picture is drawn.

>>> doc = {"points": [[0, 0], [1, 0], [0, 1]], "triangles": [[0, 1, 2]],
...        "cell_data": {"quality": [0.87]}}
>>> png = render_picture(doc, "png", PictureOptions(width=300, height=200))
>>> png[:8] == b"\\x89PNG\\r\\n\\x1a\\n"
True
"""

from __future__ import annotations

from .figure import WORST_COLOR, render_picture
from .options import COLORMAP, METRICS, Metric, PictureError, PictureOptions, color_range
from .pool import RenderPool, picture_options

__all__ = [
    "COLORMAP",
    "METRICS",
    "WORST_COLOR",
    "Metric",
    "PictureError",
    "PictureOptions",
    "RenderPool",
    "color_range",
    "picture_options",
    "render_picture",
]
