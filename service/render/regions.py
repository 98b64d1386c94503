"""``color=region``: triangles in one colour per region, tagged lines in one colour per tag, and
a legend naming both (a document without regions is a :class:`PictureError`)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from .options import PictureError, PictureOptions
from .panels import aspect_of, edge_sets

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["REGION", "region_figure"]

#: The ``color`` value that colours by region.
REGION = "region"
_INK = "#1f2933"


def _names(table: Mapping[str, Any], ids: Any) -> dict[int, str]:
    names = {int(v): str(k) for k, v in table.items()}
    return {int(i): names.get(int(i), f"#{int(i)}") for i in np.unique(ids)}


def region_figure(doc: Mapping[str, Any], options: PictureOptions, size: tuple[int, int]) -> Figure:
    """The figure of ``doc`` coloured by region, ``size`` pixels."""
    from matplotlib import colormaps
    from matplotlib.collections import LineCollection, PolyCollection
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    region = doc.get("cell_data", {}).get("region")
    if region is None:
        raise PictureError("color", "this mesh has no regions to colour by")
    pts = np.asarray(doc["points"], dtype=np.float64).reshape(-1, 2)
    tris = np.asarray(doc["triangles"], dtype=np.int64).reshape(-1, 3)
    ids = np.asarray(region, dtype=np.int64)
    fig = Figure(figsize=(size[0] / 100, size[1] / 100), dpi=100, layout="constrained")
    ax = fig.subplots()
    fills, inks = colormaps["Pastel1"], colormaps["Dark2"]
    regions = _names(doc.get("regions", {}), ids)
    order = {r: k for k, r in enumerate(regions)}
    faces = [fills(order[int(r)] % fills.N) for r in ids]
    edges = "#ffffff" if options.edges is not False else "face"
    ax.add_collection(PolyCollection(list(pts[tris]), facecolors=faces, edgecolors=edges, lw=0.3))
    handles: list[Any] = [
        Patch(color=fills(k % fills.N), label=n) for k, n in enumerate(regions.values())
    ]
    lines = np.asarray(doc.get("lines", []), dtype=np.int64).reshape(-1, 2)
    tag = np.asarray(doc.get("line_data", {}).get("tag", []), dtype=np.int64)
    if len(lines) and len(tag) == len(lines):
        for k, (t, name) in enumerate(_names(doc.get("tags", {}), tag).items()):
            segs: Any = pts[lines[tag == t]]
            ax.add_collection(LineCollection(segs, colors=[inks(k % inks.N)], lw=2.0, zorder=3))
            handles.append(Line2D([], [], color=inks(k % inks.N), lw=2.0, label=name))
    else:
        outline: Any = pts[edge_sets(tris)[1]]
        ax.add_collection(LineCollection(outline, colors=_INK, linewidths=0.8, zorder=3))
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    ax.set_aspect(aspect_of(doc, pts))
    ax.autoscale_view()
    ax.margins(0.02)
    ax.set_title("regions and tagged lines", loc="left", fontsize=13, color=_INK)
    return fig
