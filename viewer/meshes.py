"""Meshes for the 3D view, generated in NumPy: sphere, torus, cube, plane.

Each function returns ``(vertices, indices)``: ``vertices`` float32 (N, 6) with position and unit
normal per vertex, ``indices`` uint32 (M, 3) counter-clockwise triangles. Objects fit in the cube
[-1, 1]^3 and are centred on the origin; the texture is applied as a solid texture, so no UVs.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt

__all__ = ["SHAPES", "Mesh", "mesh", "sphere", "torus", "cube", "plane"]

#: (vertices float32 (N, 6), indices uint32 (M, 3)), as the module docstring says
Mesh = tuple[npt.NDArray[np.float32], npt.NDArray[np.uint32]]


def _grid_indices(nu: int, nv: int) -> npt.NDArray[np.uint32]:
    """Two triangles per quad of an (nu + 1) x (nv + 1) vertex grid, u fastest."""
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="xy")
    a = (j * (nu + 1) + i).ravel()
    b, c, d = a + 1, a + nu + 1, a + nu + 2
    # (quads, 2 triangles, 3 corners); numpy 1.x's stubs type np.stack of these Any
    tris: npt.NDArray[np.intp] = np.stack([np.stack([a, b, d], 1), np.stack([a, d, c], 1)], 1)
    return tris.reshape(-1, 3).astype(np.uint32)


def sphere(segments: int = 96, rings: int = 48) -> Mesh:
    """Unit UV sphere."""
    u = np.linspace(0.0, 2.0 * np.pi, segments + 1)
    v = np.linspace(0.0, np.pi, rings + 1)
    uu, vv = np.meshgrid(u, v, indexing="xy")
    n = np.stack([np.sin(vv) * np.cos(uu), np.cos(vv), -np.sin(vv) * np.sin(uu)], -1).reshape(-1, 3)
    # v runs from the north pole down, so the grid's winding is flipped to face outwards.
    return np.hstack([n, n]).astype(np.float32), _grid_indices(segments, rings)[:, ::-1].copy()


def torus(major: int = 96, minor: int = 48, r_major: float = 0.7,
          r_minor: float = 0.3) -> Mesh:
    """Torus around the y axis, outer radius 1."""
    u = np.linspace(0.0, 2.0 * np.pi, major + 1)
    v = np.linspace(0.0, 2.0 * np.pi, minor + 1)
    uu, vv = np.meshgrid(u, v, indexing="xy")
    ring = np.stack([np.cos(uu), np.zeros_like(uu), -np.sin(uu)], -1)
    n = np.cos(vv)[..., None] * ring + np.sin(vv)[..., None] * np.array([0.0, 1.0, 0.0])
    p = r_major * ring + r_minor * n
    return np.hstack([p.reshape(-1, 3), n.reshape(-1, 3)]).astype(np.float32), _grid_indices(major, minor)


def plane(divisions: int = 1) -> Mesh:
    """Square [-1, 1]^2 in the xz plane (y = 0), facing +y."""
    t = np.linspace(-1.0, 1.0, divisions + 1)
    xx, zz = np.meshgrid(t, -t, indexing="xy")
    p = np.stack([xx, np.zeros_like(xx), zz], -1).reshape(-1, 3)
    n = np.tile([0.0, 1.0, 0.0], (len(p), 1))
    return np.hstack([p, n]).astype(np.float32), _grid_indices(divisions, divisions)


def cube(divisions: int = 1) -> Mesh:
    """Cube [-1, 1]^3 with flat faces (separate vertices per face)."""
    pv, pi = plane(divisions)
    verts, idx = [], []
    # Rotations taking +y to each face normal.
    rots = [
        np.eye(3),                                                  # +y
        np.diag([1.0, -1.0, -1.0]),                                 # -y
        np.array([[0, 1, 0], [-1, 0, 0], [0, 0, 1]], float),        # +x
        np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1]], float),        # -x
        np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], float),        # +z
        np.array([[1, 0, 0], [0, 0, 1], [0, -1, 0]], float),        # -z
    ]
    for k, r in enumerate(rots):
        p = pv[:, :3] + np.array([0.0, 1.0, 0.0])
        verts.append(np.hstack([p @ r.T, pv[:, 3:] @ r.T]))
        idx.append(pi + k * len(pv))
    return np.vstack(verts).astype(np.float32), np.vstack(idx).astype(np.uint32)


SHAPES: dict[str, Callable[[], Mesh]] = {"sphere": sphere, "torus": torus, "cube": cube, "plane": plane}


def mesh(name: str) -> Mesh:
    """The mesh called ``name`` (one of :data:`SHAPES`)."""
    try:
        return SHAPES[name]()
    except KeyError:
        raise ValueError(f"unknown shape {name!r}; expected one of: {', '.join(SHAPES)}") from None
