"""cellgl's interactive viewer: a GLFW window, Dear ImGui panel, live texture preview.

``cellgl view [PRESET_OR_RECIPE]`` or ``python -m cellgl.viewer``. See docs/viewer.md.
GUI libraries (imgui-bundle, glfw) are imported lazily, by :mod:`cellgl.viewer.app`.
"""

from __future__ import annotations

from collections.abc import Sequence

__all__ = ["main"]


def main(argv: Sequence[str] | None = None) -> int:
    from .cli import main as _main

    return _main(argv)
