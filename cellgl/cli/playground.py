"""``cellgl playground -o DIR``: the static web page that tries every texture preset in the browser
(docs/playground.md; :mod:`cellgl.playground.site` writes it)."""
from __future__ import annotations

import argparse
import sys
import time

__all__ = ["add_parser", "run_cli"]


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    """Declare ``cellgl playground`` on the CLI's subparsers."""
    p = sub.add_parser(
        "playground", help="write a static web page to try every texture preset in the browser",
        description="Write a static site (HTML + JavaScript, no server: open DIR/index.html, also "
        "from file://) with every texture preset, its parameters as sliders, 2D / tiled / animated "
        "views and buttons that copy the snippet or the `cellgl bake` command. See docs/playground.md.")
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="directory to write (created; its parent must exist)")
    p.add_argument("--preset", dest="presets", action="append", default=None, metavar="NAME",
                   help="only these presets or recipe .json files (repeatable; default: every preset)")
    p.add_argument("--no-thumbnails", action="store_true", help="skip rendering the preset thumbnails")
    p.add_argument("--jobs", "-j", type=int, default=None, metavar="N",
                   help="processes exporting the shader variants (default: the CPUs available)")
    p.add_argument("--quiet", "-q", action="store_true", help="no progress lines")
    return p


def run_cli(args: argparse.Namespace) -> int:
    """Run ``cellgl playground``; returns the exit status."""
    from cellgl.io.tempfiles import check_output_dir
    from cellgl.playground.site import build_site

    t0 = time.perf_counter()

    out = check_output_dir(args.output)     # before the work: the one rule of every command
    log = None if args.quiet else (lambda s: print(s, file=sys.stderr))
    if args.jobs is not None and args.jobs < 1:
        raise ValueError(f"--jobs {args.jobs}: accepted: 1 or more processes")
    res = build_site(out, args.presets, thumbs=not args.no_thumbnails, log=log, jobs=args.jobs)
    if not args.quiet:
        for name, why in res["refused"].items():
            print(f"skipped {name}: {why}", file=sys.stderr)
    print(f"wrote {out / 'index.html'}: {len(res['presets'])} presets, {res['variants']} shader variants "
          f"({time.perf_counter() - t0:.1f} s)")
    return 0
