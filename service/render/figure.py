"""Drawing with matplotlib: the mesh panels, their histograms, titles and the colour bar."""

from __future__ import annotations

import io
import math
import re
import threading
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from .options import COLORMAP, METRICS, Metric, PictureOptions, color_range
from .panels import (
    Panel,
    aspect_of,
    edge_sets,
    extent_of,
    histogram,
    mean_area,
    panels_of,
    stats_lines,
)
from .regions import REGION, region_figure

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.colors import Colormap
    from matplotlib.figure import Figure

__all__ = ["WORST_COLOR", "render_picture"]

#: Outline of the worst triangles: a red that stands out of every viridis colour.
WORST_COLOR = "#e8112d"


_INK = "#1f2933"


_MUTED = "#6b7683"


#: Pixels of a comparison below and above its meshes: titles, histograms, labels and margins.
COMPARE_EXTRA = 380


def _size(options: PictureOptions, shape: float) -> tuple[int, int]:
    """Pixels: the requested ones, else the default width and a height fitting the mesh."""
    width = options.width or (1600 if options.compare else 1200)
    if options.height:
        return width, options.height
    if options.compare:
        panel = (width - 190) / 2
        height = min(max(panel * shape, 150), 1.1 * panel) + COMPARE_EXTRA
    else:
        height = (width - 190) * shape + 120  # the colour bar's column, titles and margins
    return width, int(min(max(height, 0.4 * width), 1.25 * width))


#: Up to this many triangles a picture draws them as polygons (sharp vector output); above it,
#: as Gouraud triangles of one colour each, which Agg fills several times faster.
POLYGON_LIMIT = 5000


def _draw_mesh(
    ax: Axes,
    panel: Panel,
    metric: Metric,
    cmap: Colormap,
    norm: Any,
    options: PictureOptions,
    aspect: float,
    fig_px: tuple[int, int],
) -> None:
    from matplotlib.collections import LineCollection, PolyCollection
    from matplotlib.tri import Triangulation

    pts, tris = panel.points, panel.triangles
    big = len(tris) > POLYGON_LIMIT
    # Vector output of 10^5 triangles is megabytes that viewers choke on: rasterize big meshes.
    ax_w = ax.get_position().width * fig_px[0]
    span = max(float(np.ptp(pts[:, 0])), float(np.ptp(pts[:, 1])) / aspect, 1e-300)
    scale = ax_w / span  # pixels per data unit (roughly: the axes may shrink to keep the aspect)
    mean_edge_px = math.sqrt(4 / math.sqrt(3) * mean_area(pts, tris)) * scale
    draw_edges = options.edges if options.edges is not None else mean_edge_px >= 6
    edges, outline = edge_sets(tris)
    if metric.on == "point":
        tri = Triangulation(pts[:, 0], pts[:, 1], tris)
        ax.tripcolor(tri, panel.values, shading="gouraud", cmap=cmap, norm=norm, rasterized=big)
    elif big:
        corners = pts[tris].reshape(-1, 2)
        tri = Triangulation(corners[:, 0], corners[:, 1], np.arange(len(corners)).reshape(-1, 3))
        ax.tripcolor(
            tri,
            np.repeat(panel.values, 3),
            shading="gouraud",
            cmap=cmap,
            norm=norm,
            rasterized=True,
        )
    else:
        tri = Triangulation(pts[:, 0], pts[:, 1], tris)
        # Without edges, a hairline in the face colour closes the seams anti-aliasing leaves.
        ax.tripcolor(
            tri, facecolors=panel.values, cmap=cmap, norm=norm, edgecolors="face", linewidth=0.2
        )
    if draw_edges:
        segments: Any = pts[edges]  # (n, 2, 2): what LineCollection takes, untyped there
        ax.add_collection(
            LineCollection(segments, colors="#ffffff8c", linewidths=0.35, rasterized=big)
        )
    boundary: Any = pts[outline]
    ax.add_collection(LineCollection(boundary, colors=_INK, linewidths=0.8, zorder=3))
    k = min(options.worst, len(tris))
    if k:
        q = panel.quality
        worst = np.argpartition(q, k - 1)[:k] if k < len(tris) else np.arange(len(tris))
        rings = pts[tris[worst]]
        ax.add_collection(
            PolyCollection(
                list(rings), facecolors="none", edgecolors=WORST_COLOR, linewidths=1.6, zorder=4
            )
        )
        if mean_edge_px < 12:  # too small to see: ring them
            centre = rings.mean(axis=1)
            ax.scatter(
                centre[:, 0],
                centre[:, 1],
                s=110,
                facecolors="none",
                edgecolors=WORST_COLOR,
                linewidths=1.4,
                zorder=5,
            )
    ax.set_aspect(aspect)
    ax.autoscale_view()
    ax.margins(0.02)
    for side in ("top", "right"):
        ax.spines[side].set_visible(False)
    for side in ("left", "bottom"):
        ax.spines[side].set_color("#c5ccd3")
    ax.tick_params(colors=_MUTED, labelsize=8, length=3)


def _draw_histogram(
    ax: Axes, panel: Panel, other: Panel, other_name: str, cmap: Colormap, lo: float, ymax: float
) -> None:
    """Counts on a log scale: the few poor triangles are what matters, and a linear axis
    would show only the good bulk."""
    counts, edges = histogram(panel.quality, lo)
    centres = (edges[:-1] + edges[1:]) / 2
    ax.bar(
        centres,
        counts,
        width=np.diff(edges),
        color=cmap((centres - lo) / (1.0 - lo)),
        edgecolor="white",
        linewidth=0.4,
    )
    ax.stairs(
        histogram(other.quality, lo)[0],
        edges,
        color=_INK,
        linewidth=0.9,
        linestyle=(0, (3, 2)),
        baseline=None,
    )
    worst = float(panel.quality.min())
    ax.axvline(worst, color=WORST_COLOR, linewidth=1.2)
    ax.annotate(
        f"min {worst:.3f}",
        (worst, 1.0),
        xycoords=("data", "axes fraction"),
        xytext=(4, -2),
        textcoords="offset points",
        color=WORST_COLOR,
        fontsize=8,
        va="top",
    )
    ax.set_yscale("log")
    ax.set_xlim(lo, 1.0)
    ax.set_ylim(0.7, max(ymax, 1.0) * 2.5)
    ax.set_xlabel("triangle quality", fontsize=9, color=_INK)
    ax.set_ylabel("triangles", fontsize=9, color=_INK)
    ax.set_title(
        f"bars: {panel.title.split(':')[0]}   dashed: {other_name}",
        loc="right",
        fontsize=8,
        color=_MUTED,
    )
    for side in ("top", "right"):
        ax.spines[side].set_visible(False)
    for side in ("left", "bottom"):
        ax.spines[side].set_color("#c5ccd3")
    ax.tick_params(colors=_MUTED, labelsize=8)


def _titles(ax: Axes, title: str, lines: list[str], size: float, note: str) -> None:
    """A bold title over lines of figures, flush left; a red note flush right."""
    ax.set_title(
        title,
        loc="left",
        fontsize=size,
        color=_INK,
        fontweight="bold",
        pad=10 + (size - 3.5) * 1.5 * len(lines),
    )
    # Left out of the layout: a long line must not shrink the mesh (the title's pad holds room).
    text = ax.annotate(
        "\n".join(lines),
        (0, 1),
        xycoords="axes fraction",
        xytext=(0, 6),
        textcoords="offset points",
        fontsize=size - 3.5,
        color=_MUTED,
        va="bottom",
        linespacing=1.5,
    )
    text.set_in_layout(False)
    if note:  # beside the first line of figures (the short one)
        rise = 6 + (size - 3.5) * 1.5 * (len(lines) - 1)
        mark = ax.annotate(
            note,
            (1, 1),
            xycoords="axes fraction",
            xytext=(0, rise),
            textcoords="offset points",
            fontsize=size - 3.5,
            color=WORST_COLOR,
            ha="right",
            va="bottom",
        )
        mark.set_in_layout(False)


def _figure(doc: Mapping[str, Any], options: PictureOptions) -> tuple[Figure, tuple[int, int]]:
    from matplotlib import colormaps
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize
    from matplotlib.figure import Figure
    from matplotlib.layout_engine import ConstrainedLayoutEngine

    if options.color == REGION:  # categorical: a legend, not a colour scale
        pts = np.asarray(doc["points"], dtype=np.float64).reshape(-1, 2)
        span = np.ptp(pts, axis=0)
        size = _size(options, float(span[1] * aspect_of(doc, pts) / max(span[0], 1e-300)))
        return region_figure(doc, options, size), size
    metric = METRICS[options.color]
    panels = panels_of(doc, options)
    aspect = aspect_of(doc, panels[-1].points)
    width, height = _size(options, extent_of(panels, aspect))
    lo, hi = color_range(metric, [p.values for p in panels])
    lo = options.vmin if options.vmin is not None else lo
    hi = options.vmax if options.vmax is not None else hi
    reverse = lo > hi  # a metric whose high values are bad: the bad end stays dark
    norm = Normalize(min(lo, hi), max(lo, hi))
    cmap = colormaps[COLORMAP + ("_r" if reverse else "")]

    k = min(options.worst, len(panels[-1].quality))
    note = f"red: the {k} lowest-quality triangles" if k else ""
    layout = ConstrainedLayoutEngine(w_pad=0.12, h_pad=0.1)
    fig = Figure(figsize=(width / 100, height / 100), dpi=100, layout=layout)
    scale = ScalarMappable(norm=norm, cmap=cmap)
    if options.compare:
        axes = fig.subplots(2, 2, height_ratios=[max(height - COMPARE_EXTRA, 100), 210])
        q_lo = color_range(METRICS["quality"], [p.quality for p in panels])[0]
        hist_cmap = cmap if metric.name == "quality" else colormaps[COLORMAP]
        ymax = max(histogram(p.quality, q_lo)[0].max() for p in panels)
        for i, panel in enumerate(panels):
            _draw_mesh(axes[0][i], panel, metric, cmap, norm, options, aspect, (width, height))
            _titles(axes[0][i], panel.title, stats_lines(panel), 12, note)
            other = panels[1 - i]
            _draw_histogram(
                axes[1][i], panel, other, other.title.split(":")[0], hist_cmap, q_lo, ymax
            )
        bar = fig.colorbar(scale, ax=axes[0].tolist(), shrink=0.9, pad=0.02, aspect=30)
    else:
        ax = fig.subplots()
        _draw_mesh(ax, panels[0], metric, cmap, norm, options, aspect, (width, height))
        _titles(ax, _title(doc), stats_lines(panels[0]), 13, note)
        bar = fig.colorbar(scale, ax=ax, shrink=0.85, pad=0.02, aspect=30)
    bar.set_label(metric.label, fontsize=10, color=_INK)
    bar.ax.tick_params(labelsize=8, colors=_MUTED)
    bar.outline.set_visible(False)
    return fig, (width, height)


def _title(doc: Mapping[str, Any]) -> str:
    """What made the mesh, from the parameters the document records.

    >>> params = {"sizing": {"size": 0.03}, "smoothing": {"method": "ga"}}
    >>> _title({"summary": {"parameters": params}})
    'evomesh  ·  size 0.03  ·  smoothing ga'
    """
    params = doc.get("summary", {}).get("parameters", {})
    parts = ["evomesh"]
    size = params.get("sizing", {}).get("size")
    if size is not None:
        parts.append(f"size {size:g}")
    method = params.get("smoothing", {}).get("method")
    if method is not None:
        parts.append(f"smoothing {method}")
    return "  ·  ".join(parts)


_ONE_AT_A_TIME = threading.Lock()
_SVG_SIZE = re.compile(rb'<svg([^>]*?) width="[^"]*" height="[^"]*"')


def render_picture(
    doc: Mapping[str, Any], fmt: Literal["png", "svg"], options: PictureOptions | None = None
) -> bytes:
    """A PNG or SVG picture of a mesh document (see the module docstring).

    Raises :class:`PictureError` when the options do not fit the document.
    """
    import matplotlib

    options = options or PictureOptions()
    style: Any = {"svg.hashsalt": "evomesh", "svg.fonttype": "path", "font.family": "DejaVu Sans"}
    # rc_context sets matplotlib's global settings: one picture at a time (the service draws
    # them in threads; they are CPU-bound, so little is lost).
    with _ONE_AT_A_TIME, matplotlib.rc_context(style):
        fig, (width, height) = _figure(doc, options)
        out = io.BytesIO()
        if fmt == "png":
            fig.savefig(out, format="png", dpi=100, metadata={"Software": "evomesh"})
            return out.getvalue()
        # Rasterized parts (big meshes) at twice the pixel size, so they stay sharp when zoomed.
        fig.savefig(out, format="svg", dpi=200, metadata={"Date": None, "Creator": "evomesh"})
    # matplotlib states the size in points; state it in pixels, as for the PNG (the viewBox,
    # in points, scales to it).
    return _SVG_SIZE.sub(
        rb'<svg\1 width="%dpx" height="%dpx"' % (width, height), out.getvalue(), count=1
    )
