"""The set of files of ``cellgl export --target materialx -o DIR`` on disk: it lands whole or
not at all.

What the export owns in ``DIR`` (and nothing else there is read, moved or deleted):

* the documents: the node library, ``cellgl_defs.mtlx`` (the definitions) and one
  implementation document per target, ``cellgl_genglsl_impl.mtlx`` and
  ``cellgl_genosl_impl.mtlx`` (:data:`LIBRARIES`); ``cellgl_materials.mtlx`` and
  ``cellgl_materials.usda``; and ``cellgl_nodes.mtlx``, the one-file library of earlier
  versions, which an export removes (its nodedefs would meet the new ones);
* the code files the previous implementation documents (and a previous ``cellgl_nodes.mtlx``)
  name in their implementations' ``file`` attributes, where they have the form
  ``genglsl/cellgl_<name>.glsl`` or ``genosl/cellgl_<name>.osl`` (so a hand-edited library
  cannot make the export delete a file of any other name), and the code files of the new set;
* the baked maps the previous ``cellgl_materials.mtlx`` names in its image nodes' ``file``
  inputs, where they have the form ``textures/cellgl_<name>_<channel>[.<UDIM>].png``
  (:data:`cellgl.export.materialx_baked.TEXTURE_FILE`; a ``<UDIM>`` name: its tiles), and the
  maps of the new set (``--bake-maps``);
* the folders ``genglsl/``, ``genosl/`` and ``textures/`` are created when missing and removed
  only when the export emptied them.

The new set is written into a hidden temporary folder first (named as
:mod:`cellgl.io.tempfiles` names its temporary folders, so a later run sweeps it if this one is
killed): a new ``DIR`` is that folder, written beside it and renamed onto it; an existing
``DIR`` gets the folder inside it (the same filesystem, even where ``DIR`` is a mount point),
then, holding the folder's commit lock (:func:`cellgl.io.tempfiles.commit_lock`), the previous
set's files are moved aside, the new ones moved in (the code files first, the library last),
and the previous set's files that the new set does not have are deleted with the temporary
folder. Any failure before the end (a full disk, a file in the way, Ctrl-C) moves everything
back: the previous set is untouched, and no file of the new one is left. As for
:func:`cellgl.io.tempfiles.atomic_paths`, only a crash in the middle of the renames (a narrow
window) can leave a mix.
"""
from __future__ import annotations

import contextlib
import os
import re
import shutil
from pathlib import Path

from cellgl.export.snippets import ExportError
from cellgl.io.tempfiles import (check_output_dir, commit_lock, default_mode, naming_destination_in,
                                 scratch_dir)

__all__ = ["DEFS", "IMPLS", "LIBRARIES", "MATERIALS", "USD", "CODE_DIRS", "check_dir", "check_places",
           "previous_set", "write_set"]

#: the node library: the definitions (nodedefs, and the node graphs that implement the
#: single-output variants), then one implementation document per target, as MaterialX's own
#: libraries keep them (``stdlib_defs.mtlx``, ``stdlib_genglsl_impl.mtlx``, ...)
DEFS = "cellgl_defs.mtlx"
IMPLS = {"genglsl": "cellgl_genglsl_impl.mtlx", "genosl": "cellgl_genosl_impl.mtlx"}
LIBRARIES = (DEFS, *IMPLS.values())
#: the one-file library of earlier versions (definitions and implementations together)
LEGACY_LIBRARY = "cellgl_nodes.mtlx"
MATERIALS = "cellgl_materials.mtlx"
USD = "cellgl_materials.usda"
DOCUMENTS = (*LIBRARIES, MATERIALS, USD, LEGACY_LIBRARY)
CODE_DIRS = ("genglsl", "genosl", "textures")
#: a code file of the set, as the library names it
CODE_FILE = re.compile(r"(?:genglsl/cellgl_[A-Za-z0-9_]+\.glsl|genosl/cellgl_[A-Za-z0-9_]+\.osl)")
#: the most of a previous library read to find its code files (the full library is ~50 KiB)
_LIBRARY_MAX = 64 << 20


def check_dir(path) -> Path:
    """``path`` as the output directory: an existing directory, or a new one in an existing,
    writable folder; one clear error otherwise (the messages of every command's output,
    :func:`cellgl.io.tempfiles.check_output_dir`, and for an existing file: give a directory)."""
    p = Path(os.fspath(path))
    if str(os.fspath(path)) and (p.exists() or p.is_symlink()) and not p.is_dir():
        raise ExportError(f"output {str(p)!r} is a file; --target materialx writes a directory of files "
                          "(the node library, the implementations, the materials): give a directory")
    try:
        return check_output_dir(path)
    except ValueError as exc:
        raise ExportError(str(exc)) from None


def previous_set(root: Path) -> set[str]:
    """The files (relative paths) of the set an earlier export wrote in ``root``: the documents
    there, the code files its implementation documents name, the maps its materials name
    (see the module doc)."""
    from xml.etree import ElementTree

    have = {d for d in DOCUMENTS if (root / d).is_file() or (root / d).is_symlink()}
    for name in (*IMPLS.values(), LEGACY_LIBRARY):
        lib = root / name
        try:
            if not lib.is_file() or lib.stat().st_size > _LIBRARY_MAX:
                continue
            tree = ElementTree.parse(lib)
        except (OSError, ElementTree.ParseError, RecursionError, ValueError):
            continue                    # not a library cellgl can read: only the documents
        for el in tree.getroot():
            f = el.get("file")
            if el.tag == "implementation" and f and CODE_FILE.fullmatch(f):
                p = root / f
                if p.is_symlink() or p.is_file():
                    have.add(f)
    return have | _previous_maps(root)


def _previous_maps(root: Path) -> set[str]:
    """The baked maps (``textures/cellgl_<name>_<channel>[.<tile>].png``) that the previous
    ``cellgl_materials.mtlx`` names in its image nodes' ``file`` inputs, those that exist (a
    ``<UDIM>`` name: its tiles 1001..1100)."""
    from xml.etree import ElementTree

    from cellgl.export.materialx_baked import TEXTURE_FILE

    have: set[str] = set()
    doc = root / MATERIALS
    try:
        if not doc.is_file() or doc.stat().st_size > _LIBRARY_MAX:
            return have
        tree = ElementTree.parse(doc)
    except (OSError, ElementTree.ParseError, RecursionError, ValueError):
        return have
    for el in tree.getroot().iter("input"):
        f = el.get("value")
        if el.get("type") != "filename" or not f or not TEXTURE_FILE.fullmatch(f):
            continue
        for rel in ([f.replace("<UDIM>", str(k)) for k in range(1001, 1101)] if "<UDIM>" in f else [f]):
            if (root / rel).is_symlink() or (root / rel).is_file():
                have.add(rel)
    return have


def _fill(folder: Path, files: dict[str, str]) -> None:
    """Write ``files`` under ``folder`` (each flushed to disk)."""
    for rel, text in files.items():
        dest = folder / rel
        dest.parent.mkdir(exist_ok=True)
        if isinstance(text, Path):      # a baked map: copied (streamed) from where it was baked
            with open(text, "rb") as src, open(dest, "wb") as f:
                shutil.copyfileobj(src, f, 1 << 20)
                f.flush()
                os.fsync(f.fileno())
            continue
        with open(dest, "w", encoding="utf-8", newline="\n") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())


def _order(rels) -> list[str]:
    """The order the new files move in: code files and maps, then the USD stage, the materials,
    the implementation documents, the definitions."""
    rank = {USD: 1, MATERIALS: 2, **{i: 3 for i in IMPLS.values()}, DEFS: 4}
    return sorted(rels, key=lambda r: (rank.get(r, 0), r))


def check_places(root: Path, rels=DOCUMENTS) -> None:
    """Refuse, before any work, a set that cannot land: a file where a code folder goes, a
    folder where one of ``rels`` goes."""
    root = Path(root)
    for sub in sorted(({Path(r).parent for r in rels} | {Path(d) for d in CODE_DIRS}) - {Path(".")}):
        p = root / sub
        if (p.exists() or p.is_symlink()) and not p.is_dir():
            raise ExportError(f"output {str(p)!r} is a file, not a directory: the export writes its code files "
                              "into a folder of that name; move the file away")
    for r in rels:
        p = root / r
        if p.is_dir():
            raise ExportError(f"output {str(p)!r} is a directory: the export writes a file of that name; "
                              "move the directory away")


def write_set(files: dict, outdir) -> list[Path]:
    """Write ``{relative path: text, or a file (a Path) to copy}`` as the set of ``outdir``
    (created if missing), whole or not at all, removing the previous set's files that the new
    one has not (the module doc)."""
    root = check_dir(outdir)
    rels = list(files)
    check_places(root, rels)
    if not root.exists():
        with scratch_dir(root, "export") as tmp:
            try:
                _fill(tmp, files)
            except OSError as exc:
                raise naming_destination_in(exc, tmp, root) from None
            os.chmod(tmp, default_mode(0o777))
            with commit_lock([root.parent if str(root.parent) else "."]):
                try:
                    os.rename(tmp, root)
                except OSError:
                    if not root.exists():
                        raise
                    raise ExportError(f"output directory {str(root)!r} was made by another program during the "
                                      "export; nothing was written there: export again") from None
        return [root / r for r in rels]
    with scratch_dir(root / DEFS, "export") as tmp:
        new, aside = tmp / "new", tmp / "old"
        new.mkdir()
        aside.mkdir()
        try:
            _fill(new, files)
        except OSError as exc:
            raise naming_destination_in(exc, new, root) from None
        with commit_lock([root]):       # another export into DIR: one set after the other
            try:
                _swap(root, new, aside, _order(rels), previous_set(root))
            except OSError as exc:      # name the output, not the hidden folder
                raise naming_destination_in(naming_destination_in(exc, new, root), aside, root) from None
    return [root / r for r in rels]


def _swap(root: Path, new: Path, aside: Path, rels: list[str], old: set[str]) -> None:
    """Move the previous set's files (``old``) and whatever the new set replaces into
    ``aside``, then the new set in; on any failure, undo every step."""
    out, moved_in, made = [], [], []
    try:
        for rel in sorted(old | set(rels)):
            src = root / rel
            if src.is_symlink() or src.is_file():
                (aside / rel).parent.mkdir(exist_ok=True)
                os.replace(src, aside / rel)
                out.append(rel)
        for rel in rels:
            dest = root / rel
            if not dest.parent.is_dir():
                dest.parent.mkdir()
                made.append(dest.parent)
            os.replace(new / rel, dest)
            moved_in.append(rel)
    except BaseException:
        for rel in reversed(moved_in):
            with contextlib.suppress(OSError):
                os.replace(root / rel, new / rel)
        for d in reversed(made):
            with contextlib.suppress(OSError):
                d.rmdir()
        for rel in reversed(out):
            with contextlib.suppress(OSError):
                os.replace(aside / rel, root / rel)
        raise
    for sub in {Path(r).parent for r in old} - {Path(r).parent for r in rels} - {Path(".")}:
        with contextlib.suppress(OSError):
            (root / sub).rmdir()        # only an emptied folder goes
