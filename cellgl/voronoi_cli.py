"""``cellgl voronoi``: Blender's Voronoi node (:func:`cellgl.voronoi`) over the unit square, to an
image or an array.

Pixel ``(row, column)`` of a W x H image samples the node's Vector at the pixel centre
``((column + 0.5) / W, 1 - (row + 0.5) / H, z)`` (y up, as a texture), W at ``--w``.

    cellgl voronoi -o cells.png --size 512 --dimensions 2 --feature F1 --output color
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

OUTPUTS = ("distance", "color", "position", "w", "radius")


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    from cellgl.basis.voronoi import FEATURES

    p = sub.add_parser("voronoi", help="Blender's Voronoi node, socket for socket, to a PNG or .npy",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("-o", "--output-file", required=True, metavar="FILE",
                   help=".png (distance, w, radius: 16-bit gray clipped to [0, 1]; color, position: "
                        "8-bit RGB clipped) or .npy (float32, the output as it is)")
    p.add_argument("--size", type=int, nargs="+", default=[512], metavar="N",
                   help="width [height] in pixels (default 512)")
    p.add_argument("--output", choices=OUTPUTS, default=None,
                   help="which socket (default: distance, or radius for n_sphere_radius)")
    p.add_argument("--dimensions", type=int, choices=(1, 2, 3, 4), default=3)
    p.add_argument("--feature", choices=FEATURES, default="F1")
    p.add_argument("--metric", default="euclidean",
                   help="euclidean, manhattan, chebyshev or minkowski")
    for name, default in (("exponent", 0.5), ("scale", 5.0), ("detail", 0.0), ("roughness", 0.5),
                          ("lacunarity", 2.0), ("randomness", 1.0), ("smoothness", 1.0), ("w", 0.0),
                          ("z", 0.0)):
        p.add_argument(f"--{name}", type=float, default=default,
                       help=f"default {default}" + (" (the Vector's z, 3D and 4D)" if name == "z" else ""))
    p.add_argument("--normalize", action="store_true")
    p.add_argument("--distribution", default="blender",
                   help="blender (the node's points, default), poisson, jitter or worley1996")
    p.add_argument("--backend", choices=("gpu", "numpy"), default="gpu")
    return p


def sample_points(width: int, height: int, dimensions: int, z: float, w: float) -> np.ndarray:
    """The sample of every pixel, row-major from the top row: (H * W, d) float64 (1D: u only)."""
    u = (np.arange(width) + 0.5) / width
    v = 1.0 - (np.arange(height) + 0.5) / height
    uu, vv = np.meshgrid(u, v)
    cols = [uu.ravel(), vv.ravel(), np.full(uu.size, z), np.full(uu.size, w)]
    if dimensions == 1:
        return uu.ravel()[:, None]
    return np.stack(cols[:dimensions], axis=1)


def run_cli(args: argparse.Namespace) -> int:
    import cellgl
    from cellgl.io.formats import atomic_path, write_png

    size = list(args.size)
    if len(size) not in (1, 2) or min(size) < 1 or max(size) > 16384:
        raise ValueError(f"--size takes a width and an optional height in 1..16384, got {args.size}")
    width, height = size[0], size[-1]
    path = Path(args.output_file)
    if path.suffix.lower() not in (".png", ".npy"):
        raise ValueError(f"-o {args.output_file}: accepted extensions .png, .npy")
    out = args.output or ("radius" if args.feature == "n_sphere_radius" else "distance")
    pts = sample_points(width, height, args.dimensions, args.z, args.w)
    r = cellgl.voronoi(pts, dimensions=args.dimensions, feature=args.feature, metric=args.metric,
                       exponent=args.exponent, scale=args.scale, detail=args.detail,
                       roughness=args.roughness, lacunarity=args.lacunarity, normalize=args.normalize,
                       randomness=args.randomness, smoothness=args.smoothness, w=args.w,
                       distribution=args.distribution, backend=args.backend)
    arr = getattr(r, out)
    if arr is None:
        raise ValueError(f"--output {out}: feature {args.feature!r} in {args.dimensions}D has no such "
                         f"output; it has: {', '.join(o for o in OUTPUTS if getattr(r, o) is not None)}")
    img = arr.reshape((height, width) + arr.shape[1:])
    with atomic_path(path) as tmp:
        if path.suffix.lower() == ".npy":
            np.save(tmp, img.astype(np.float32))
        elif img.ndim == 2:
            write_png(tmp, [np.round(np.clip(img, 0, 1) * 65535).astype(np.uint16)], width, height, 1, 16)
        else:
            rgb = np.zeros((height, width, 3), np.float32)
            rgb[..., : img.shape[2]] = img
            write_png(tmp, [np.round(np.clip(rgb, 0, 1) * 255).astype(np.uint8)], width, height, 3, 8)
    print(f"wrote {path} ({out}, {width}x{height})")
    return 0
