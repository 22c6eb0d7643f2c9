"""Measure and show the antialiasing of fractal presets (docs/antialias.md).

Usage: python docs/make_antialias.py [--size 128] [--reference 1024] [--samples 4] [--no-images] [names...]

For each preset, the colour of a ``size``^2 bake is compared with a ``reference``^2 bake box-filtered
down to ``size``^2 (the average of each ``reference/size``-square block: what a perfectly filtered
small bake shows). Printed: the RMS difference (colour in [0, 1], over RGB) of

* ``off``: point samples, as before the band limit (``--set antialias=0``);
* ``band``: band-limited fractal octaves (the default, ``antialias = 1``);
* ``ss``: point samples, ``--samples`` sub-pixels per pixel (supersampling alone);
* ``band+ss``: band-limited and ``--samples`` sub-pixels per pixel;

the reference itself with and without the band limit (``ref change``: RMS between the two
``reference``^2 bakes: the look of a large bake is unchanged), and writes side-by-side images to
``docs/antialias/<name>.png``: the box-filtered reference, off, band, band+ss (each upscaled 2x,
nearest).
"""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import cellgl  # noqa: E402
from cellgl.recipes import load_recipe  # noqa: E402

HERE = Path(__file__).resolve().parent
PRESETS = ("qin-cloud", "hide", "crumple", "rock", "qin-wrinkle")


def box(a: np.ndarray, k: int) -> np.ndarray:
    """Average k x k blocks of an (H, W, C) image (float64)."""
    h, w = a.shape[0] // k, a.shape[1] // k
    return a[: h * k, : w * k].reshape(h, k, w, k, -1).astype(np.float64).mean(axis=(1, 3))


def rms(a, b) -> float:
    return float(np.sqrt(np.mean((np.asarray(a, np.float64) - np.asarray(b, np.float64)) ** 2)))


def color(recipe, size, **kw) -> np.ndarray:
    return cellgl.render(recipe, size, size, **kw)["color"][..., :3]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("names", nargs="*", default=list(PRESETS))
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--reference", type=int, default=1024)
    ap.add_argument("--samples", type=int, default=4)
    ap.add_argument("--no-images", action="store_true")
    args = ap.parse_args(argv)
    k = args.reference // args.size
    out_dir = HERE / "antialias"
    print(f"# {args.size}^2 vs {args.reference}^2 box-filtered by {k}; load {os.getloadavg()[0]:.2f}")
    print(f"| preset | RMS off | RMS band | RMS ss{args.samples} | RMS band+ss{args.samples} | off / band | "
          f"off / ss | off / band+ss | ref change |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for name in args.names:
        r = load_recipe(name)
        off_r = r.replace(antialias=0.0)
        ref_on = color(r, args.reference)
        ref_off = color(off_r, args.reference)
        target = box(ref_on, k)
        off = color(off_r, args.size)
        band = color(r, args.size)
        ss = color(r, args.size, samples=args.samples)
        e_off, e_band, e_ss = rms(off, target), rms(band, target), rms(ss, target)
        e_pss = rms(color(off_r, args.size, samples=args.samples), target)
        print(f"| {name} | {e_off:.4f} | {e_band:.4f} | {e_pss:.4f} | {e_ss:.4f} | {e_off / e_band:.2f} | "
              f"{e_off / e_pss:.2f} | {e_off / e_ss:.2f} | {rms(ref_on, ref_off):.4f} |", flush=True)
        if not args.no_images:
            from PIL import Image

            out_dir.mkdir(exist_ok=True)
            tiles = [target, off, band, ss]
            gap = 4
            s = args.size * 2
            sheet = np.ones((s, 4 * s + 3 * gap, 3))
            for i, t in enumerate(tiles):
                sheet[:, i * (s + gap): i * (s + gap) + s] = np.repeat(np.repeat(t, 2, 0), 2, 1)
            Image.fromarray((np.clip(sheet, 0, 1) * 255 + 0.5).astype(np.uint8)).save(out_dir / f"{name}.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
