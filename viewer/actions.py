"""Panel actions: save the recipe, bake it, copy / save a GLSL snippet, screenshot.

Each action is a plain function of the viewer (tests call them directly); :func:`draw` puts
them in the panel. Bake and export go through the same public functions as the command line
(``cellgl.bake.core.bake``, ``cellgl.export.export``), never through a copy of their code.
"""

from __future__ import annotations

import os

from imgui_bundle import imgui

__all__ = ["draw", "save_recipe", "bake", "snippet", "save_snippet", "copy_snippet", "have_export"]


def _stem(viewer) -> str:
    return os.path.splitext(os.path.basename(viewer.model.name))[0] or "recipe"


def save_recipe(viewer, path: str) -> str:
    """Write the current recipe as JSON to ``path``."""
    viewer.model.save(path)
    viewer.status = f"saved recipe {path}"
    return path


def bake(viewer, path: str, size=1024, **kw) -> list:
    """``cellgl bake`` of the current recipe (same function, same pixels)."""
    from cellgl.bake.core import bake as _bake

    out = _bake(viewer.model.recipe, path, size=size, progress=False, **kw)
    viewer.status = "baked " + ", ".join(str(p) for p in out)
    return out


def have_export() -> bool:
    try:
        from cellgl import export  # noqa: F401
    except ImportError:
        return False
    return hasattr(export, "export")


def snippet(viewer, target: str = "glsl") -> str:
    from cellgl.export.snippets import export

    return export(viewer.model.recipe, target)


def save_snippet(viewer, path: str, target: str = "glsl") -> str:
    text = snippet(viewer, target)
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)
    viewer.status = f"saved {target} snippet {path}"
    return path


def copy_snippet(viewer, target: str = "glsl") -> str:
    text = snippet(viewer, target)
    imgui.set_clipboard_text(text)
    viewer.status = f"copied {target} snippet ({len(text.splitlines())} lines) to the clipboard"
    return text


class _State:
    path: str | None = None
    bake_size: int = 1024
    target: int = 0


def _error(viewer, exc: Exception) -> None:
    viewer.status = f"error: {exc}"


def draw(viewer) -> None:
    st = viewer.__dict__.setdefault("_actions_state", _State())
    if st.path is None:
        st.path = _stem(viewer)  # relative to the working directory
    imgui.set_next_item_width(-1)
    _, st.path = imgui.input_text("##path", st.path)
    if imgui.is_item_hovered():
        imgui.set_item_tooltip("file name stem for save / bake / snippet / screenshot")
    base = os.path.splitext(st.path)[0]
    if imgui.button("save recipe"):
        try:
            save_recipe(viewer, base + ".json")
        except Exception as exc:
            _error(viewer, exc)
    imgui.same_line()
    if imgui.button("bake"):
        try:
            bake(viewer, base + ".png", size=st.bake_size)
        except Exception as exc:
            _error(viewer, exc)
    imgui.same_line()
    imgui.set_next_item_width(80)
    _, st.bake_size = imgui.input_int("px##bake", st.bake_size, 0)
    st.bake_size = max(16, min(16384, st.bake_size))
    imgui.same_line()
    if imgui.button("screenshot"):
        try:
            viewer.screenshot(base + "_screenshot.png")
        except Exception as exc:
            _error(viewer, exc)
    if have_export():
        from cellgl.export.snippets import TARGETS

        names = list(TARGETS)
        imgui.set_next_item_width(110)
        _, st.target = imgui.combo("##target", st.target, names)
        imgui.same_line()
        if imgui.button("copy snippet"):
            try:
                copy_snippet(viewer, names[st.target])
            except Exception as exc:
                _error(viewer, exc)
        imgui.same_line()
        if imgui.button("save snippet"):
            try:
                suffix = TARGETS[names[st.target]].suffix
                save_snippet(viewer, base + suffix, names[st.target])
            except Exception as exc:
                _error(viewer, exc)
