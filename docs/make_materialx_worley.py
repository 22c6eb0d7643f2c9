"""How often MaterialX's own ``worleynoise3d`` (F1, F2; jitter 1) differs from the exact answer.

MaterialX's standard library (1.39) searches a fixed 3 x 3 x 3 window of cells around the
sample's: a feature point outside it is never seen, even when it is nearer. This renders
``worleynoise3d`` (type vector2: F1, F2; style Distance, jitter 1) with MaterialX's own GLSL and
renderer (RenderGlsl: needs an X display, e.g. ``xvfb-run -a``), over slices of 3D space, and
compares it with the exact F1, F2 of the same feature points (MaterialX's hash, one point per
cell: ``cell + cellnoise_vec3(cell)``), found by brute force over every cell within 3 of the
sample's with cellgl's reference distances (:func:`cellgl.basis.reference.distances`); the
script checks that 3 cells suffice (every exact F2 < 2). Prints a Markdown table
(docs/engines.md quotes it).

    xvfb-run -a python docs/make_materialx_worley.py [--size 256] [--slices 8]
"""
from __future__ import annotations

import argparse
import sys

import numpy as np

CELLS = 16.0            # cells across a slice
TOL = 1e-4              # |MaterialX - exact| above this (cells) counts as a difference


def materialx_points(cells: np.ndarray) -> np.ndarray:
    """MaterialX's feature point of each integer cell (N, 3): ``cell + cellnoise_vec3(cell)``
    at jitter 1 (mx_worley_cell_position; float32 arithmetic as its GLSL)."""
    from cellgl.basis.population import jenkins_hash

    c = cells.astype(np.int64)
    words = [(c[:, k] & 0xFFFFFFFF).astype(np.uint64) for k in range(3)]
    off = np.stack([np.float32(jenkins_hash(*words, k).astype(np.float32) / np.float32(4294967295.0))
                    for k in range(3)], -1).astype(np.float32)
    off = (off - np.float32(0.5)) * np.float32(1.0) + np.float32(0.5)
    return (cells.astype(np.float32) + off).astype(np.float64)


def exact_f1f2(p: np.ndarray, reach: int = 3) -> np.ndarray:
    """Exact (F1, F2) at samples ``p`` (N, 3) over MaterialX's points, by brute force over the
    (2 reach + 1)^3 cells around each sample's (cellgl's reference distances)."""
    from cellgl.basis.reference import distances

    r = np.arange(-reach, reach + 1)
    offs = np.stack(np.meshgrid(r, r, r, indexing="ij"), -1).reshape(-1, 3)
    base = np.floor(p).astype(np.int64)
    out = np.empty((len(p), 2))
    for k in range(len(p)):
        cells = base[k] + offs
        d = distances(p[k:k + 1], materialx_points(cells), "euclidean")[0]
        out[k] = np.partition(d, 1)[:2]
    return out


def exact_f1f2_fast(p: np.ndarray, reach: int = 3, chunk: int = 4096) -> np.ndarray:
    """:func:`exact_f1f2`, vectorised in chunks (the same brute force)."""
    r = np.arange(-reach, reach + 1)
    offs = np.stack(np.meshgrid(r, r, r, indexing="ij"), -1).reshape(-1, 3)
    out = np.empty((len(p), 2))
    for s in range(0, len(p), chunk):
        q = p[s:s + chunk]
        cells = (np.floor(q).astype(np.int64)[:, None, :] + offs[None]).reshape(-1, 3)
        pts = materialx_points(cells).reshape(len(q), len(offs), 3)
        d = np.sqrt(((pts - q[:, None, :]) ** 2).sum(-1))
        out[s:s + chunk] = np.partition(d, 1, axis=1)[:, :2]
    return out


def render_worley(size: int, z: float) -> np.ndarray:
    """MaterialX's worleynoise3d (vector2, jitter 1) at (u, v, z) * (CELLS, CELLS, 1) for the
    pixel centres of a size x size quad, rendered by RenderGlsl: (size, size, 2), row 0 at v ~ 0."""
    import MaterialX as mx
    from MaterialX import PyMaterialXGenGlsl as g, PyMaterialXGenShader as mxg
    from MaterialX import PyMaterialXRender as mxr, PyMaterialXRenderGlsl as rg

    lib = mx.createDocument()
    mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), lib)
    doc = mx.createDocument()
    doc.importLibrary(lib)
    ng = doc.addNodeGraph("NG_worley")
    tc = ng.addNode("texcoord", "tc", "vector2")
    sc = ng.addNode("multiply", "sc", "vector2")
    sc.setConnectedNode("in1", tc)
    sc.setInputValue("in2", CELLS)
    sep = ng.addNode("separate2", "sep", "multioutput")
    sep.setConnectedNode("in", sc)
    pos = ng.addNode("combine3", "pos", "vector3")
    for k, o in (("in1", "outx"), ("in2", "outy")):
        pos.addInput(k, "float").setConnectedNode(sep)
        pos.getInput(k).setOutputString(o)
    pos.setInputValue("in3", float(z))
    w = ng.addNode("worleynoise3d", "w", "vector2")
    w.setConnectedNode("position", pos)
    w.setInputValue("jitter", 1.0)
    out = ng.addOutput("out", "vector2")
    out.setConnectedNode(w)
    ok, msg = doc.validate()
    assert ok, msg
    gen = g.GlslShaderGenerator.create()
    ctx = mxg.GenContext(gen)
    ctx.registerSourceCodeSearchPath(mx.getDefaultDataSearchPath())
    shader = gen.generate("worley", out, ctx)
    r = rg.GlslRenderer.create(size, size, mxr.BaseType.FLOAT)
    r.initialize()
    r.setImageHandler(rg.GLTextureHandler.create(mxr.StbImageLoader.create()))
    r.createProgram(shader)
    r.validateInputs()
    r.renderTextureSpace(mx.Vector2(0, 0), mx.Vector2(1, 1))
    return image_array(r.captureImage(None))[..., :2]


def image_array(img) -> np.ndarray:
    """A float MaterialX image as a NumPy copy (height, width, channels); row 0 is the image's
    y = 0 (RenderGlsl: the bottom row, v ~ 0)."""
    import ctypes

    h, w, c = img.getHeight(), img.getWidth(), img.getChannelCount()
    buf = (ctypes.c_float * (h * w * c)).from_address(img.getResourceBuffer())
    return np.ctypeslib.as_array(buf).reshape(h, w, c).copy()


def compare(size: int = 256, slices: int = 8) -> dict:
    """Counts of samples where MaterialX's F1 and F2 differ from the exact ones."""
    n = f1_bad = f2_bad = 0
    f1_max = f2_max = 0.0
    for s in range(slices):
        z = 0.37 + 1.618 * s
        got = render_worley(size, z).reshape(-1, 2)
        c = (np.arange(size) + 0.5) / size
        uu, vv = np.meshgrid(c, c)           # row y of the capture: v = (y + 0.5) / size
        p = np.stack([(uu * CELLS).ravel(), (vv * CELLS).ravel(), np.full(uu.size, z)], -1)
        want = exact_f1f2_fast(p)
        assert want[:, 1].max() < 2.0, "an F2 of 2 cells or more: widen the brute force's reach"
        e = np.abs(got - want)
        n += len(p)
        f1_bad += int((e[:, 0] > TOL).sum())
        f2_bad += int((e[:, 1] > TOL).sum())
        f1_max = max(f1_max, float(e[:, 0].max()))
        f2_max = max(f2_max, float(e[:, 1].max()))
    return dict(samples=n, f1=f1_bad, f2=f2_bad, f1_max=f1_max, f2_max=f2_max)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=256, help="samples per slice side (default %(default)s)")
    ap.add_argument("--slices", type=int, default=8, help="z slices (default %(default)s)")
    a = ap.parse_args(argv)
    import MaterialX as mx

    r = compare(a.size, a.slices)
    n = r["samples"]
    print(f"MaterialX {mx.__version__} worleynoise3d (jitter 1) against the exact F1, F2 of its own points, "
          f"{n} samples ({a.slices} slices of {a.size} x {a.size}, {CELLS:g} cells across):\n")
    print("| value | samples that differ (> 1e-4 cells) | largest difference (cells) |")
    print("| --- | --- | --- |")
    for k in ("f1", "f2"):
        print(f"| {k.upper()} | {r[k]} of {n} ({100.0 * r[k] / n:.3f} %) | {r[k + '_max']:.4f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
