"""Geodata: coordinate reference systems, the antimeridian and region files.

The request path runs ``project_rings`` on the parsed rings, meshes ``Projection.parts`` and maps
the result's points back with ``Projection.inverse``; see :mod:`service.geo.crs`.
"""

from __future__ import annotations

from .antimeridian import crosses_antimeridian, normalize_longitudes, unwrap_parts
from .crs import ALIASES, Projection, crs_name, legacy_crs, local_crs, project_rings, resolve_crs
from .errors import GeoError, InvalidCoordinates, MissingDependency, RegionTooLarge, UnknownCRS
from .files import RegionFile, RegionFileError, read_region_file

__all__ = [
    "ALIASES",
    "GeoError",
    "InvalidCoordinates",
    "MissingDependency",
    "Projection",
    "RegionFile",
    "RegionFileError",
    "RegionTooLarge",
    "UnknownCRS",
    "crosses_antimeridian",
    "crs_name",
    "legacy_crs",
    "local_crs",
    "normalize_longitudes",
    "project_rings",
    "read_region_file",
    "resolve_crs",
    "unwrap_parts",
]
