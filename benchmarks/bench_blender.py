#!/usr/bin/env python
"""cellgl's Voronoi features side by side with Blender's Voronoi Texture node.

Each case is timed on the same S x S samples (default 1024^2) on both sides, interleaved in one run
(case by case, round by round), and the median of ``--repeats`` rounds is reported:

* Blender: the node's own cost in a Cycles render on the CPU (1 sample, box filter, an orthographic
  camera on a plane whose position feeds the node): the render with the node minus the same render
  with a constant, so the scene setup, the camera rays and the film are not counted.
  Blender runs in a worker process with its own interpreter (bpy 4.5 needs numpy < 2):
  ``$CELLGL_BLENDER_PYTHON`` or ``--blender-python``, else this interpreter.
* cellgl: ``cellgl.cellular_grid`` with distribution ``blender`` (the node's own feature points)
  over the same grid, the whole call (positions, search, read back into NumPy).

Blender's node searches a fixed window of cells (3^d for F1, 5^d around the nearest point for
distance to edge and n-sphere radius, 5^d for smooth F1) and is approximate where that window
misses a point; cellgl's answers are exact (docs/blender.md). Smooth F1 is compared in both of
cellgl's modes: ``polynomial`` (the node's fold over its 5^d window, the node's values) and ``exp``
(log-sum-exp over every point that matters).

    python benchmarks/bench_blender.py [--size 1024] [--repeats 5] [--dims 2 3] [--quick]

``--cache on|off|both``: cellgl's workgroup cell cache of grids (``CELLGL_CELL_CACHE``, off by
default); ``both`` times cellgl both ways against the same node render, round by round.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

_REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if _REPO not in sys.path:
    sys.path.insert(0, _REPO)

SCALE = 16.0       # the node's Scale: cells per unit; the plane spans [-1, 1]^2, 32 cells across
PAUSE = 0.2        # seconds of quiet before each timed call
Z = 0.37           # the plane's height (3D): z * SCALE is not a cell border

# The Blender worker: reads one JSON case per line, renders it, prints the seconds.
_WORKER = r"""
import json, sys, time
import bpy

size = int(sys.argv[1])
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = 1
scene.cycles.use_adaptive_sampling = False
scene.cycles.use_denoising = False
scene.cycles.pixel_filter_type = "BOX"
scene.cycles.filter_width = 0.01
scene.cycles.max_bounces = 0
scene.render.resolution_x = size
scene.render.resolution_y = size
scene.render.resolution_percentage = 100
scene.view_settings.view_transform = "Raw"
bpy.ops.mesh.primitive_plane_add(size=2.0, location=(0.0, 0.0, %(z)r))
plane = bpy.context.active_object
cam_data = bpy.data.cameras.new("cam")
cam_data.type = "ORTHO"
cam_data.ortho_scale = 2.0
cam = bpy.data.objects.new("cam", cam_data)
cam.location = (0.0, 0.0, 5.0)
scene.collection.objects.link(cam)
scene.camera = cam
mat = bpy.data.materials.new("m")
mat.use_nodes = True
plane.data.materials.append(mat)
nt = mat.node_tree
nt.nodes.clear()
out = nt.nodes.new("ShaderNodeOutputMaterial")
emit = nt.nodes.new("ShaderNodeEmission")
nt.links.new(emit.outputs["Emission"], out.inputs["Surface"])
geo = nt.nodes.new("ShaderNodeNewGeometry")
vor = nt.nodes.new("ShaderNodeTexVoronoi")
vor.inputs["Scale"].default_value = %(scale)r
vor.inputs["Randomness"].default_value = 1.0
nt.links.new(geo.outputs["Position"], vor.inputs["Vector"])

vname, ename = vor.name, emit.name

def setup(case):
    # Look the nodes up again: a render can leave the Python wrappers stale.
    nt = bpy.data.materials["m"].node_tree
    vor, emit = nt.nodes[vname], nt.nodes[ename]
    for l in list(emit.inputs["Color"].links) + list(emit.inputs["Strength"].links):
        nt.links.remove(l)
    if case["feature"] == "CONST":
        emit.inputs["Color"].default_value = (0.5, 0.5, 0.5, 1.0)
        return
    vor.voronoi_dimensions = case["dims"]
    vor.feature = case["feature"]
    for sock in vor.inputs:      # by identifier: an unavailable socket is not found by name
        if sock.identifier == "Smoothness":
            sock.default_value = case.get("smoothness", 1.0)
    name = "Radius" if case["feature"] == "N_SPHERE_RADIUS" else "Distance"
    nt.links.new(vor.outputs[name], emit.inputs["Color"])

for line in sys.stdin:
    case = json.loads(line)
    setup(case)
    bpy.ops.render.render(write_still=False)      # compiles the kernel for this graph
    t0 = time.perf_counter()
    bpy.ops.render.render(write_still=False)
    print(json.dumps(time.perf_counter() - t0), flush=True)
"""


class Blender:
    """A worker process running Blender as a module; render(case) -> seconds."""

    def __init__(self, python: str, size: int):
        code = _WORKER % {"z": Z / SCALE, "scale": SCALE}
        self.proc = subprocess.Popen([python, "-c", code, str(size)], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, text=True, bufsize=1)

    def render(self, case: dict) -> float:
        self.proc.stdin.write(json.dumps(case) + "\n")
        while True:
            line = self.proc.stdout.readline()
            if not line:
                raise RuntimeError("the Blender worker stopped")
            try:
                return float(json.loads(line))
            except (ValueError, TypeError):
                continue          # Blender's own output

    def wait_idle(self, timeout: float = 5.0) -> None:
        """Return once the worker has used no CPU for a while (Cycles frees its session and its
        threads spin after the render call returned): its leftovers must not slow the next
        timed call, ours or its own."""
        path = f"/proc/{self.proc.pid}/stat"
        if not os.path.exists(path):
            time.sleep(PAUSE)
            return

        def cpu():
            with open(path) as fh:
                fields = fh.read().rsplit(")", 1)[1].split()
            return int(fields[11]) + int(fields[12])          # utime + stime, clock ticks

        end = time.monotonic() + timeout
        last, still = cpu(), 0
        while time.monotonic() < end and still < 3:
            time.sleep(0.05)
            now = cpu()
            still = still + 1 if now == last else 0
            last = now

    def close(self):
        self.proc.stdin.close()
        self.proc.wait()


def cases(dims, quick):
    """(label, Blender case, cellgl keyword arguments) of every compared feature."""
    out = []
    for d in dims:
        bd = f"{d}D"
        out.append((f"{bd} F1", {"dims": bd, "feature": "F1"}, {"outputs": ("F",)}))
        out.append((f"{bd} distance to edge", {"dims": bd, "feature": "DISTANCE_TO_EDGE"},
                    {"outputs": ("edge",)}))
        out.append((f"{bd} n-sphere radius", {"dims": bd, "feature": "N_SPHERE_RADIUS"},
                    {"outputs": ("nsphere",)}))
        for k in ((0.05, 1.0) if quick else (0.05, 0.25, 0.5, 1.0)):
            out.append((f"{bd} smooth F1 {k:g} polynomial",
                        {"dims": bd, "feature": "SMOOTH_F1", "smoothness": k},
                        {"outputs": ("smooth_F1",), "smooth": "polynomial", "smoothness": k}))
        for k in ((0.05, 0.25) if quick else (0.05, 0.1, 0.25)):
            # exp's k is lattice units; the node's smoothness 2k is the same width (k = s / 2).
            out.append((f"{bd} smooth F1 {k:g} exp",
                        {"dims": bd, "feature": "SMOOTH_F1", "smoothness": min(1.0, 2 * k)},
                        {"outputs": ("smooth_F1",), "smooth": "exp", "smoothness": k}))
    return out


def cellgl_call(size: int, d: int, kw: dict, cache: str | None = None):
    """The cellgl side of a case; cache "0"/"1": CELLGL_CELL_CACHE for the call (None: as set)."""
    import cellgl

    span = 2.0 * SCALE                  # cells across the image, as the Blender plane
    h = span / size
    origin = (-SCALE + h / 2, -SCALE + h / 2) + ((Z,) if d == 3 else ())
    shape = (size, size) if d == 2 else (1, size, size)

    def call():
        old = os.environ.get("CELLGL_CELL_CACHE")
        if cache is not None:
            os.environ["CELLGL_CELL_CACHE"] = cache
        try:
            return cellgl.cellular_grid(shape, origin=origin, spacing=h, n=1, distribution="blender",
                                        jitter=1.0, **kw)
        finally:
            if cache is not None:
                os.environ.pop("CELLGL_CELL_CACHE", None)
                if old is not None:
                    os.environ["CELLGL_CELL_CACHE"] = old

    return call


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--size", type=int, default=1024, help="image side (samples = size^2)")
    ap.add_argument("--repeats", type=int, default=5, help="interleaved rounds (median reported)")
    ap.add_argument("--dims", type=int, nargs="+", default=[2, 3], choices=(2, 3))
    ap.add_argument("--only", nargs="+", default=[""], metavar="TEXT",
                    help="only the cases whose label contains one of these (e.g. '2D distance')")
    ap.add_argument("--quick", action="store_true", help="fewer smoothness values")
    ap.add_argument("--blender-python", default=os.environ.get("CELLGL_BLENDER_PYTHON", sys.executable))
    ap.add_argument("--cache", default="default", choices=("default", "on", "off", "both"),
                    help="cellgl's workgroup cell cache of grids (CELLGL_CELL_CACHE)")
    a = ap.parse_args()
    caches = {"default": [None], "on": ["1"], "off": ["0"], "both": ["0", "1"]}[a.cache]
    todo = [(label + ("" if c is None else f" (cache {'on' if c == '1' else 'off'})"), bcase, kw, c)
            for label, bcase, kw in cases(a.dims, a.quick) if any(o in label for o in a.only)
            for c in caches]
    samples = a.size * a.size
    load0 = os.getloadavg()
    blender = Blender(a.blender_python, a.size)
    calls = {label: cellgl_call(a.size, int(label[0]), kw, c) for label, _, kw, c in todo}
    for label, *_ in todo:
        calls[label]()                                   # compile cellgl's shaders
    times = {label: {"blender": [], "const": [], "cellgl": []} for label, *_ in todo}
    try:
        for rnd in range(a.repeats):
            for label, bcase, _, _ in todo:
                t = times[label]
                # A pause before each timed call: the other side's worker threads (Cycles' task
                # pool spins a while after a render) must not eat into it.
                time.sleep(PAUSE)
                t["const"].append(blender.render({"feature": "CONST"}))
                blender.wait_idle()
                t["blender"].append(blender.render(bcase))
                blender.wait_idle()
                time.sleep(PAUSE)
                t0 = time.perf_counter()
                calls[label]()
                t["cellgl"].append(time.perf_counter() - t0)
            print(f"round {rnd + 1}/{a.repeats} done, load {os.getloadavg()[0]:.1f}", file=sys.stderr)
    finally:
        blender.close()
    load1 = os.getloadavg()
    print(f"{samples} samples ({a.size}^2), median of {a.repeats} interleaved rounds; "
          f"load {load0[0]:.1f} -> {load1[0]:.1f} (1 min), {os.cpu_count()} cores")
    print("| case | Blender node Ms/s | cellgl Ms/s | cellgl / Blender |")
    print("| --- | ---: | ---: | ---: |")
    for label, *_ in todo:
        t = times[label]
        node = [b - c for b, c in zip(t["blender"], t["const"])]
        # per round ratio, then the median of the ratios (robust to load drifting between rounds)
        ratios = [n / g for n, g in zip(node, t["cellgl"]) if n > 0]
        mn = statistics.median(node)
        mg = statistics.median(t["cellgl"])
        rate_b = samples / mn / 1e6 if mn > 0 else float("inf")
        ratio = statistics.median(ratios) if ratios else float("nan")
        print(f"| {label} | {rate_b:.2f} | {samples / mg / 1e6:.2f} | {ratio:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
