"""``bpy`` as a module, with what Blender's UI would set up for OSL Script nodes.

As a module nothing runs the Script node's update callback, which compiles the node's OSL
and creates its sockets: :func:`compile_script_node` calls it. That callback imports
``oslquery``, which the ``bpy`` wheel ships under ``bpy/<version>/python/lib/python3.X/
site-packages`` (off ``sys.path``): :func:`import_bpy` adds that folder.
"""
from __future__ import annotations

import os
import sys

__all__ = ["import_bpy", "enable_osl_compiler", "compile_script_node", "osl_compile", "BlenderMissing"]


class BlenderMissing(ImportError):
    """``bpy`` is not installed (the ``[blender]`` extra)."""


_READY = False


def import_bpy():
    """Return the ``bpy`` module, ready to compile OSL Script nodes and render with Cycles.

    Raises
    ------
    BlenderMissing
        ``bpy`` is not importable; the message says how to install it.
    """
    global _READY
    try:
        import bpy
    except ImportError as exc:
        raise BlenderMissing(
            f"Blender as a Python module is not installed ({exc}); install the extra: "
            "pip install 'cellgl[blender]' (bpy 4.5, Python 3.11)") from None
    if _READY:
        return bpy
    # bpy.__file__: .../bpy/4.5/scripts/modules/bpy/__init__.py; oslquery lies under
    # .../bpy/4.5/python/lib/python3.X/site-packages
    root = bpy.__file__.split(os.sep + "scripts" + os.sep)[0]
    lib = os.path.join(root, "python", "lib")
    if os.path.isdir(lib):
        for d in sorted(os.listdir(lib)):
            site = os.path.join(lib, d, "site-packages")
            if os.path.isdir(os.path.join(site, "oslquery")) and site not in sys.path:
                sys.path.append(site)
    import addon_utils

    if not addon_utils.check("cycles")[1]:      # inside Blender it is on already
        addon_utils.enable("cycles", default_set=True, persistent=True)
    _READY = True
    return bpy


def enable_osl_compiler():
    """:func:`import_bpy` under the name the add-on's ``register`` uses."""
    return import_bpy()


def _cycles_osl():
    import importlib

    for name, mod in list(sys.modules.items()):
        if name.endswith("cycles.osl") and hasattr(mod, "update_script_node"):
            return mod
    for name in [n for n in sys.modules if n == "cycles" or n.endswith(".cycles")]:
        mod = importlib.import_module(name + ".osl")
        if hasattr(mod, "update_script_node"):
            return mod
    raise RuntimeError("the Cycles add-on's osl module is not loaded (call import_bpy first)")


def compile_script_node(node) -> None:
    """Compile the OSL of Script node ``node`` (internal text or external file) and create its
    sockets, as Blender's UI does when the script changes.

    Raises
    ------
    RuntimeError
        The OSL does not compile; the message holds the compiler's report.
    """
    import_bpy()
    messages = []

    def report(kind, text):
        messages.append(f"{'/'.join(sorted(kind))}: {text}")

    if node.mode == "INTERNAL":
        node.bytecode = ""
        node.bytecode_hash = ""
    ok = _cycles_osl().update_script_node(node, report)
    if not ok:
        raise RuntimeError("OSL compilation failed: " + ("; ".join(messages) or "no report"))


def osl_compile(source: str) -> str:
    """Compile OSL ``source`` with Cycles' compiler; return the ``.oso`` bytecode text.

    Raises
    ------
    RuntimeError
        The source does not compile (the compiler prints its errors on standard error).
    """
    import tempfile

    import_bpy()
    import _cycles

    with tempfile.TemporaryDirectory(prefix="cellgl-osl-") as d:
        src, oso = os.path.join(d, "shader.osl"), os.path.join(d, "shader.oso")
        with open(src, "w", encoding="utf-8") as f:
            f.write(source)
        if not _cycles.osl_compile(src, oso):
            raise RuntimeError("OSL compilation failed (the compiler's errors are on standard error)")
        with open(oso, encoding="utf-8") as f:
            return f.read()
