"""What a docs block wrote, checked (for tests/docs_runner.py): no empty file, images and arrays
that read back, the files its commands name present, no temporary file left behind; and the
windows on an X display, for the blocks that open one; what a console block printed, against
the document."""
from __future__ import annotations

import json
import os
import shlex
from pathlib import Path


def snapshot(folder: Path) -> dict[str, tuple[int, int]]:
    out = {}
    for dirpath, dirnames, filenames in os.walk(folder):
        dirnames[:] = [d for d in dirnames if d not in ("__pycache__", ".git")]
        for f in filenames:
            p = os.path.join(dirpath, f)
            try:
                st = os.lstat(p)
            except OSError:
                continue
            out[os.path.relpath(p, folder)] = (st.st_size, st.st_mtime_ns)
    return out


def _zarr_root(rel: str) -> str | None:
    parts = Path(rel).parts
    for k, part in enumerate(parts):
        if part.endswith(".zarr"):
            return str(Path(*parts[:k + 1]))
    return None


def check_outputs(folder: Path, before: dict, after: dict) -> list[str]:
    """Problems with the files a block wrote (new or changed between the snapshots)."""
    problems = []
    changed = sorted(n for n, st in after.items() if before.get(n) != st)
    zarrs = set()
    for name in changed:
        base = os.path.basename(name)
        if ".cellgl-" in base and base.startswith("."):
            problems.append(f"left a temporary file behind: {name}")
            continue
        z = _zarr_root(name)
        if z:
            zarrs.add(z)
            continue
        if after[name][0] == 0:
            problems.append(f"wrote an empty file: {name}")
            continue
        err = check_file(folder / name)
        if err:
            problems.append(f"{name}: {err}")
    for z in sorted(zarrs):
        err = check_file(folder / z)
        if err:
            problems.append(f"{z}: {err}")
    return problems


def check_file(path: Path) -> str | None:
    """None if ``path`` reads back as what its extension says, else what is wrong."""
    ext = path.suffix.lower()
    try:
        if ext in (".png", ".webp", ".gif", ".jpg", ".jpeg", ".bmp"):
            from PIL import Image

            with Image.open(path) as im:
                for k in range(getattr(im, "n_frames", 1)):
                    im.seek(k)
                    im.load()
                if min(im.size) < 1:
                    return f"image of size {im.size}"
        elif ext in (".tif", ".tiff"):
            import tifffile

            with tifffile.TiffFile(path) as tf:
                if not tf.pages:
                    return "TIFF without pages"
                tf.pages[0].asarray()
        elif ext == ".exr":
            import OpenEXR

            with OpenEXR.File(str(path)) as f:
                channels = f.channels()
                if not channels:
                    return "EXR without channels"
                for ch in channels.values():
                    ch.pixels     # decodes
        elif ext == ".npy":
            import numpy as np

            a = np.load(path, mmap_mode="r")
            if a.size == 0:
                return f"empty array {a.shape}"
            np.asarray(a[(0,) * a.ndim])
        elif ext == ".json":
            json.loads(path.read_text(encoding="utf-8"))
        elif ext == ".zarr":
            import zarr

            g = zarr.open_group(str(path), mode="r")
            if not list(g.array_keys()):
                return "Zarr group without arrays"
        elif ext in (".glsl", ".hlsl", ".wgsl", ".gdshader", ".gdshaderinc", ".ush", ".txt", ".md", ".py"):
            path.read_text(encoding="utf-8")
    except Exception as exc:  # noqa: BLE001 - any failure to read back is the finding
        return f"does not read back as {ext}: {type(exc).__name__}: {exc}"
    return None


def named_outputs(command: str) -> list[str]:
    """The files a shell command says it writes: ``-o FILE``, ``--output FILE``, ``> FILE``
    (``--output`` is the output file in every cellgl command)."""
    try:
        words = shlex.split(command, comments=True)
    except ValueError:
        return []
    out = []
    for k, w in enumerate(words):
        if w in ("-o", "--output", ">", "1>") and k + 1 < len(words):
            out.append(words[k + 1])
        elif w.startswith(">") and len(w) > 1 and not w.startswith(">&") and not w.startswith(">>"):
            out.append(w[1:])
    return [o for o in out if o and not o.startswith("/dev/")]


def missing_outputs(folder: Path, commands: list[str]) -> list[str]:
    missing = []
    for cmd in commands:
        for name in named_outputs(cmd):
            p = folder / name
            if p.exists():
                continue
            stem, ext = os.path.splitext(p.name)
            if p.parent.is_dir() and any(p.parent.glob(f"{stem}_*{ext}")):
                continue       # several channels (<stem>_<channel><ext>) or frames (<stem>_0000<ext>)
            if "<UDIM>" in p.name and p.parent.is_dir() and \
                    any(p.parent.glob(p.name.replace("<UDIM>", "1[01][0-9][0-9]"))):
                continue       # a UDIM set (wall.<UDIM>.tx: wall.1001.tx, ...)
            missing.append(f"{name} (from: {cmd.strip()})")
    return missing


def console_matches(expected: list[str], got: str) -> bool:
    lines = [ln.rstrip() for ln in got.replace("\r\n", "\n").rstrip("\n").split("\n")] if got.strip() else []
    return _match(expected, lines)


def _match(exp: list[str], got: list[str]) -> bool:
    if not exp:
        return not got
    if exp[0] == "...":
        return any(_match(exp[1:], got[k:]) for k in range(len(got) + 1))
    return bool(got) and got[0] == exp[0] and _match(exp[1:], got[1:])


def x11_window_names(display: str) -> list[str] | None:
    """The names (titles) of the windows on X display ``display``, two levels below the root;
    None where libX11 cannot be loaded or the display not opened."""
    import ctypes
    import ctypes.util

    lib = ctypes.util.find_library("X11")
    if not lib:
        return None
    try:
        x = ctypes.CDLL(lib)
    except OSError:
        return None
    ulong, vp = ctypes.c_ulong, ctypes.c_void_p
    x.XOpenDisplay.restype, x.XOpenDisplay.argtypes = vp, [ctypes.c_char_p]
    x.XDefaultRootWindow.restype, x.XDefaultRootWindow.argtypes = ulong, [vp]
    x.XQueryTree.argtypes = [vp, ulong, ctypes.POINTER(ulong), ctypes.POINTER(ulong),
                             ctypes.POINTER(ctypes.POINTER(ulong)), ctypes.POINTER(ctypes.c_uint)]
    x.XFetchName.argtypes = [vp, ulong, ctypes.POINTER(vp)]
    x.XFree.argtypes, x.XCloseDisplay.argtypes = [vp], [vp]
    # a window may vanish while it is walked: Xlib's default error handler would exit the process
    handler = ctypes.CFUNCTYPE(ctypes.c_int, vp, vp)(lambda d, e: 0)
    x.XSetErrorHandler.restype, x.XSetErrorHandler.argtypes = vp, [vp]
    old = x.XSetErrorHandler(ctypes.cast(handler, vp))
    d = x.XOpenDisplay(display.encode())
    if not d:
        x.XSetErrorHandler(old)
        return None
    names: list[str] = []

    def walk(w: int, depth: int) -> None:
        r, parent, children, n = ulong(), ulong(), ctypes.POINTER(ulong)(), ctypes.c_uint()
        if not x.XQueryTree(d, w, ctypes.byref(r), ctypes.byref(parent), ctypes.byref(children), ctypes.byref(n)):
            return
        kids = [children[i] for i in range(n.value)]
        if children:
            x.XFree(ctypes.cast(children, vp))
        for c in kids:
            name = vp()
            if x.XFetchName(d, c, ctypes.byref(name)) and name.value:
                names.append(ctypes.string_at(name.value).decode("utf-8", "replace"))
                x.XFree(name)
            if depth < 1:
                walk(c, depth + 1)

    try:
        walk(x.XDefaultRootWindow(d), 0)
    finally:
        x.XCloseDisplay(d)
        x.XSetErrorHandler(old)
    return names
