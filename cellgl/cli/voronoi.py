"""``cellgl voronoi``: Blender's Voronoi node (cellgl.voronoi) over the unit square, to an image
or an array. The help text is plain text built from the tables in cellgl.basis (docs/blender.md)."""
from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

#: the node's output sockets, in the order of its panel
SOCKETS = ("distance", "color", "position", "w", "radius")

_DESCRIPTION = """\
Blender's Voronoi Texture node, socket for socket, over the unit square.

Pixel (row, column) of a W x H image samples the node's Vector at the pixel centre
((column + 0.5) / W, 1 - (row + 0.5) / H, z): y up, as a texture; W at --w. In 1D the
node's only input is W: column c samples W = --w + (c + 0.5) / W (every row the same), so
--w moves the strip along the 1D axis.

example:
  cellgl voronoi -o cells.png --size 512 --dimensions 2 --feature F1 --socket color
"""

#: the node's float sockets: name -> (default, help); ranges from cellgl.basis.voronoi.RANGES
_FLOATS = {
    "scale": (5.0, "Scale: cells per unit"),
    "detail": (0.0, "Detail: fractal octaves beyond the first"),
    "roughness": (0.5, "Roughness: amplitude ratio of an octave to the one before"),
    "lacunarity": (2.0, "Lacunarity: frequency ratio of an octave to the one before"),
    "randomness": (1.0, "Randomness: spread of the points in their cells"),
    "smoothness": (1.0, "Smoothness of smooth_F1"),
    "exponent": (0.5, "Exponent of the minkowski metric"),
    "w": (0.0, "W: the fourth coordinate (4D); in 1D the W of the left edge (column c samples "
               "W = w + (c + 0.5) / width)"),
    "z": (0.0, "the Vector's z (3D and 4D)"),
}


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    from cellgl.basis.core import BACKENDS
    from cellgl.basis.enums import Distribution, Metric
    from cellgl.basis.voronoi import FEATURES, RANGES

    p = sub.add_parser("voronoi", help="Blender's Voronoi node, socket for socket, to a PNG or .npy",
                       description=_DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("-o", "--output", required=True, metavar="FILE",
                   help=".png (distance, w, radius: 16-bit gray clipped to [0, 1]; color, position: "
                        "8-bit RGB clipped) or .npy (float32, the socket as it is)")
    p.add_argument("--size", default="512", metavar="W[xH]",
                   help="image size in pixels, 1..16384 a side: W (square) or WxH, as in bake "
                        "(default %(default)s)")
    p.add_argument("--socket", choices=SOCKETS, default=None,
                   help="which output socket to write: " + ", ".join(SOCKETS)
                        + " (default: distance, or radius for n_sphere_radius)")
    p.add_argument("--dimensions", type=int, choices=(1, 2, 3, 4), default=3,
                   help="1, 2, 3 or 4 (default %(default)s)")
    p.add_argument("--feature", choices=FEATURES, default="F1",
                   help=", ".join(FEATURES) + " (default %(default)s)")
    metrics = [m.name.lower() for m in Metric]
    p.add_argument("--metric", choices=metrics, default="euclidean",
                   help=", ".join(metrics) + " (default %(default)s)")
    for name, (default, text) in _FLOATS.items():
        lo, hi = RANGES.get(name, (None, None))
        accepted = f", {lo:g}..{hi:g}" if lo is not None else ", any finite number"
        p.add_argument(f"--{name}", type=float, default=default, metavar="X",
                       help=f"{text}{accepted} (default {default:g})")
    p.add_argument("--normalize", action="store_true", help="Normalize: distances in [0, 1]")
    dists = [d.name.lower() for d in Distribution]
    p.add_argument("--distribution", choices=dists, default="blender",
                   help=", ".join(dists) + " (default blender: the node's own points and colours)")
    p.add_argument("--backend", choices=BACKENDS, default="gpu",
                   help=", ".join(BACKENDS) + " (default %(default)s)")
    p.add_argument("--allow-inexact", action="store_true",
                   help="write the image even where the search could not settle a sample (Minkowski "
                        "exponents below 0.443 in 3D, 0.713 in 4D; very sparse points): those pixels "
                        "hold the nearest point within the search cap, not the nearest point. Without "
                        "it such a run is refused and nothing is written")
    return p


def _size(text: str) -> tuple[int, int]:
    """``W`` or ``WxH`` -> (W, H), each in 1..16384."""
    try:
        nums = [int(v) for v in text.lower().split("x")]
    except ValueError:
        nums = []
    if len(nums) not in (1, 2) or min(nums) < 1 or max(nums) > 16384:
        raise ValueError(f"--size {text!r}: accepted W or WxH, whole numbers in 1..16384")
    return nums[0], nums[-1]


def sample_points(width: int, height: int, dimensions: int, z: float, w: float) -> np.ndarray:
    """The sample of every pixel, row-major from the top row: (H * W, d) float64 (1D: the node's
    W, ``w + u``: the image spans W in [w, w + 1])."""
    u = (np.arange(width) + 0.5) / width
    v = 1.0 - (np.arange(height) + 0.5) / height
    uu, vv = np.meshgrid(u, v)
    cols = [uu.ravel(), vv.ravel(), np.full(uu.size, z), np.full(uu.size, w)]
    if dimensions == 1:
        return (uu.ravel() + w)[:, None]
    return np.stack(cols[:dimensions], axis=1)


def run_cli(args: argparse.Namespace) -> int:
    import cellgl
    from cellgl.io.formats import atomic_path, write_png
    from cellgl.io.spec import quantize
    from cellgl.io.tempfiles import check_output

    width, height = _size(args.size)
    path = Path(args.output)
    if path.suffix.lower() not in (".png", ".npy") and not path.is_dir():
        raise ValueError(f"-o {args.output}: accepted extensions .png, .npy")
    check_output(path)                  # a directory, a missing or read-only folder, a long name
    for name in _FLOATS:
        if not math.isfinite(getattr(args, name)):
            raise ValueError(f"--{name} {getattr(args, name)}: accepted a finite number")
    out = args.socket or ("radius" if args.feature == "n_sphere_radius" else "distance")
    from cellgl.basis.reference import minkowski_floor, minkowski_message

    if (args.metric == "minkowski" and args.feature in ("F1", "F2", "smooth_F1") and args.dimensions > 1
            and not args.allow_inexact and args.exponent < minkowski_floor(args.dimensions)):
        raise ValueError(minkowski_message("--exponent", args.exponent, args.dimensions, "--dimensions")
                         + "; or pass --allow-inexact to write the nearest point within that cap")
    pts = sample_points(width, height, args.dimensions, args.z, args.w)
    r = cellgl.voronoi(pts, dimensions=args.dimensions, feature=args.feature, metric=args.metric,
                       exponent=args.exponent, scale=args.scale, detail=args.detail,
                       roughness=args.roughness, lacunarity=args.lacunarity, normalize=args.normalize,
                       randomness=args.randomness, smoothness=args.smoothness, w=args.w,
                       distribution=args.distribution, backend=args.backend,
                       allow_inexact=args.allow_inexact)
    left = int(np.size(r.exact) - np.count_nonzero(r.exact))
    if left and not args.allow_inexact:
        raise ValueError(f"{left} of {np.size(r.exact)} samples could not be computed exactly (their "
                         f"nearest points may lie beyond the rings the search visits); nothing written. "
                         f"Raise the exponent or the density, or pass --allow-inexact to write them anyway")
    arr = getattr(r, out)
    if arr is None:
        raise ValueError(f"--socket {out}: feature {args.feature!r} in {args.dimensions}D has no such "
                         f"output; it has: {', '.join(o for o in SOCKETS if getattr(r, o) is not None)}")
    img = arr.reshape((height, width) + arr.shape[1:])
    with atomic_path(path) as tmp:
        if path.suffix.lower() == ".npy":
            np.save(tmp, img.astype(np.float32))
        elif img.ndim == 2:
            write_png(tmp, [quantize(img, 16)], width, height, 1, 16)
        else:
            rgb = np.zeros((height, width, 3), np.float32)
            rgb[..., : img.shape[2]] = img
            write_png(tmp, [quantize(rgb, 8)], width, height, 3, 8,
                      srgb=out == "color")   # colour is display-encoded; positions are data
    print(f"wrote {path} ({out}, {width}x{height})")
    return 0
