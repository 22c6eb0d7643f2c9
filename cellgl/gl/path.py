"""Which GPU path runs cellgl's shaders on a context: compute, or fragment.

The compute path needs OpenGL 4.3 (compute shaders, storage buffers). Everywhere else from
OpenGL 3.3 core up (Apple's 4.1 core included) the fragment path runs the same ``shaders/lib``
code in fragment programs over tiled quads, with inputs in textures and outputs in render
targets, and gives the same bits.

``CELLGL_PATH=compute|fragment`` forces one (for tests and comparisons); unset or empty, the
context decides.
"""

from __future__ import annotations

import os

#: Accepted values of ``CELLGL_PATH``.
PATHS = ("compute", "fragment")

#: moderngl's version code of the first OpenGL with compute shaders.
COMPUTE_GL = 430

#: On the fragment path, what the compute entries read from a storage buffer (density-image
#: levels, cell-colour images, PUPs control points) is an R32UI texture 2^STORAGE_ROW_BITS words
#: wide on the texture unit numbered like the buffer's binding (``shaders/storage.glsl``). A
#: 4096 x 4096 image makes a 4096 x 4096 texture, within every OpenGL 4.1 implementation's 16384.
STORAGE_ROW_BITS = 12


def has_compute(ctx) -> bool:
    """True when ``ctx`` (a moderngl context) runs compute shaders."""
    return ctx.version_code >= COMPUTE_GL


def forced_path() -> str | None:
    """The path named by ``CELLGL_PATH``, or None when it is unset or empty.

    Raises
    ------
    ValueError
        ``CELLGL_PATH`` names no path.
    """
    value = os.environ.get("CELLGL_PATH", "").strip().lower()
    if not value:
        return None
    if value not in PATHS:
        raise ValueError(
            f"CELLGL_PATH={os.environ['CELLGL_PATH']!r} is not a GPU path; accepted values: "
            f"{', '.join(PATHS)} (or unset it: compute where the context has OpenGL 4.3)"
        )
    return value


def gpu_path(ctx) -> str:
    """``"compute"`` or ``"fragment"``: the path cellgl runs on ``ctx``.

    Raises
    ------
    ValueError
        ``CELLGL_PATH`` names no path, or forces ``compute`` on a context without compute
        shaders.
    """
    forced = forced_path()
    if forced == "compute" and not has_compute(ctx):
        raise ValueError(
            f"CELLGL_PATH=compute, but this OpenGL {ctx.version_code // 100}."
            f"{ctx.version_code % 100 // 10} context has no compute shaders (OpenGL 4.3); "
            "unset CELLGL_PATH or set CELLGL_PATH=fragment"
        )
    if forced:
        return forced
    return "compute" if has_compute(ctx) else "fragment"
