#!/usr/bin/env python
"""The size table of docs/engines.md: lines and bytes of every preset's and every basis
snippet in every target (``cellgl export``), between the markers

    <!-- snippet-sizes:begin --> ... <!-- snippet-sizes:end -->

    python docs/make_snippet_table.py           # rewrite the table in docs/engines.md
    python docs/make_snippet_table.py --check   # exit 1 if the table is not current
"""
from __future__ import annotations

import argparse
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

BEGIN, END = "<!-- snippet-sizes:begin -->", "<!-- snippet-sizes:end -->"
DOC = os.path.join(ROOT, "docs", "engines.md")


def presets() -> list[str]:
    from cellgl.recipes import list_presets, load_recipe

    out = []
    for name, _ in list_presets():
        r = load_recipe(name)
        if getattr(r, "kind", None) == "pups" or r.values["cell_color"] == "image" \
                or r.values["density_map"] == "image":
            continue
        out.append(name)
    return out


def cell(text: str) -> str:
    """One cell: lines / kilobytes."""
    return f"{len(text.splitlines())} / {len(text.encode()) / 1000:.1f}k"


def rows() -> list:
    """(label, make) per row: ``make(target)`` is the snippet's text, None where the target
    refuses it (``--basis`` for OSL)."""
    from cellgl.export import snippets
    from cellgl.export.basis import BASES, basis_export

    def basis(b: str, t: str):
        try:
            return basis_export(b, 3, t)
        except snippets.ExportError:         # --basis is refused for some targets (OSL)
            return None

    out = [(name, lambda t, name=name: snippets.export(name, t)) for name in presets()]
    out += [(f"`--basis {b} --dim 3`", lambda t, b=b: basis(b, t)) for b in BASES]
    return out


def row(make, targets: list[str]) -> list[str]:
    """One row's cells, a target each (tests/test_export_compiler.py checks each row on its own,
    so that pytest -n spreads them)."""
    return ["-" if (text := make(t)) is None else cell(text) for t in targets]


def format_table(labels: list[str], targets: list[str], cells: list[list[str]]) -> str:
    """The Markdown table: a row per label, a column per target."""
    head = "| snippet | " + " | ".join(f"`{t}`" for t in targets) + " |"
    rule = "| --- | " + " | ".join("---:" for _ in targets) + " |"
    body = [f"| {label} | " + " | ".join(r) + " |" for label, r in zip(labels, cells)]
    return "\n".join([head, rule, *body])


def table() -> str:
    from cellgl.export import snippets

    targets = list(snippets.TARGETS)
    made = rows()
    return format_table([label for label, _ in made], targets, [row(make, targets) for _, make in made])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--check", action="store_true", help="only check that the table is current")
    args = ap.parse_args(argv)
    with open(DOC, encoding="utf-8") as f:
        doc = f.read()
    if BEGIN not in doc or END not in doc:
        print(f"{DOC}: markers {BEGIN} / {END} not found", file=sys.stderr)
        return 1
    before, rest = doc.split(BEGIN, 1)
    _, after = rest.split(END, 1)
    new = before + BEGIN + "\n" + table() + "\n" + END + after
    if args.check:
        if new != doc:
            print("docs/engines.md: the snippet size table is out of date; run "
                  "python docs/make_snippet_table.py", file=sys.stderr)
            return 1
        return 0
    if new != doc:
        tmp = DOC + ".tmp"
        with open(tmp, "w", encoding="utf-8", newline="\n") as f:
            f.write(new)
        os.replace(tmp, DOC)
    return 0


if __name__ == "__main__":
    sys.exit(main())
