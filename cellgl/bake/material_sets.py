"""Material sets: the maps a game engine's standard material takes, packed as that engine expects,
baked into one folder with a manifest (``cellgl bake flagstone --material unreal -o DIR``).

Each engine preset (:data:`ENGINES`) lists its map files: which render channels go into which
samples of each file (``ORM``: R ambient occlusion, G roughness, B metallic; Unity HDRP's mask
map: R metallic, G occlusion, B detail mask, A smoothness; ...), the normal convention (DirectX,
green down, for Unreal; OpenGL for the others: the recipe's ``normal_convention`` is set to it),
bit depths and colour spaces. Every sample of a packed map is the same value the bake of that
channel alone writes (:func:`cellgl.io.spec.encoding_of` quantises both), bit for bit;
smoothness is ``top - roughness`` of the quantised roughness (255 - r at 8 bits), so it too is
exact. Each PNG map goes through the bake's writer of its format (:func:`cellgl.bake.core.write_tiles`,
chosen by the extension), tile by tile, memory bounded as a bake.

``map_format="dds"``/``"ktx2"`` writes each map as one GPU texture file with its whole mip chain
(:func:`gpu_format`: colour ``BC7_SRGB``, normals ``BC5_UNORM`` (x and y; readers rebuild z),
packed maps (ORM, mask, metallic-smoothness) ``BC7_UNORM``, 8-bit single masks ``BC4_UNORM``,
16-bit height ``R16_UNORM``): every level is the packed map of the set rendered at that level's
size (``max(1, floor(W / 2^k))``, the levels DDS and KTX2 define), never downsampled, each sample
the PNG set's bits at that size (8 bits for the block formats); the blocks come from
:func:`cellgl.io.gpu_textures.packed_levels` (etcpak on every core), the container from
:func:`cellgl.io.gpu_textures.write_container`.

The whole set (maps, ``manifest.json``, ``recipe.json`` and, for ``gltf``, a ``.gltf`` whose
material references the maps) is written into a hidden folder beside ``DIR`` and moved into place
only when complete (:func:`cellgl.io.tempfiles.scratch_dir`, as animation frames): a new ``DIR``
is the renamed folder; into an existing one the files are moved under its commit lock, each
replacing the file of that name. A failure leaves ``DIR`` as it was. See docs/bake.md
("Material sets").
"""
from __future__ import annotations

import base64
import json
import os
import dataclasses
import shlex
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cellgl.bake.core import Output, Progress, load_recipe_sets, plan_tiles, write_tiles
from cellgl.bake.request import DEFAULT_BUDGET, DEFAULT_SIZE, parse_size
from cellgl.io.spec import BakeError, Encoding, check_size, encoding_of
from cellgl.io.tempfiles import check_output_dir, commit_lock, scratch_dir
from cellgl.texture import antialias

__all__ = ["ENGINES", "MAP_FORMATS", "MapSpec", "Engine", "bake_material", "gpu_format"]


@dataclass(frozen=True)
class MapSpec:
    """One file of a set: ``layout`` names its samples in order, each a render channel
    (``color``, ``normal``: all their samples; ``roughness``, ``ao``, ``metallic``, ``height``:
    one), ``1-roughness`` (smoothness: the quantised roughness subtracted from the top value) or
    ``1`` (the top value: a constant mask)."""

    suffix: str
    slot: str                   #: the engine material's input it goes to
    layout: tuple[str, ...]
    bits: int = 8
    srgb: bool = False

    def channels(self) -> tuple[str, ...]:
        """The render channels it needs."""
        out = []
        for s in self.layout:
            c = s[2:] if s.startswith("1-") else s
            if c != "1" and c not in out:
                out.append(c)
        return tuple(out)

    def samples(self) -> int:
        return sum(3 if s in ("color", "normal") else 1 for s in self.layout)

    def letters(self) -> list[tuple[str, str]]:
        """(sample letter, what it holds) of each sample."""
        names = {1: "Y", 2: "YA", 3: "RGB", 4: "RGBA"}[self.samples()]
        held = []
        for s in self.layout:
            if s == "color":
                held += ["colour red", "colour green", "colour blue"]
            elif s == "normal":
                held += ["normal x (right)", "normal y", "normal z (out)"]
            else:
                held.append(_WHAT[s])
        return list(zip(names, held))


_WHAT = {"roughness": "roughness", "ao": "ambient occlusion", "metallic": "metallic",
         "height": "height", "1-roughness": "smoothness (1 - roughness)", "1": "1 (detail mask: everywhere)"}


@dataclass(frozen=True)
class Engine:
    name: str
    title: str
    normal: str                 #: "opengl" or "directx"
    maps: tuple[MapSpec, ...]
    prefix: str = ""            #: file name prefix (Unreal: "T_")


_BC = ("color",)
#: engine presets by name (docs/bake.md, "Material sets")
ENGINES: dict[str, Engine] = {e.name: e for e in (
    Engine("unreal", "Unreal Engine (Material: Base Color, Normal, packed ORM, Height)", "directx", (
        MapSpec("BC", "Base Color", _BC, srgb=True),
        MapSpec("N", "Normal (texture compression Normalmap)", ("normal",)),
        MapSpec("ORM", "Ambient Occlusion (R), Roughness (G), Metallic (B); sRGB off", ("ao", "roughness", "metallic")),
        MapSpec("H", "Height (displacement, parallax occlusion)", ("height",), 16)), prefix="T_"),
    Engine("unity-hdrp", "Unity HDRP Lit (Base Map, Mask Map, Normal Map, Height Map)", "opengl", (
        MapSpec("BaseColor", "Base Map", _BC, srgb=True),
        MapSpec("MaskMap", "Mask Map: R metallic, G ambient occlusion, B detail mask, A smoothness",
                ("metallic", "ao", "1", "1-roughness")),
        MapSpec("Normal", "Normal Map (Texture Type: Normal map)", ("normal",)),
        MapSpec("Height", "Height Map", ("height",), 16))),
    Engine("unity-urp", "Unity URP Lit (Base Map, Metallic Map with smoothness in alpha, Normal, Occlusion, Height)",
           "opengl", (
               MapSpec("BaseMap", "Base Map", _BC, srgb=True),
               MapSpec("MetallicSmoothness", "Metallic Map (Source: Metallic Alpha): RGB metallic, A smoothness",
                       ("metallic", "metallic", "metallic", "1-roughness")),
               MapSpec("Normal", "Normal Map (Texture Type: Normal map)", ("normal",)),
               MapSpec("Occlusion", "Occlusion Map", ("ao",)),
               MapSpec("Height", "Height Map", ("height",), 16))),
    Engine("godot", "Godot 4 ORMMaterial3D (Albedo, ORM, Normal Map, Height)", "opengl", (
        MapSpec("albedo", "Albedo > Texture", _BC, srgb=True),
        MapSpec("orm", "ORM > Texture: R ambient occlusion, G roughness, B metallic", ("ao", "roughness", "metallic")),
        MapSpec("normal", "Normal Map > Texture", ("normal",)),
        MapSpec("height", "Height > Texture", ("height",), 16))),
    Engine("gltf", "glTF 2.0 metallic-roughness material (.gltf referencing the maps)", "opengl", (
        MapSpec("baseColor", "baseColorTexture", _BC, srgb=True),
        MapSpec("occlusionRoughnessMetallic", "occlusionTexture (R) and metallicRoughnessTexture (G roughness, "
                "B metallic)", ("ao", "roughness", "metallic")),
        MapSpec("normal", "normalTexture", ("normal",)))),
    Engine("blender", "Blender Principled BSDF (Base Color, Roughness, Metallic, Normal Map node, Displacement)",
           "opengl", (
               MapSpec("color", "Base Color (Color Space: sRGB)", _BC, srgb=True),
               MapSpec("roughness", "Roughness (Non-Color)", ("roughness",)),
               MapSpec("metallic", "Metallic (Non-Color)", ("metallic",)),
               MapSpec("normal", "Normal Map node > Normal (Non-Color)", ("normal",), 16),
               MapSpec("height", "Displacement node > Height (Non-Color)", ("height",), 16),
               MapSpec("ao", "ambient occlusion (Non-Color; multiply into Base Color or leave to the renderer)",
                       ("ao",)))),
)}

#: formats a set's maps may be written in (name -> extension): PNG (one file a level) or a GPU
#: texture file holding every level (:func:`gpu_format`)
MAP_FORMATS = {"png": ".png", "dds": ".dds", "ktx2": ".ktx2"}


def gpu_format(m: MapSpec):
    """The texel format of map ``m`` in a ``.dds``/``.ktx2`` set (a cellgl.io.containers.TexFormat):
    colour ``BC7_SRGB``; a normal ``BC5_UNORM`` (x, y); a packed map (ORM, mask, ...) ``BC7_UNORM``
    (linear: its samples are data); one 8-bit sample ``BC4_UNORM``; one 16-bit sample (height)
    ``R16_UNORM``, its bits kept."""
    from cellgl.io.containers import TEX_FORMATS

    if m.srgb:
        name = "BC7_SRGB"
    elif m.layout == ("normal",):
        name = "BC5_UNORM"
    elif m.samples() == 1:
        name = "R16_UNORM" if m.bits == 16 else "BC4_UNORM"
    else:
        name = "BC7_UNORM"
    return TEX_FORMATS[name]


def _engine(name) -> Engine:
    key = str(name).strip().lower()
    if key not in ENGINES:
        raise BakeError(f"--material {name!r}: unknown engine preset; accepted: {', '.join(ENGINES)}")
    return ENGINES[key]


def _size(size) -> tuple[int, int]:
    if isinstance(size, str):
        w, h, d = parse_size(size)
        if d is not None:
            raise BakeError(f"--size {size}: a material set is 2D maps; accepted: W or WxH")
        return w, h
    w, h = (size, size) if isinstance(size, (int, np.integer)) else tuple(size)
    check_size(w, h, None, f"size {w}x{h}")
    return int(w), int(h)


def _file_name(engine: Engine, stem: str, m: MapSpec, ext: str) -> str:
    return f"{engine.prefix}{stem}_{m.suffix}{ext}"


def _tiles(recipe, m: MapSpec, enc: Encoding, plan, bar):
    """``(x0, y0, {enc.channel: samples})`` of map ``m``, row-major tiles, each sample quantised as
    the bake of its channel alone does."""
    from cellgl import recipes

    bits = 8 * enc.dtype.itemsize       # m.bits, or 8 where a block format holds the map
    top = (1 << bits) - 1
    extra = {"samples": plan.samples} if plan.samples != 1 else {}
    for x0, y0, tw, th in plan.tiles():
        res = recipes.render(recipe, plan.width, plan.height, channels=m.channels(), x0=x0, y0=y0,
                             tile_w=tw, tile_h=th, **extra)
        q = {c: encoding_of(c, ".png", bits).encode(res[c]) for c in m.channels()}
        parts = []
        for s in m.layout:
            if s == "1":
                parts.append(np.full((th, tw), top, enc.dtype))
            elif s.startswith("1-"):
                parts.append((top - q[s[2:]].astype(np.int32)).astype(enc.dtype))
            else:
                parts.append(q[s])
        a = parts[0] if len(parts) == 1 else np.dstack(parts)
        bar.step()
        yield x0, y0, {enc.channel: np.ascontiguousarray(a)}


def bake_material(recipe_or_name, directory, engine="gltf", *, size=DEFAULT_SIZE, tileable=None, sets=(),
                  samples=1, map_format="png", mips=False, supercompression=None, progress=True,
                  memory_budget=DEFAULT_BUDGET) -> list[Path]:
    """Bake the material set of an engine preset into ``directory``.

    Parameters
    ----------
    recipe_or_name : Recipe, preset name or recipe JSON path
        A cellular texture recipe (its ``material`` section makes roughness, ao and metallic).
    directory : str or PathLike
        The set's folder: an existing one (files of the same names are replaced) or a new one
        in an existing folder (never its parents).
    engine : str
        One of :data:`ENGINES`: ``unreal``, ``unity-hdrp``, ``unity-urp``, ``godot``, ``gltf``,
        ``blender``.
    size, tileable, sets, samples, memory_budget :
        As :func:`cellgl.bake.core.bake` (2D sizes only).
    map_format : str
        The maps' format, one of :data:`MAP_FORMATS`: ``png`` (the default), ``dds`` or ``ktx2``
        (each map one GPU texture file in its :func:`gpu_format`; not for ``gltf``, whose KTX2
        images need Basis Universal data: KHR_texture_basisu).
    mips : bool
        Also every mip level of every map, each rendered at its own size (:mod:`cellgl.bake.mips`:
        level ``k`` is the set baked at ``ceil(W / 2^k) x ceil(H / 2^k)``, never downsampled), as
        numbered files ``<map>_mip<k>.png`` beside level 0, down to 1 x 1; in a ``.dds``/``.ktx2``
        map, inside the file (level ``k`` ``max(1, floor(W / 2^k))`` wide, as those formats define).
    supercompression : None or "zstd"
        ``ktx2`` only: zstd supercompression of every level (``--zstd``).
    progress : bool
        A progress bar per map on stderr.

    Returns
    -------
    list of pathlib.Path
        The files of the set, maps first (each followed by its levels with ``mips``), then
        ``recipe.json``, the ``.gltf`` (gltf) and ``manifest.json``.

    Raises
    ------
    BakeError (a ValueError)
        Unknown engine (the message lists them) or format, bad size, a PUPs recipe. Nothing
        is written.
    """
    eng = _engine(engine)
    fmt = str(map_format).strip().lower().lstrip(".")
    if fmt not in MAP_FORMATS:
        raise BakeError(f"--material {eng.name}: map format {map_format!r}; accepted: {', '.join(MAP_FORMATS)}")
    ext = MAP_FORMATS[fmt]
    w, h = _size(size)
    _check_gpu(eng, fmt, supercompression, w, h)
    try:
        samples = antialias.check_samples(samples)
        out_dir = check_output_dir(directory)
    except ValueError as exc:
        raise BakeError(str(exc)) from None
    from cellgl.bake.request import check_budget

    memory_budget = check_budget(memory_budget)
    base = load_recipe_sets(recipe_or_name, sets, tileable)
    if getattr(base, "kind", None) == "pups":
        raise BakeError(f"--material {eng.name}: {base.name} is a PUPs recipe, which has no roughness, ao or "
                        "metallic channel; accepted: a cellular texture recipe (cellgl presets)")
    recipe = base.replace(normal_convention=eng.normal)
    stem = "".join(c if c.isalnum() or c in "-_" else "_" for c in base.name) or "material"
    from cellgl.bake.mips import level_path, mip_sizes

    names = [_file_name(eng, stem, m, ext) for m in eng.maps]
    levels = mip_sizes(w, h, rounding="up" if fmt == "png" else "down") if mips else [(w, h)]
    if fmt != "png":
        _check_memory(eng, fmt, levels, memory_budget)
    written = []
    with scratch_dir(out_dir, "frames") as tmp:
        for m, name in zip(eng.maps, names):
            if fmt != "png":
                meta = {"generator": "cellgl", "material": eng.name, "map": m.suffix, "format": gpu_format(m).name,
                        "levels": len(levels), "samples": dict(_stored(m)), "recipe": recipe.to_dict(),
                        "size": [w, h]}
                _write_gpu_map(tmp / name, recipe, m, ext, levels, samples, memory_budget, progress,
                               json.dumps(meta, sort_keys=True), supercompression)
                written.append(name)
                continue
            # (the colour map's encoding is named "color": the writer tags it sRGB, as a colour bake)
            enc = Encoding("color" if m.srgb else m.suffix, m.samples(), np.dtype(np.uint8 if m.bits == 8 else np.uint16))
            for k, (lw, lh) in enumerate(levels):
                file = level_path(name, k).name
                out = Output(out_dir / file, (enc.channel,), (enc,))
                plan = plan_tiles(lw, lh, None, ext, m.channels(), None, memory_budget,
                                  m.samples() * m.bits // 8)
                plan = dataclasses.replace(plan, samples=samples)
                bar = Progress(plan.count, f"baking {file}", progress)
                meta = json.dumps({"generator": "cellgl", "material": eng.name, "map": m.suffix, "level": k,
                                   "samples": dict(m.letters()), "recipe": recipe.to_dict(), "size": [lw, lh]},
                                  sort_keys=True)
                with bar:
                    write_tiles(tmp / file, _tiles(recipe, m, enc, plan, bar), out, ext, plan, meta)
                written.append(file)
        extra = ["recipe.json"]
        (tmp / "recipe.json").write_text(base.to_json())
        if eng.name == "gltf":
            extra.append(f"{stem}.gltf")
            (tmp / extra[-1]).write_text(json.dumps(_gltf(stem, dict(zip((m.suffix for m in eng.maps), names))),
                                                    indent=2) + "\n")
        extra.append("manifest.json")
        command = _command(recipe_or_name, sets, tileable, eng, out_dir, (w, h), samples, fmt, mips,
                           supercompression)
        manifest = _manifest(eng, base, names, extra[:-1], levels, samples, fmt, command)
        (tmp / "manifest.json").write_text(json.dumps(manifest, indent=2) + "\n")
        return _move_into_place(tmp, out_dir, written + extra)


def _check_gpu(eng: Engine, fmt: str, supercompression, w: int, h: int) -> None:
    """Refusals of a ``.dds``/``.ktx2`` set (and ``--zstd``), before any work."""
    from cellgl.io import gpu_textures
    from cellgl.io import blocks

    if supercompression not in (None, "zstd"):
        raise BakeError(f"supercompression {supercompression!r}: accepted 'zstd' (or none)")
    if supercompression and fmt != "ktx2":
        raise BakeError(f"--zstd with --map-format {fmt}: zstd supercompression is a KTX2 feature; "
                        f"accepted with --map-format ktx2")
    if fmt == "png":
        return
    if eng.name == "gltf":
        raise BakeError(f"--material gltf --map-format {fmt}: a glTF 2.0 image is PNG or JPEG; KTX2 only "
                        f"through KHR_texture_basisu, which holds Basis Universal (ETC1S/UASTC) data, not "
                        f"the BCn blocks cellgl writes (DDS only through MSFT_texture_dds); accepted for "
                        f"gltf: --map-format png")
    if max(w, h) > gpu_textures.MAX_SIDE_2D:
        raise BakeError(f"size {w}x{h} for {fmt}: a 2D texture's sides are at most {gpu_textures.MAX_SIDE_2D} "
                        f"(the GPUs' limit); accepted 1..{gpu_textures.MAX_SIDE_2D}")
    if not blocks.have_encoder():
        raise BakeError(f"--map-format {fmt} needs the 'etcpak' package (block encoding): pip install "
                        f"'cellgl[gpu]' (or --map-format png)")
    if supercompression:
        try:
            import zstandard  # noqa: F401
        except ImportError:
            raise BakeError("--zstd needs the 'zstandard' package: pip install zstandard") from None


def _check_memory(eng: Engine, fmt: str, levels, budget: int) -> None:
    """A ``.dds``/``.ktx2`` map holds every level's packed samples and its file's bytes at once
    (one map at a time): refused beyond ``budget``, as a ``.dds``/``.ktx2`` bake is."""
    from cellgl.io.containers import level_bytes

    def need(m: MapSpec) -> int:
        tf = gpu_format(m)
        per_texel = m.samples() * (1 if tf.compressed else m.bits // 8)
        return sum(lw * lh * per_texel + level_bytes(tf, lw, lh) for lw, lh in levels)

    worst = max(eng.maps, key=need)
    if need(worst) > budget:
        mb = -(-need(worst) // (1 << 20))
        w, h = levels[0]
        raise BakeError(f"size {w}x{h} to {fmt}: a map ({_file_name(eng, '<name>', worst, '.' + fmt)}) holds "
                        f"its {len(levels)} level(s)' samples and its file's bytes, about {mb} MB, more than "
                        f"--memory {budget >> 20} MB; accepted --memory {mb} or more, or a smaller --size")


def _stored(m: MapSpec) -> list[tuple[str, str]]:
    """(sample letter, what it holds) of map ``m`` as its GPU format stores it (BC5: x, y only)."""
    if gpu_format(m).name == "BC5_UNORM":
        return [("R", "normal x (right)"), ("G", "normal y")]
    letters = m.letters()
    return [("R", letters[0][1])] if len(letters) == 1 else letters


def _write_gpu_map(path: Path, recipe, m: MapSpec, ext: str, levels, samples: int, budget: int, progress: bool,
                   meta: str, supercompression) -> None:
    """Map ``m`` as one ``.dds``/``.ktx2`` at ``path``: each level the packed map rendered at that
    level's size (the PNG set's samples at that size, 8-bit for block formats), then every
    level's blocks at once on every core (cellgl.io.gpu_textures.packed_levels)."""
    from cellgl.io import gpu_textures

    fmt = gpu_format(m)
    bits = m.bits if not fmt.compressed else 8
    enc = Encoding("color" if m.srgb else m.suffix, m.samples(), np.dtype(np.uint8 if bits == 8 else np.uint16))
    plans = [dataclasses.replace(plan_tiles(lw, lh, None, ".png", m.channels(), None, budget,
                                            m.samples() * bits // 8), samples=samples) for lw, lh in levels]
    images = []
    with Progress(sum(p.count for p in plans), f"baking {path.name} ({len(levels)} level(s))", progress) as bar:
        for plan in plans:
            a = np.empty((plan.height, plan.width) + ((m.samples(),) if m.samples() > 1 else ()), enc.dtype)
            for x0, y0, tile in _tiles(recipe, m, enc, plan, bar):
                t = tile[enc.channel]
                a[y0:y0 + t.shape[0], x0:x0 + t.shape[1]] = t
            images.append(a)
    data = gpu_textures.packed_levels(fmt, images)
    del images
    with open(path, "wb") as f:
        gpu_textures.write_container(f, ext, fmt, (levels[0][0], levels[0][1], None), data,
                               supercompression=supercompression, metadata=meta)


def _move_into_place(tmp: Path, out_dir: Path, names: list[str]) -> list[Path]:
    """The finished set: ``tmp`` renamed to a new ``out_dir``, or its files moved into an existing
    one (all or, if a move fails, none: those done are moved back)."""
    umask = os.umask(0)
    os.umask(umask)
    for n in names:
        os.chmod(tmp / n, 0o666 & ~umask)
    if not out_dir.exists():
        os.chmod(tmp, 0o777 & ~umask)
        os.rename(tmp, out_dir)
        return [out_dir / n for n in names]
    done = []
    try:
        with commit_lock([out_dir]):
            for n in names:
                os.replace(tmp / n, out_dir / n)
                done.append(n)
    except BaseException:
        for n in reversed(done):
            try:
                os.replace(out_dir / n, tmp / n)
            except OSError:
                pass
        raise
    return [out_dir / n for n in names]


def _command(recipe_or_name, sets, tileable, eng: Engine, out_dir: Path, size, samples, fmt, mips,
             supercompression=None) -> str:
    """The command line that bakes the set again (the recipe by its name or path; a recipe given
    as an object by the set's own recipe.json, its --set already applied)."""
    if isinstance(recipe_or_name, (str, os.PathLike)):
        words = ["cellgl", "bake", str(recipe_or_name)]
        words += [f"--set={s}" for s in sets]
        words += ["--tileable"] if tileable else []
    else:
        words = ["cellgl", "bake", str(out_dir / "recipe.json")]
    words += ["--material", eng.name, "-o", str(out_dir), "--size", f"{size[0]}x{size[1]}"]
    words += ["--samples", str(samples)] if samples != 1 else []
    words += ["--map-format", fmt] if fmt != "png" else []
    words += ["--mips"] if mips else []
    words += ["--zstd"] if supercompression else []
    return " ".join(shlex.quote(w) for w in words)


def _manifest(eng: Engine, recipe, names, extra, levels, samples, fmt, command) -> dict:
    from cellgl._version import __version__
    from cellgl.bake.mips import level_path

    files = []
    for m, name in zip(eng.maps, names):
        if fmt == "png":
            mip = {"mips": [{"level": k, "file": level_path(name, k).name, "size": list(s)}
                            for k, s in enumerate(levels)]} if len(levels) > 1 else {}
            bits, letters = m.bits, m.letters()
            space = "sRGB (tagged: PNG sRGB chunk)" if m.srgb else "linear (data, not colour; untagged)"
        else:
            tf = gpu_format(m)
            mip = {"texel_format": tf.name, "levels": [{"level": k, "size": list(s)} for k, s in enumerate(levels)]}
            bits, letters = (8 if tf.compressed else m.bits), _stored(m)
            tag = " (KTX2 transfer function sRGB)" if fmt == "ktx2" else ""
            space = (f"sRGB ({tf.name}{tag})" if m.srgb else
                     f"linear (data, not colour; {tf.name}{' (KTX2 transfer function linear)' if tag else ''})")
            if tf.name == "BC5_UNORM":
                mip["note"] = "BC5 stores x and y; z = sqrt(1 - x^2 - y^2) (the engines' normal-map sampling rebuilds it)"
        files.append({
            "file": name, "slot": m.slot, "format": fmt.upper(), "bit_depth": bits,
            "color_space": space,
            "channels": dict(letters),
            **({"normal_convention": eng.normal + (" (green down)" if eng.normal == "directx" else " (green up)")}
               if "normal" in m.layout else {}),
            "made_of": list(m.channels()),
            **mip,
        })
    notes = {"recipe.json": "the recipe the maps were baked from (cellgl recipe JSON)",
             "manifest.json": "this file"}
    for n in extra:
        files.append({"file": n, "what": notes.get(n, "glTF 2.0 file: a quad whose material references the maps")})
    files.append({"file": "manifest.json", "what": notes["manifest.json"]})
    return {"generator": f"cellgl {__version__}", "material": eng.name, "engine": eng.title,
            "normal_convention": eng.normal, "size": list(levels[0]), "samples_per_pixel": samples,
            "files": files, "recipe": recipe.to_dict(), "command": command,
            "exact": "each sample of a packed map equals the bake of its channel alone "
                     "(smoothness: the top value minus the quantised roughness)"
                     + ("" if fmt == "png" else "; in the block formats, before block encoding (BCn is lossy)")}


def _gltf(stem: str, maps: dict[str, str]) -> dict:
    """A glTF 2.0 document: one quad (1 x 1, facing +Z, uv (0, 0) at its top left, tangents along
    +u) with a metallic-roughness material whose textures are the set's maps."""
    pos = np.array([[-0.5, -0.5, 0], [0.5, -0.5, 0], [0.5, 0.5, 0], [-0.5, 0.5, 0]], np.float32)
    nrm = np.tile(np.array([0, 0, 1], np.float32), (4, 1))
    tan = np.tile(np.array([1, 0, 0, 1], np.float32), (4, 1))
    uv = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], np.float32)
    idx = np.array([0, 1, 2, 0, 2, 3], np.uint16)
    blobs = [pos.tobytes(), nrm.tobytes(), tan.tobytes(), uv.tobytes(), idx.tobytes() + b"\0\0"]
    views, offset = [], 0
    for i, b in enumerate(blobs):
        views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(b) - (2 if i == 4 else 0),
                      "target": 34963 if i == 4 else 34962})
        offset += len(b)
    data = b"".join(blobs)
    acc = [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
            "min": pos.min(0).tolist(), "max": pos.max(0).tolist()},
           {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
           {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC4"},
           {"bufferView": 3, "componentType": 5126, "count": 4, "type": "VEC2"},
           {"bufferView": 4, "componentType": 5123, "count": 6, "type": "SCALAR"}]
    order = ("baseColor", "occlusionRoughnessMetallic", "normal")
    return {
        "asset": {"version": "2.0", "generator": "cellgl"},
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0, "name": stem}],
        "meshes": [{"name": stem, "primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TANGENT": 2,
                                                                 "TEXCOORD_0": 3}, "indices": 4, "material": 0}]}],
        "materials": [{"name": stem, "pbrMetallicRoughness": {
            "baseColorTexture": {"index": 0}, "metallicRoughnessTexture": {"index": 1},
            "metallicFactor": 1.0, "roughnessFactor": 1.0},
            "occlusionTexture": {"index": 1}, "normalTexture": {"index": 2}}],
        "textures": [{"source": i, "sampler": 0} for i in range(3)],
        "images": [{"uri": maps[k], "mimeType": "image/png"} for k in order],
        "samplers": [{"magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497}],
        "buffers": [{"byteLength": len(data),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode("ascii")}],
        "bufferViews": views, "accessors": acc,
    }
