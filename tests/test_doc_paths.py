"""Every module, file and dotted name the documentation puts in code quotes exists: a module move
(issue 47's rooms: cellgl/bake/, cellgl/cli/) cannot leave a doc pointing at a path that is gone.
Placeholders (``NAME``) and the lines that list old paths on purpose are left out."""
from __future__ import annotations

import importlib
import importlib.util
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = sorted([*ROOT.glob("docs/*.md"), ROOT / "README.md", ROOT / "CONTRIBUTING.md"])
FILE = re.compile(r"`((?:cellgl|viewer|shaders|tests|benchmarks|docs)/[A-Za-z0-9_./-]+"
                  r"\.(?:py|glsl|comp|frag|vert|md|json))")
DOTTED = re.compile(r"`(cellgl(?:\.[A-Za-z_][A-Za-z0-9_]*)+)")


def _lines(doc: Path):
    for n, line in enumerate(doc.read_text().splitlines(), 1):
        if "NAME" in line or re.search(r"old (module )?paths?", line, re.I):
            continue
        yield n, line


def _resolves(name: str) -> bool:
    """``name`` is a module, or a module then attributes of it."""
    parts = name.split(".")
    for i in range(len(parts), 0, -1):
        mod = ".".join(parts[:i])
        try:
            found = importlib.util.find_spec(mod) is not None
        except (ImportError, ValueError):
            found = False
        if found:
            obj = importlib.import_module(mod)
            for attr in parts[i:]:
                if not hasattr(obj, attr):
                    return False
                obj = getattr(obj, attr)
            return True
    return False


def missing(doc: Path) -> list[str]:
    out = []
    for n, line in _lines(doc):
        out += [f"{doc.name}:{n}: {p}" for p in FILE.findall(line) if not (ROOT / p).exists()]
        out += [f"{doc.name}:{n}: {d}" for d in DOTTED.findall(line)
                if not d.endswith(".zip") and not _resolves(d)]
    return out


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_the_paths_a_doc_names_exist(doc):
    assert not missing(doc), "named in the docs but not in the tree:\n" + "\n".join(missing(doc))


def test_a_moved_module_is_found(tmp_path):
    """The check can fail: a doc naming the old bake module and a file that is gone."""
    doc = tmp_path / "x.md"
    doc.write_text("Bake with `cellgl.io.bake.bake` (`cellgl/io/bake.py`); `cellgl.bake.bake` is right.\n")
    assert missing(doc) == ["x.md:1: cellgl/io/bake.py", "x.md:1: cellgl.io.bake.bake"]
