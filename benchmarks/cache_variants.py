#!/usr/bin/env python
"""Why no cell cache pays on llvmpipe: variants of the grid's cell source against no cache.

Each variant is this checkout's ``cellgl/`` and ``shaders/`` copied into a temporary directory and
patched as text (the patches are below, each a list of (file, old, new); a patch whose ``old``
text is missing stops the run with the variant's name: the shader changed under it). A worker
process per variant (``PYTHONPATH`` the copy) times ``cellular_grid`` F1 + F2, ``jitter``, on
bench_vs_fnl.py's 1024^2 grid slice of [0, 64)^2, with the variant's cache and without any
(``CELLGL_CELL_CACHE`` 0), alternately round by round, and the table gives the median of the
per-round ratios of the process CPU time (with / without; above 1: the variant is slower).

    python benchmarks/cache_variants.py [--rounds 5] [--dims 3 2] [--only TEXT ...]

The variants (docs/performance.md, "Why no cache pays on llvmpipe"):

* the workgroup cache in shared memory as built (``CELLGL_CELL_CACHE=1``); without its per-visit
  fallback to hashing; with one ``vec4`` a point (the ID's bits in w) and no count read; with one
  ``uint`` a cell (its hash word); that fill and barrier alone;
* a subgroup source (GL_ARB_shader_ballot): the 8 lanes of a SIMD vector hash the cells of rings 0
  and 1 around all of them together (4 x 3^(d-1) cells, one per lane and round) and each lane reads
  its point from the lane that holds it (``readInvocationARB``, a constant lane); with the
  fallback, without, with one candidate lane, and with free reads (the bound). It assumes
  llvmpipe's 8-lane subgroups (256-bit SIMD), checked at run time.

The patched copies exist only for the run; the variants that drop the fallback are exact only on
grids like this one (every read inside the block) and are not a product.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile

_REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
COMP = "shaders/cellular.comp"
GPU = "cellgl/basis/gpu.py"

_NO_FALLBACK = (COMP, """bool cell_shared_on()
{
    return cell_cache_fits;
}""", """bool cell_shared_on()
{
    return true;                // the host proves every read is in the block
}""")
_ONE_COUNT = (COMP, """    count = s_cell_count[slot];
    return slot;""", """    count = 1;                  // jitter: one point a cell
    return slot;""")
_VEC4_POINT = [
    (COMP, """    id = s_cell_id[slot * CELL_CACHE_POINTS + k];
    return s_cell_q[slot * CELL_CACHE_POINTS + k];""", """    vec4 v = s_cell_q[slot * CELL_CACHE_POINTS + k];
    id = floatBitsToUint(v.w);
    return vec4(v.xyz, 0.0);"""),
    (COMP, """                s_cell_q[t * CELL_CACHE_POINTS + k] = cell_next_point(state, c, p, id);
                s_cell_id[t * CELL_CACHE_POINTS + k] = id;""", """                vec4 q = cell_next_point(state, c, p, id);
                s_cell_q[t * CELL_CACHE_POINTS + k] = vec4(q.xyz, uintBitsToFloat(id));"""),
]
_WORD_CELL = [
    (COMP, """    id = s_cell_id[slot * CELL_CACHE_POINTS + k];
    return s_cell_q[slot * CELL_CACHE_POINTS + k];""", """    uint state = s_cell_id[slot];     // the cell's hash word: its point follows in a few operations
    return cell_next_point(state, ivec4(0), cell_load_params(), id);"""),
    (COMP, """            s_cell_count[t] = count;
            for (int k = 0; k < count; k++) {
                uint id;
                s_cell_q[t * CELL_CACHE_POINTS + k] = cell_next_point(state, c, p, id);
                s_cell_id[t * CELL_CACHE_POINTS + k] = id;
            }""", """            s_cell_id[t] = state;"""),
]
_FILL_ALONE = (COMP, """    return true;                // the host proves every read is in the block""",
               """    return false;               // the fill alone: the search still hashes""")

# The subgroup source: an entry-point cell source (CELL_SHARED_CELLS 2) beside the shared one.
_SG_CODE = """#if CELL_GRID && CELL_SHARED_CELLS == 2
// The subgroup's cell source: the lanes of a SIMD vector hash the cells of rings 0 and 1 around
// all of them, one cell per lane and round; each lane reads its point from the lane holding it.
#define CELL_SG_ROW (CELL_DIM == 2 ? 3 : (CELL_DIM == 3 ? 9 : 27))
#define CELL_SG_CELLS (CELL_SG_NX * CELL_SG_ROW)
#define CELL_SG_ROUNDS ((CELL_SG_CELLS + CELL_SG_SIZE - 1) / CELL_SG_SIZE)
vec4 sg_q[CELL_SG_ROUNDS];
uint sg_id[CELL_SG_ROUNDS];
int sg_dx;
bool sg_on;

bool cell_shared_on()
{
    return sg_on;
}

int cell_shared_open(ivec4 cell, ivec4 o, out int count)
{
    count = 1;
    ivec4 s = o + 1;
#if CELL_DIM == 2
    return s.x * 3 + s.y;
#elif CELL_DIM == 3
    return (s.x * 3 + s.y) * 3 + s.z;
#else
    return ((s.x * 3 + s.y) * 3 + s.z) * 3 + s.w;
#endif
}

vec4 cell_shared_point(int slot, int k, out uint id)
{
    vec4 q = vec4(0.0);
    id = 0u;
    for (int d = 0; d <= CELL_SG_NX - 3; d++) {          // the lane's cell: sg_dx past the first's
        int u = slot + d * CELL_SG_ROW;
        vec4 qd = readInvocationARB(sg_q[u / CELL_SG_SIZE], uint(u % CELL_SG_SIZE));
        uint idd = readInvocationARB(sg_id[u / CELL_SG_SIZE], uint(u % CELL_SG_SIZE));
        if (sg_dx == d) {
            q = qd;
            id = idd;
        }
    }
    return q;
}

void cell_sg_fill(ivec4 cell, CellParams p)
{
    ivec4 c0 = readFirstInvocationARB(cell);
    sg_dx = cell.x - c0.x;
    sg_on = allInvocationsARB(all(equal(cell.yzw, c0.yzw)) && sg_dx >= 0 && sg_dx <= CELL_SG_NX - 3)
            && gl_SubGroupSizeARB == uint(CELL_SG_SIZE);
    if (sg_on) {
        ivec4 lo = c0 - _cell_axes;
        int lane = int(gl_SubGroupInvocationARB);
        for (int r = 0; r < CELL_SG_ROUNDS; r++) {
            int t = min(lane + r * CELL_SG_SIZE, CELL_SG_CELLS - 1);
            ivec4 o = ivec4(t / CELL_SG_ROW, 0, 0, 0);
#if CELL_DIM == 2
            o.y = t % 3;
#elif CELL_DIM == 3
            o.yz = ivec2(t / 3 % 3, t % 3);
#else
            o.yzw = ivec3(t / 9 % 3, t / 3 % 3, t % 3);
#endif
            ivec4 c;
            uint state;
            _cell_open(lo, o, p, c, state);
            sg_q[r] = cell_next_point(state, c, p, sg_id[r]);
        }
    }
}
#endif

void main()
{"""
_SUBGROUP = [
    (COMP, "#version 430\n", "#version 430\n#if CELL_GRID && CELL_SHARED_CELLS == 2\n"
     "#extension GL_ARB_shader_ballot : require\n#extension GL_ARB_shader_group_vote : require\n#endif\n"),
    (COMP, "#if CELL_GRID && CELL_SHARED_CELLS\n", "#if CELL_GRID && CELL_SHARED_CELLS == 1\n"),
    (COMP, "void main()\n{", _SG_CODE),
    (COMP, """#if CELL_SHARED_CELLS
    cell_cache_fill(cell_load_params());      // before any invocation leaves
#endif
    uvec3 g = gl_GlobalInvocationID;
    if (g.x >= uint(u_slab_size.x)) {
        return;
    }
    // Output index within the slab, x fastest.
    uint i = (g.z * uint(u_slab_size.y) + g.y) * uint(u_slab_size.x) + g.x;
    ivec4 idx = ivec4(u_slab.x + int(g.x), u_slab.y + int(g.y), u_slab.z + int(g.z), u_slab.w);
    cell_grid_sample(idx, cell, frac);""", """#if CELL_SHARED_CELLS == 1
    cell_cache_fill(cell_load_params());      // before any invocation leaves
#endif
    uvec3 g = gl_GlobalInvocationID;
    ivec4 idx = ivec4(u_slab.x + int(g.x), u_slab.y + int(g.y), u_slab.z + int(g.z), u_slab.w);
    cell_grid_sample(idx, cell, frac);
#if CELL_SHARED_CELLS == 2
    cell_sg_fill(cell, cell_load_params());   // every lane, before any leaves
#endif
    if (g.x >= uint(u_slab_size.x)) {
        return;
    }
    // Output index within the slab, x fastest.
    uint i = (g.z * uint(u_slab_size.y) + g.y) * uint(u_slab_size.x) + g.x;"""),
    (GPU, """    if os.environ.get("CELLGL_CELL_CACHE", "0") != "1" or p.density_map is not None:""",
     """    if os.environ.get("CELLGL_CELL_CACHE", "0") == "2" and int(p.distribution) == int(Distribution.JITTER):
        return dict(CELL_SHARED_CELLS=2, CELL_SG_SIZE=8, CELL_SG_NX=4)
    if os.environ.get("CELLGL_CELL_CACHE", "0") != "1" or p.density_map is not None:"""),
]
_SG_NO_FALLBACK = (COMP, """bool cell_shared_on()
{
    return sg_on;
}""", """bool cell_shared_on()
{
    return true;                // the host proves every read is in the block
}""")
_SG_FILL_ALWAYS = (COMP, "    if (sg_on) {\n        ivec4 lo = c0 - _cell_axes;", "    {\n        ivec4 lo = c0 - _cell_axes;")
_SG_ONE = (COMP, "    for (int d = 0; d <= CELL_SG_NX - 3; d++) {", "    for (int d = 0; d <= 0; d++) {")
_SG_FREE = (COMP, """        vec4 qd = readInvocationARB(sg_q[u / CELL_SG_SIZE], uint(u % CELL_SG_SIZE));
        uint idd = readInvocationARB(sg_id[u / CELL_SG_SIZE], uint(u % CELL_SG_SIZE));""",
            """        vec4 qd = vec4(0.5);       // the bound: reads cost nothing (wrong points)
        uint idd = uint(u);""")

#: name -> (CELLGL_CELL_CACHE value, patches)
VARIANTS = {
    "shared memory, as built": ("1", []),
    "shared, no fallback": ("1", [_NO_FALLBACK]),
    "shared, no fallback, one vec4 a point": ("1", [_NO_FALLBACK, _ONE_COUNT, *_VEC4_POINT]),
    "shared, no fallback, one uint a cell": ("1", [_NO_FALLBACK, _ONE_COUNT, *_WORD_CELL]),
    "that fill and barrier alone": ("1", [_NO_FALLBACK, _ONE_COUNT, *_WORD_CELL, _FILL_ALONE]),
    "subgroup lanes, with the fallback": ("2", _SUBGROUP),
    "subgroup lanes, no fallback": ("2", [*_SUBGROUP, _SG_NO_FALLBACK, _SG_FILL_ALWAYS]),
    "subgroup lanes, no fallback, one candidate": ("2", [*_SUBGROUP, _SG_NO_FALLBACK, _SG_FILL_ALWAYS, _SG_ONE]),
    "subgroup lanes, free reads (bound)": ("2", [*_SUBGROUP, _SG_NO_FALLBACK, _SG_FILL_ALWAYS, _SG_FREE]),
}

_WORKER = r"""
import json, os, sys, time
import cellgl
assert os.path.dirname(os.path.dirname(os.path.abspath(cellgl.__file__))) == os.getcwd(), cellgl.__file__
dim, cache, rounds = int(sys.argv[1]), sys.argv[2], int(sys.argv[3])
size = 1024
h = 64.0 / size
origin = (h / 2, h / 2) + ((0.37,) if dim == 3 else ())
shape = (size, size) if dim == 2 else (1, size, size)
def call(c):
    os.environ["CELLGL_CELL_CACHE"] = c
    t0 = time.process_time()
    cellgl.cellular_grid(shape, origin=origin, spacing=h, n=2, distribution="jitter", jitter=1.0, outputs=("F",))
    return time.process_time() - t0
call("0"), call(cache)                      # compile both
ratios = []
for r in range(rounds):
    order = ("0", cache) if r % 2 == 0 else (cache, "0")
    t = {c: call(c) for c in order}
    ratios.append(t[cache] / t["0"])
print(json.dumps(ratios))
"""


def build(tmp: str, patches) -> None:
    """This checkout's cellgl/ and shaders/ in tmp, with the patches applied."""
    for part in ("cellgl", "shaders"):
        shutil.copytree(os.path.join(_REPO, part), os.path.join(tmp, part),
                        ignore=shutil.ignore_patterns("__pycache__"))
    for rel, old, new in patches:
        path = os.path.join(tmp, rel)
        with open(path) as fh:
            text = fh.read()
        if old not in text:
            raise SystemExit(f"{rel} changed: a patch's text is not in it ({old.splitlines()[0]!r} ...)")
        with open(path, "w") as fh:
            fh.write(text.replace(old, new, 1))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--dims", type=int, nargs="+", default=[3, 2], choices=(2, 3))
    ap.add_argument("--only", nargs="+", default=[""], metavar="TEXT", help="variants whose name has one of these")
    a = ap.parse_args(argv)
    todo = {k: v for k, v in VARIANTS.items() if any(o in k for o in a.only)}
    load0 = os.getloadavg()[0]
    rows = []
    for name, (cache, patches) in todo.items():
        with tempfile.TemporaryDirectory(prefix="cellgl-variant-") as tmp:
            build(tmp, patches)
            cells = []
            for dim in a.dims:
                out = subprocess.run([sys.executable, "-c", _WORKER, str(dim), cache, str(a.rounds)],
                                     env=dict(os.environ, PYTHONPATH=tmp), cwd=tmp, capture_output=True,
                                     text=True, check=False)
                if out.returncode != 0:
                    raise SystemExit(f"{name}, {dim}D failed:\n{out.stderr[-3000:]}")
                r = json.loads(out.stdout.strip().splitlines()[-1])
                cells.append(f"{statistics.median(r):.2f} ({min(r):.2f}-{max(r):.2f})")
            rows.append((name, cells))
            print(f"{name}: " + ", ".join(f"{d}D {c}" for d, c in zip(a.dims, cells)), file=sys.stderr, flush=True)
    print(f"F1 + F2, jitter, 1024^2 grid slice; CPU time with the variant / without a cache, median of "
          f"{a.rounds} alternating rounds (min-max); load {load0:.1f} -> {os.getloadavg()[0]:.1f} (1 min)")
    print("| cell source | " + " | ".join(f"{d}D" for d in a.dims) + " |")
    print("| --- | " + " | ".join("---:" for _ in a.dims) + " |")
    for name, cells in rows:
        print(f"| {name} | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
