"""The baked materials of ``cellgl export --target materialx``: every example material
``M_<preset>`` gets ``M_<preset>_baked`` beside it, the same surface reading the files
``cellgl bake`` writes instead of running the cellgl node, for the renderers that do not run
a MaterialX node library's code (Karma, Omniverse RTX, RenderMan, Apple's: docs/materialx.md).

The maps (PNG: the one format every one of those renderers reads) lie in ``textures/`` beside
the documents:

* ``textures/cellgl_<preset>_color.png``: the bake's colour, sRGB-encoded (MaterialX
  ``colorspace="srgb_texture"``, USD ``sourceColorSpace = "sRGB"``);
* ``textures/cellgl_<preset>_normal.png``: the bake's normal map (OpenGL green), data
  (no colour space in MaterialX, USD ``sourceColorSpace = "raw"``), where the preset has one.

With a UDIM set (``udim="1001-1004"``) the names carry MaterialX's and USD's ``<UDIM>`` token:
``textures/cellgl_<preset>_color.<UDIM>.png``, one file per tile as ``cellgl bake --udim`` writes
them (:mod:`cellgl.bake.udim`).

In ``cellgl_materials.mtlx`` the baked material is ``image`` nodes (``normalmap`` decoding the
normal map) into the same ``open_pbr_surface``; in ``cellgl_materials.usda`` it is
``UsdPreviewSurface`` reading ``UsdUVTexture`` shaders (USD's own preview material, which every
Hydra renderer and USD importer reads, no MaterialX needed). The export writes the maps itself
when asked (:func:`bake_maps`, ``--bake-maps SIZE``), into the set that lands whole; otherwise
the materials name the files and ``cellgl bake`` writes them (the command is in the document).
"""
from __future__ import annotations

import re
from pathlib import Path
from xml.sax.saxutils import quoteattr

from cellgl.export.materialx import MxNode
from cellgl.export.snippets import ExportError

__all__ = ["TEXTURES", "TEXTURE_FILE", "maps", "check_options", "mtlx_lines", "usd_lines", "bake_maps",
           "bake_command"]

TEXTURES = "textures"
#: a map file of the set, as the materials name it (the token) or as it lies on disk (a tile)
TEXTURE_FILE = re.compile(r"textures/cellgl_[A-Za-z0-9_]+_(?:color|normal)(?:\.(?:<UDIM>|1\d{3}))?\.png")


def maps(node: MxNode, udim: str | None = None) -> dict[str, str]:
    """``{channel: relative path}`` of the maps the baked material of ``node`` reads: colour,
    and the normal map where the node has a normal output; ``<UDIM>`` in the names of a set."""
    tail = ".<UDIM>.png" if udim else ".png"
    return {c: f"{TEXTURES}/{node.name}_{c}{tail}" for c in ("color", "normal")
            if c in node.example.get("outputs", ())}


def check_options(size, udim) -> tuple[int | None, str | None]:
    """``(size or None, udim or None)`` checked before any work: a side in 1..65536, a UDIM
    range as ``cellgl bake --udim`` takes it; one clear error otherwise."""
    from cellgl.bake import udim as udim_mod
    from cellgl.io.spec import BakeError, check_size

    side = None
    if size is not None:
        try:
            side = int(size) if isinstance(size, int) or str(size).strip().isdigit() else None
            if side is None:
                raise BakeError(f"--bake-maps {size!r}: give one side in pixels, 1..65536 (the maps are square)")
            check_size(side, side, None, f"--bake-maps {side}")
        except BakeError as exc:
            raise ExportError(str(exc)) from None
    if udim is not None:
        try:
            udim_mod.tiles_for(f"x.{udim_mod.UDIM_TOKEN}.png", str(udim))
        except ValueError as exc:
            raise ExportError(str(exc)) from None
        udim = str(udim)
    return side, udim


def bake_command(node: MxNode, udim: str | None) -> str:
    """The ``cellgl bake`` commands that write the maps of ``node`` (run in the export's folder)."""
    recipe = node.example["recipe"]
    tail = f" --udim {udim}" if udim else ""
    return "; ".join(f"cellgl bake {recipe} -o '{rel}' --channels {c} --size 1024{tail}"
                     for c, rel in maps(node, udim).items())


def mtlx_lines(node: MxNode, udim: str | None = None) -> list[str]:
    """The elements of ``M_<preset>_baked`` in ``cellgl_materials.mtlx``."""
    e = node.name[len("cellgl_"):]
    m = maps(node, udim)
    lines = [f'  <image name="{e}_baked_color" type="color3">',
             f'    <input name="file" type="filename" value={quoteattr(m["color"])} colorspace="srgb_texture" />',
             "  </image>"]
    if "normal" in m:
        lines += [f'  <image name="{e}_baked_normal" type="vector3">',
                  f'    <input name="file" type="filename" value={quoteattr(m["normal"])} />',
                  "  </image>",
                  f'  <normalmap name="{e}_baked_normalmap" type="vector3">',
                  f'    <input name="in" type="vector3" nodename="{e}_baked_normal" />',
                  "  </normalmap>"]
    lines += [f'  <open_pbr_surface name="{e}_baked_surface" type="surfaceshader">',
              f'    <input name="base_color" type="color3" nodename="{e}_baked_color" />',
              '    <input name="specular_roughness" type="float" value="0.5" />']
    if "normal" in m:
        lines.append(f'    <input name="geometry_normal" type="vector3" nodename="{e}_baked_normalmap" />')
    lines += ["  </open_pbr_surface>",
              f'  <surfacematerial name="M_{e}_baked" type="material" '
              f'doc={quoteattr("reads the maps `cellgl bake` writes: " + bake_command(node, udim))}>',
              f'    <input name="surfaceshader" type="surfaceshader" nodename="{e}_baked_surface" />',
              "  </surfacematerial>"]
    return lines


def usd_lines(node: MxNode, udim: str | None = None) -> list[str]:
    """``M_<preset>_baked`` in ``cellgl_materials.usda``: ``UsdPreviewSurface`` with
    ``UsdUVTexture`` shaders reading the maps (anchored to the stage's folder)."""
    e = node.name[len("cellgl_"):]
    path = f"/cellgl/Materials/M_{e}_baked"
    m = maps(node, udim)
    out = [f'        def Material "M_{e}_baked" (', f'            doc = "reads the maps `cellgl bake` writes: '
           f'{bake_command(node, udim)}"', "        )", "        {",
           f"            token outputs:surface.connect = <{path}/{e}_preview.outputs:surface>", "",
           f'            def Shader "{e}_preview"', "            {",
           '                uniform token info:id = "UsdPreviewSurface"',
           f"                color3f inputs:diffuseColor.connect = <{path}/{e}_color.outputs:rgb>",
           "                float inputs:roughness = 0.5"]
    if "normal" in m:
        out.append(f"                normal3f inputs:normal.connect = <{path}/{e}_normal.outputs:rgb>")
    out += ["                token outputs:surface", "            }", "",
            f'            def Shader "{e}_st"', "            {",
            '                uniform token info:id = "UsdPrimvarReader_float2"',
            '                string inputs:varname = "st"', "                float2 outputs:result", "            }"]
    for c, rel in m.items():
        out += ["", f'            def Shader "{e}_{c}"', "            {",
                '                uniform token info:id = "UsdUVTexture"',
                f"                asset inputs:file = @./{rel}@",
                f'                token inputs:sourceColorSpace = "{"sRGB" if c == "color" else "raw"}"',
                f"                float2 inputs:st.connect = <{path}/{e}_st.outputs:result>"]
        if c == "normal":       # the map's 0.5 n + 0.5 back to n
            out += ["                float4 inputs:scale = (2, 2, 2, 1)", "                float4 inputs:bias = (-1, -1, -1, 0)"]
        out += ["                float3 outputs:rgb", "            }"]
    out += ["        }", ""]
    return out


def bake_maps(nodes: list[MxNode], size: int, udim: str | None, folder) -> dict[str, Path]:
    """``{relative path in the set: file}``: the maps of every texture node's baked material,
    baked by :func:`cellgl.bake.core.bake` (``size`` x ``size`` pixels, a tile each with
    ``udim``) into ``folder`` (a temporary folder the caller removes), which
    :func:`cellgl.export.materialx_files.write_set` copies into the set, so that they land with
    the rest of it (streamed file to file: no map is held in memory). A preset's recipe is the
    node's, as exported (its ``--set`` values included)."""
    from cellgl.bake.core import bake
    from cellgl.bake.udim import UDIM_TOKEN

    out: dict[str, Path] = {}
    for n in nodes:
        if not n.example:
            continue
        for c, rel in maps(n, udim).items():
            dest = Path(folder) / Path(rel).name
            for p in bake(n.example["recipe_obj"], str(dest), size=size, channels=(c,), udim=udim, progress=False):
                name = Path(rel).name
                if udim:
                    name = name.replace(UDIM_TOKEN, re.search(r"\.(\d{4})\.png$", Path(p).name).group(1))
                out[f"{TEXTURES}/{name}"] = Path(p)
    return out
