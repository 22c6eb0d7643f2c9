"""What the docs state as fact about the code, checked against the code (issue 42 item 20): the
name of the volume TIFF spool (docs/bake.md) and the size of the ``--basis`` snippets (README)."""
from __future__ import annotations

import itertools
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _doc_pattern(name: str) -> re.Pattern:
    """A documented temporary name (``.x.cellgl-<pid>@<host>.<random>.spool.npy``) as a regex."""
    parts = re.split(r"(<pid>|<host>|<random>)", name)
    sub = {"<pid>": r"\d+", "<host>": r"[A-Za-z0-9-]+", "<random>": r"[0-9a-f]{8}"}
    return re.compile("".join(sub.get(p, re.escape(p)) for p in parts) + r"\Z")


def test_bake_md_names_the_volume_spool_as_the_bake_does(ctx, tmp_path, monkeypatch):
    """A `.tif` volume bake spools through a temporary file named as docs/bake.md says."""
    pytest.importorskip("tifffile")
    from cellgl.bake import core as B

    doc = (ROOT / "docs" / "bake.md").read_text()
    m = re.search(r"the volume TIFF spool\s*\(`([^`]+)`", doc)
    assert m, "docs/bake.md no longer names the volume TIFF spool"
    seen = []
    real = B.cio.scratch_path

    def spy(directory, suffix=""):
        cm = real(directory, suffix)
        path = cm.__enter__()
        seen.append(path)
        return _Wrapped(cm, path)

    monkeypatch.setattr(B.cio, "scratch_path", spy)
    B.bake("f1", tmp_path / "vol.tif", size=(16, 16), depth_slices=2, sets=["dimension=3"], progress=False)
    assert len(seen) == 1 and seen[0].parent == tmp_path, seen
    assert _doc_pattern(m.group(1)).match(seen[0].name), (m.group(1), seen[0].name)
    assert not seen[0].exists()


class _Wrapped:
    def __init__(self, cm, path):
        self.cm, self.path = cm, path

    def __enter__(self):
        return self.path

    def __exit__(self, *exc):
        return self.cm.__exit__(*exc)


def _readme_basis_bounds() -> tuple[int, int, int, int]:
    """README's ``--basis`` sizes: (lo, hi) in every target but OSL, (lo, hi) in OSL."""
    text = " ".join((ROOT / "README.md").read_text().split())
    m = re.search(r"exports one function of the basis alone \((\d+)-(\d+) lines in every target but OSL "
                  r"and (\d+)-(\d+) in OSL, over every basis, dimension, metric and distribution", text)
    assert m, "README no longer states the --basis snippet sizes"
    return tuple(int(g) for g in m.groups())


def _basis_lines(cases) -> dict[str, list[int]]:
    from cellgl.export.basis import basis_export
    from cellgl.export.snippets import ExportError, TARGETS

    out: dict[str, list[int]] = {"osl": [], "other": []}
    for (basis, dim, metric, dist), target in itertools.product(cases, TARGETS):
        try:
            text = basis_export(basis, dim, target, metric=metric, distribution=dist)
        except ExportError as exc:       # edge is Euclidean only
            assert "Euclidean only" in str(exc), exc
            continue
        out["osl" if target == "osl" else "other"].append(len(text.splitlines()))
    return out


def _check_basis_sizes(cases, whole: bool) -> None:
    lo, hi, osl_lo, osl_hi = _readme_basis_bounds()
    got = _basis_lines(cases)
    assert got["other"] and got["osl"]
    assert lo <= min(got["other"]) and max(got["other"]) <= hi, (min(got["other"]), max(got["other"]))
    assert osl_lo <= min(got["osl"]) and max(got["osl"]) <= osl_hi, (min(got["osl"]), max(got["osl"]))
    if whole:   # the README's ranges are the measured ones, not loose bounds
        assert (min(got["other"]), max(got["other"]), min(got["osl"]), max(got["osl"])) == (lo, hi, osl_lo, osl_hi)


def test_readme_basis_sizes_hold_for_the_largest_and_smallest():
    """The README's ``--basis`` sizes hold for the cases that measured largest (3D, Minkowski,
    F1..F3 / F1..F4, poisson and Blender's points) and smallest (2D Manhattan F1, jitter)."""
    cases = [(b, 3, "minkowski", d) for b in ("f1f2f3", "f1f2f3f4") for d in ("poisson", "blender")]
    _check_basis_sizes(cases + [("f1", 2, "manhattan", "jitter")], whole=False)


@pytest.mark.slow
def test_readme_basis_sizes_are_those_of_every_export():
    """Every basis, dimension, metric and distribution in every target (about 1,700 exports)."""
    from cellgl.export.basis import BASES

    cases = list(itertools.product(BASES, (2, 3, 4), ("euclidean", "manhattan", "chebyshev", "minkowski"),
                                   ("poisson", "jitter", "blender")))
    _check_basis_sizes(cases, whole=True)
