"""Enumerations shared by Python, the NumPy reference and the GLSL library.

Each enum is defined once here; :func:`glsl_defines` turns them into the
``CELL_*`` macros the shaders compare against, so the two can never disagree.
"""
from __future__ import annotations

from enum import IntEnum


class Metric(IntEnum):
    """Distance metric between a sample and a feature point."""

    EUCLIDEAN = 0
    MANHATTAN = 1
    CHEBYSHEV = 2
    MINKOWSKI = 3


class Distribution(IntEnum):
    """How feature points are scattered through the integer cells."""

    POISSON = 0      #: Poisson count of mean ``density`` per cell, clamped to [min_points, max_points]
    JITTER = 1       #: one point per cell, displaced from the centre by ``jitter``
    WORLEY1996 = 2   #: the book's reference program, bit for bit (3D only)
    BLENDER = 3      #: Blender's Voronoi node: one point per cell from its hash, ``jitter`` as Randomness


class DensityMapKind(IntEnum):
    """Spatially varying density of feature points (``CELL_DENSITY_MAP``; :mod:`cellgl.basis.density`)."""

    NONE = 0     #: one density everywhere (the default path, unchanged)
    RAMP = 1     #: linear ramp along a lattice axis
    RADIAL = 2   #: distance from a centre
    IMAGE = 3    #: a grayscale image over a lattice rectangle (read from a storage buffer)


def parse_enum(enum: type[IntEnum], value: object, what: str) -> IntEnum:
    """Return the member of ``enum`` named by ``value`` (a name, or a member).

    Raises ``ValueError`` naming the accepted names otherwise.
    """
    if isinstance(value, enum):
        return value
    if isinstance(value, str):
        key = value.strip().upper().replace("-", "_")
        if key in enum.__members__:
            return enum[key]
    names = ", ".join(m.name.lower() for m in enum)
    raise ValueError(f"unknown {what} {value!r}; expected one of: {names}")


def glsl_defines() -> dict[str, int]:
    """``CELL_<ENUM>_<NAME>`` macros for every enum member, e.g. ``CELL_METRIC_EUCLIDEAN = 0``."""
    out: dict[str, int] = {}
    for enum, prefix in ((Metric, "CELL_METRIC_"), (Distribution, "CELL_DIST_"),
                         (DensityMapKind, "CELL_DMAP_")):
        for m in enum:
            out[prefix + m.name] = int(m)
    return out
