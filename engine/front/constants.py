"""Named constants of the advancing front: table columns, state indices, status codes and the
thresholds of the rules (angles in radians, lengths as fractions of the local size)."""

from __future__ import annotations

import math

# Slot table columns (LAYER: how many triangles separate the slot's edge from the boundary;
# CURVED: 1 when the front descends from a curved stretch of boundary, see driver._curved_edges;
# STAMP: the last index query that found the slot, so a query reports it once).
VERT, NEXT, PREV, VER, FAIL, ALIVE, LAYER, CURVED, STAMP = range(9)
N_COLS = 9
# Point table column holding the size field at the point (after x and y).
SIZE = 2
# Scalar state indices: points, triangles, slots, index entries and heap entries used; live
# slots; the query stamp; whether (and for how many more triangles) the rules are relaxed;
# triangles made; index tree nodes used; index entries right after its last rebuild.
NP, NT, NS, NE, NH, LIVE, QUERY, RELAXED, RELAX_LEFT, OPS, NN, KEPT = range(12)
N_STATE = 16
# Kernel status codes.
DONE, BUDGET, STUCK, GROW = 0, 1, 2, 3
# Outcomes of one attempt at a slot.
MADE, NO_MOVE, NO_ROOM = 1, 0, -1

TWO_PI = 2.0 * math.pi
T_CLOSE = math.radians(75.0)
T_BISECT = math.radians(135.0)
T_CLOSE_RELAXED = math.radians(100.0)
#: Slots flatter than this are ordered by front layer, so all fronts advance evenly.
T_FLAT = math.radians(150.0)
MAX_TRIES = 3
#: Lattice snapping (see rules.snap): from row SNAP_LAYER in, a new point within SNAP_TOL of the
#: size of a lattice node moves there, unless another front is less than SNAP_CLEAR rows ahead
#: (the gap rule spaces those rows); a boundary edge whose both ends turn by CURVE_MIN..CURVE_MAX
#: degrees is curved.
SNAP_LAYER = 3
SNAP_TOL = 0.5
SNAP_CLEAR = 5.0
CURVE_MIN, CURVE_MAX = 0.5, 30.0
#: Slots where the size field is below FINE times its size away from features are processed
#: as if their angle were FINE_LEAD smaller (corners to close excepted); see queue.slot_key.
FINE = 0.8
FINE_LEAD = math.radians(90.0)
#: A new point keeps this fraction of its edge length away from front edges and vertices.
CLEAR_EDGE = 0.45
CLEAR_VERTEX = 0.55
#: Existing vertices within this fraction of the intended edge length from a new point's
#: position are tried as the apex instead.
MERGE_RADIUS = 0.7
Q_MIN = 0.4
Q_MIN_RELAXED = 0.02
#: Another front closer than this many rows ahead spaces the remaining rows evenly.
GAP_LAYERS = 3.0
GAP_MIN_ROWS = 2
#: Candidate apexes looked at per attempt.
MAX_CANDIDATES = 256
