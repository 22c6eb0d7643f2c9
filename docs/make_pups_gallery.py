"""Render every PUPs preset to docs/gallery/<name>.png.

Usage: python docs/make_pups_gallery.py [--size 512] [--backend gpu|numpy] [--seed 0] [names...]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from PIL import Image

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from cellgl.pups import pups_render  # noqa: E402
from cellgl.pups.presets import PUPS_PRESETS  # noqa: E402


def to_png(img: np.ndarray, path: Path) -> None:
    a = np.clip(np.nan_to_num(img), 0.0, 1.0)
    Image.fromarray((a * 255 + 0.5).astype(np.uint8)).save(path)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", help="presets to render (default: all)")
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--backend", default="gpu", choices=["gpu", "numpy"])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default=str(Path(__file__).resolve().parent / "gallery"))
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for name in args.names or sorted(PUPS_PRESETS):
        t = time.perf_counter()
        img = pups_render(name, args.size, args.size, seed=args.seed, backend=args.backend)
        to_png(img, out / f"{name}.png")
        print(f"{name:28s} {time.perf_counter() - t:6.2f} s  {img.shape} {img.dtype}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
