"""Advancing-front triangulation, smallest front angle first.

The front is a set of closed loops of *slots*; slot ``s`` stands at vertex ``vert[s]`` and owns the
front edge ``vert[s] -> vert[next[s]]``, with the unmeshed region on its left. A binary heap orders
slots by the interior angle at their vertex. The slot with the smallest angle ``theta`` is
processed by the classic rules:

- ``theta < 75 deg``: close the corner with the triangle (prev, vertex, next);
- ``theta < 135 deg``: a new point on the bisector of the corner (two triangles follow);
- otherwise: a new point at the ideal apex of the shorter adjacent edge.

Fronts in fine parts of the size field go first (see :func:`engine.front.queue.slot_key`), so
they grade up before coarse fronts arrive.

Before a new point is made, existing front vertices near it are tried as the apex, so fronts
merge instead of leaving slivers. When another front lies less than ``GAP_LAYERS`` rows ahead
(a ray from the edge along the new point's direction meets it), the new point goes to an even
fraction of that gap, so the rows left between two approaching fronts are spaced evenly instead
of the last one being squeezed (narrow channels, fronts colliding).

Fronts that descend from a curved boundary (a circle drawn as a polygon) and are a few rows in,
with no other front close ahead, put their new points on one equilateral lattice of the size
(see :func:`engine.front.rules.snap`): following a circle inward, each row must shed about 5.4
nodes, which otherwise leaves five- and seven-neighbour pairs all over a disc; on the lattice the
interior is regular and the irregular nodes stay in the first rows, as in Gmsh's Frontal-Delaunay
meshes.

Every triangle is checked against the front: its corners must lie inside the front's wedges,
its new edges may not cross or touch a front edge, no front vertex may lie in it, and a new
point must keep its distance from the front. A uniform grid of front edges, with a loose
quadtree in each cell for edges far shorter than a cell (see :mod:`engine.front.index`), makes
each check local, so the cost stays near O(n) even where the size spans orders of magnitude.

When no slot can advance under the normal rules, the rules are relaxed once; if the front is still
stuck the remaining cavities are filled by :func:`engine.cavity.fill_cavities` (constrained
Delaunay, no new points), and swapping and smoothing repair their quality.

The package, one concern a module: ``constants`` (table columns, state indices, thresholds),
``state`` (the named tuples of arrays every kernel takes), ``geometry`` (predicates),
``index`` (the spatial index of front edges and its one query), ``queue`` (the heap and the
order of slots), ``slots`` (front updates), ``checks`` (validity of a triangle), ``rules``
(choosing the triangle) and ``driver`` (the main loop and :func:`advance_front`).
"""

from .driver import advance_front

__all__ = ["advance_front"]
