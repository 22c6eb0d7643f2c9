"""``cellgl view`` / ``python -m cellgl.viewer``: argument parsing only (no GL or GUI imports here)."""

from __future__ import annotations

import argparse
from collections.abc import Sequence

__all__ = ["add_arguments", "run", "main"]

from .modes import MODES
SHAPES = ("sphere", "torus", "cube", "plane")


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--size {text!r}: expected WIDTHxHEIGHT, e.g. 1280x800") from None
    if not (64 <= w <= 8192 and 64 <= h <= 8192):
        raise argparse.ArgumentTypeError(f"--size {text!r}: each side must be in [64, 8192]")
    return w, h


def _assignment(text: str) -> tuple[str, str]:
    name, sep, value = text.partition("=")
    if not sep or not name.strip():
        raise argparse.ArgumentTypeError(f"--set {text!r}: expected name=value")
    return name.strip(), value.strip()


def add_arguments(p: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """Declare the viewer's arguments on ``p`` (shared by ``cellgl view`` and ``python -m cellgl.viewer``)."""
    p.add_argument("recipe", nargs="?", default=None, metavar="PRESET_OR_RECIPE",
                   help="preset name or recipe JSON file (default: the first preset)")
    p.add_argument("--mode", choices=MODES, default="2d",
                   help="initial view: 2d texture, 3d lit object, 3x3 tiled, 4D animation "
                        "(default %(default)s)")
    p.add_argument("--shape", choices=SHAPES, default="sphere", help="3D object (default sphere)")
    p.add_argument("--size", type=_size, default=(1280, 800), metavar="WxH",
                   help="window size in pixels (default 1280x800)")
    p.add_argument("--set", dest="sets", type=_assignment, action="append", default=[],
                   metavar="NAME=VALUE", help="override a recipe parameter (repeatable)")
    p.add_argument("--screenshot", metavar="FILE", default=None,
                   help="render --frames frames, save the window to this PNG and exit")
    p.add_argument("--frames", type=int, default=3,
                   help="frames to render before --screenshot (default 3)")
    p.add_argument("--no-panel", action="store_true", help="hide the ImGui panel")
    p.add_argument("--time", type=float, default=None,
                   help="animation time (4th coordinate) for anim mode")
    return p


def run(args: argparse.Namespace) -> int:
    """Open the viewer (or capture a screenshot) as ``args`` says; return the exit status."""
    from .app import Viewer, ViewerOptions

    if args.screenshot:     # before the window opens: the one rule of every command's output
        from cellgl.io.tempfiles import check_output

        check_output(args.screenshot)
    opts = ViewerOptions(
        recipe=args.recipe, mode=args.mode, shape=args.shape, size=args.size,
        sets=list(args.sets), panel=not args.no_panel, time=args.time,
        hidden=args.screenshot is not None,
    )
    try:
        viewer = Viewer(opts)
    except RuntimeError as exc:  # no display / no GL 3.3 window: a user-facing error, not a trace
        import sys

        print(f"cellgl view: error: {exc}", file=sys.stderr)
        return 2
    try:
        if args.screenshot:
            viewer.capture(args.screenshot, frames=max(1, args.frames))
            print(args.screenshot)
        else:
            viewer.run()
    finally:
        viewer.close()
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m cellgl.viewer",
                                description="Interactive cellgl texture viewer.")
    add_arguments(p)
    args = p.parse_args(argv)
    try:
        return run(args)
    except ValueError as exc:
        import sys

        print(f"viewer: error: {exc}", file=sys.stderr)
        return 2
